"""The rule registry: every rule is an ID, a one-line purpose, a default severity and a function.

Pair rules get a ``Change`` (both revisions, already paired) and yield ``(location, message,
in_old)``; tree rules get one revision and yield ``(key, location, message)`` for what it holds,
which the runner grades: a key only NEW yields is new damage (an error), a key OLD yields too is
old damage (a warning). The runner adds the rule's ID and severity.
"""

from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, NamedTuple

from erc_codec.schema import Location

from .._finding import Severity

if TYPE_CHECKING:
    from .._model import Revision
    from .._pairing import Change

__all__ = ["RULES", "Rule", "pair_rule", "tree_rule"]

PairCheck = Callable[["Change"], Iterator[tuple[Location, str, bool]]]
TreeCheck = Callable[["Revision", "Change"], Iterator[tuple[str, Location, str]]]


class Rule(NamedTuple):
    id: str
    purpose: str
    severity: Severity
    pair: PairCheck | None = None  # exactly one of pair and tree is set
    tree: TreeCheck | None = None


RULES: dict[str, Rule] = {}


def pair_rule(
    id: str, purpose: str, severity: Severity = "error"
) -> Callable[[PairCheck], PairCheck]:
    """Register a rule comparing OLD with NEW."""

    def register(check: PairCheck) -> PairCheck:
        RULES[id] = Rule(id, purpose, severity, pair=check)
        return check

    return register


def tree_rule(id: str, purpose: str) -> Callable[[TreeCheck], TreeCheck]:
    """Register a rule over one revision (the change gives it the configuration)."""

    def register(check: TreeCheck) -> TreeCheck:
        RULES[id] = Rule(id, purpose, "error", tree=check)
        return check

    return register
