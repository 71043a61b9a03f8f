"""The rule registry: every rule is an ID, a one-line purpose, a default severity and one small
function, registered by the helper that says what the function is handed (buf's pair check
functions): one pair at a time, never the whole change.

- ``field_rule``: each field of each paired message (``FieldPair``: the OLD field and what NEW has
  at its number and under its name);
- ``enum_number_rule``: each number of each paired enum (``NumberPair``: its names before and
  after; aliases make enum values a matter of numbers, not names);
- ``message_rule``: each paired message; ``definition_rule``: each paired message and enum;
  ``deleted_message_rule``: each OLD message NEW no longer has;
- ``tree_rule``: one revision (run on OLD and on NEW: a report whose key OLD has too is old damage,
  a warning; one only NEW has is an error).

A rule function takes its pair and the ``Change`` (both revisions, the configuration, the ledger)
for context and yields ``Report``s; ``run`` adds the rule's ID and severity. A rule never loops over
the tree, loads anything or computes a size: it asks the model. Its docstring is its documentation
(what breaks on the wire, an example before and after, the fix).
"""

from collections.abc import Callable, Iterable, Iterator
from typing import Any, NamedTuple, TypeVar

from erc_codec.schema import Location

from .._finding import Finding, Severity
from .._model import Message, Revision
from .._pairing import Change, EnumPair, FieldPair, MessagePair, NumberPair

__all__ = [
    "RULES",
    "Report",
    "Reports",
    "Rule",
    "definition_rule",
    "deleted_message_rule",
    "enum_number_rule",
    "field_rule",
    "message_rule",
    "run",
    "tree_rule",
]


class Report(NamedTuple):
    """What a rule says about the pair it was handed."""

    location: Location
    message: str
    in_old: bool = False  # the location is in OLD: the element is gone from NEW
    key: str = ""  # a tree rule's name for the damage: OLD reporting the same key makes it old


Reports = Iterator[Report]
_Check = TypeVar("_Check", bound=Callable[..., Reports])
# What each helper's rules are handed (and the change, for context).
_FieldCheck = Callable[[FieldPair, Change], Reports]
_NumberCheck = Callable[[NumberPair, Change], Reports]
_MessageCheck = Callable[[MessagePair, Change], Reports]
_DefinitionCheck = Callable[[MessagePair | EnumPair, Change], Reports]
_DeletedCheck = Callable[[Message, Change], Reports]
_TreeCheck = Callable[[Revision, Change], Reports]


class Rule(NamedTuple):
    id: str
    purpose: str
    severity: Severity  # a tree rule's is "error", a warning where OLD has the damage too
    pairs: str  # what ``check`` is handed: a key of PAIRS, or "tree" (one revision)
    check: Callable[..., Reports]  # (pair, change) or (revision, change); its docstring: the docs


RULES: dict[str, Rule] = {}

# How a change hands out each kind of pair.
PAIRS: dict[str, Callable[[Change], Iterable[Any]]] = {
    "field": Change.fields,
    "enum number": Change.numbers,
    "message": lambda change: change.messages,
    "message or enum": lambda change: [*change.messages, *change.enums],
    "deleted message": lambda change: change.deleted_messages,
}


def _register(id: str, purpose: str, severity: Severity, pairs: str) -> Callable[[_Check], _Check]:
    def register(check: _Check) -> _Check:
        RULES[id] = Rule(id, purpose, severity, pairs, check)
        return check

    return register


def field_rule(
    id: str, purpose: str, severity: Severity = "error"
) -> Callable[[_FieldCheck], _FieldCheck]:
    """Register a rule handed each field of each paired message."""
    return _register(id, purpose, severity, "field")


def enum_number_rule(
    id: str, purpose: str, severity: Severity = "error"
) -> Callable[[_NumberCheck], _NumberCheck]:
    """Register a rule handed each number of each paired enum."""
    return _register(id, purpose, severity, "enum number")


def message_rule(
    id: str, purpose: str, severity: Severity = "error"
) -> Callable[[_MessageCheck], _MessageCheck]:
    """Register a rule handed each paired message."""
    return _register(id, purpose, severity, "message")


def definition_rule(
    id: str, purpose: str, severity: Severity = "error"
) -> Callable[[_DefinitionCheck], _DefinitionCheck]:
    """Register a rule handed each paired message and each paired enum."""
    return _register(id, purpose, severity, "message or enum")


def deleted_message_rule(
    id: str, purpose: str, severity: Severity = "error"
) -> Callable[[_DeletedCheck], _DeletedCheck]:
    """Register a rule handed each OLD message that NEW no longer has (not even renamed)."""
    return _register(id, purpose, severity, "deleted message")


def tree_rule(id: str, purpose: str) -> Callable[[_TreeCheck], _TreeCheck]:
    """Register a rule handed one revision, OLD and then NEW."""
    return _register(id, purpose, "error", "tree")


def run(change: Change) -> list[Finding]:
    """Every finding of every rule the configuration does not ignore, sorted by location."""
    found: list[Finding] = []
    for rule in RULES.values():
        if rule.id in change.config.ignore:
            continue
        if rule.pairs == "tree":
            existing = {report.key for report in rule.check(change.old, change)}
            for report in rule.check(change.new, change):
                severity: Severity = "warning" if report.key in existing else "error"
                found.append(Finding.at(report.location, rule.id, report.message, severity))
            continue
        for pair in PAIRS[rule.pairs](change):
            for report in rule.check(pair, change):
                found.append(
                    Finding.at(
                        report.location, rule.id, report.message, rule.severity, report.in_old
                    )
                )
    if "COMPILE" not in change.config.ignore:
        found += _uncompared(change)
    return sorted(set(found))


def _uncompared(change: Change) -> list[Finding]:
    """``COMPILE``'s word on the change itself: a file OLD could not compile hides every change to
    it, so say so, once per file (a warning located in OLD)."""
    return [
        Finding(
            str(change.old.root / name),
            1,
            1,
            "COMPILE",
            f"OLD's {name} does not compile, so its messages were not compared with NEW's.",
            "warning",
            in_old=True,
        )
        for name in sorted(change.old.tree.failed)
        if name not in change.new.tree.failed
    ]
