"""The rule registry: every rule is an ID, a one-line purpose, a default severity, the categories
it belongs to and one small function, registered by the helper that says what the function is
handed (buf's pair check functions): one pair at a time, never the whole change.

- ``field_rule``: each field (and extension) of each paired message (``FieldPair``: the OLD field
  and what NEW has at its number and under its name);
- ``enum_number_rule``: each number of each paired enum (``NumberPair``: its names before and
  after; aliases make enum values a matter of numbers, not names);
- ``message_rule``: each paired message; ``enum_rule``: each paired enum; ``definition_rule``:
  each paired message and enum; ``deleted_message_rule``: each OLD message NEW no longer has;
- ``method_rule``: each method of each paired service (``MethodPair``);
- ``tree_rule``: one revision (run on OLD and on NEW: a report whose key OLD has too is old damage,
  a warning; one only NEW has is an error);
- ``findings_rule``: what the other rules found, once they all ran (the suppressions that
  silenced none of it).

Before ``findings_rule``s run, a finding ``ignore_only`` names for its path, or an
``erc-lint:ignore`` comment covers (``_suppressions``), is dropped.

Categories select rules as buf's do (``CATEGORIES``; ``use`` and ``except`` in the configuration
name categories or rule IDs): a pair rule is ``WIRE`` (and so ``WIRE_JSON``) unless it says
otherwise, a tree rule ``TREE``, a method rule ``RPC``. ``select`` decides what a run applies, and
how severely: a rule whose ``errors_in`` holds a category the configuration uses is an error.

A rule function takes its pair and the ``Change`` (both revisions, the configuration, the ledger)
for context and yields ``Report``s; ``run`` adds the rule's ID and severity. A rule never loops over
the tree, loads anything or computes a size: it asks the model. Its docstring is its documentation
(what breaks on the wire, an example before and after, the fix).
"""

from collections.abc import Callable, Iterable, Iterator
from typing import Any, NamedTuple, Protocol, TypeVar

from erc_schema import Location

from .._config import Config
from .._errors import ConfigError
from .._finding import Finding, Severity
from .._loader import relative
from .._model import Enum, Field, Message, Revision
from .._pairing import Change, FieldPair, MethodPair, NumberPair, Paired
from .._suggest import did_you_mean
from .._suppressions import Suppression, apply, suppressions

__all__ = [
    "CATEGORIES",
    "DEFAULT_CATEGORIES",
    "RULES",
    "Found",
    "Located",
    "Report",
    "Reports",
    "Rule",
    "definition_rule",
    "deleted_message_rule",
    "enum_number_rule",
    "enum_rule",
    "field_prefix",
    "field_rule",
    "findings_rule",
    "message_rule",
    "method_rule",
    "run",
    "select",
    "tree_rule",
]

# What each category holds, as `erc-lint rules` explains it.
CATEGORIES = {
    "WIRE": "what changes how the binary wire is read (buf's WIRE, and what buf does not see)",
    "WIRE_JSON": "WIRE and protobuf JSON: FIELD_RENAMED and ENUM_VALUE_RENAMED become errors",
    "NANOPB": "what nanopb's generated code and sizes make of a change (options, sizes, budgets)",
    "RPC": "services: what clients and servers of each method send each other",
    "TREE": "one revision on its own: compile errors, names, embedded roots, the ledger",
}
# Without `use`: what an embedded fleet needs, and RPC when either revision declares a service.
DEFAULT_CATEGORIES = ("WIRE", "NANOPB", "TREE")
_WIRE = ("WIRE", "WIRE_JSON")


class Located(Protocol):
    """An element of a revision (a field, a message): a report may be located at it rather than
    at its ``Location``, which is then read only where the report becomes a finding. A tree
    rule's reports on OLD are keys and nothing else: locating them would index their files'
    source info for nothing. test_a_report_at_an_element_is_found_at_its_location holds it to
    the report at the element's location."""

    @property
    def location(self) -> Location: ...


class Report:
    """What a rule says about the pair it was handed."""

    # Plain classes, this and Found: nothing reads one as a tuple, and a NamedTuple class is slow
    # to build at import.
    __slots__ = ("container", "fix", "in_old", "key", "like", "location", "message")

    def __init__(
        self,
        location: Location | Located,
        message: str,
        in_old: bool = False,
        key: str = "",
        fix: str = "",
        container: Location | None = None,
        like: str = "",
    ) -> None:
        self.location = location
        self.message = message
        self.in_old = in_old  # the location is in OLD: the element is gone from NEW
        self.key = key  # a tree rule's name for the damage: OLD reporting it too makes it old
        self.fix = fix  # the short fix ending the finding (reserve 3 or restore the field)
        self.container = container  # in_old: where NEW has the element's container
        self.like = like  # a tree rule's report graded as this rule is (a rename: FIELD_RENAMED)

    def __eq__(self, other: object) -> bool:  # member by member: the tests compare reports
        if not isinstance(other, Report):
            return NotImplemented
        return _members(self) == _members(other)

    def __hash__(self) -> int:
        return hash(_members(self))

    def __repr__(self) -> str:
        members = ", ".join(f"{name}={getattr(self, name)!r}" for name in self.__slots__)
        return f"Report({members})"

    @property
    def where(self) -> Location:
        """Where the finding points: the report's location, or its element's (``Located``)."""
        at = self.location
        return at if isinstance(at, Location) else at.location


Reports = Iterator[Report]
_Check = TypeVar("_Check", bound=Callable[..., Reports])
# What each helper's rules are handed (and the change, for context).
_FieldCheck = Callable[[FieldPair, Change], Reports]
_NumberCheck = Callable[[NumberPair, Change], Reports]
_MessageCheck = Callable[[Paired[Message], Change], Reports]
_EnumCheck = Callable[[Paired[Enum], Change], Reports]
_DefinitionCheck = Callable[[Paired[Any], Change], Reports]  # a message or an enum pair
_DeletedCheck = Callable[[Message, Change], Reports]
_MethodCheck = Callable[[MethodPair, Change], Reports]
_TreeCheck = Callable[[Revision, Change], Reports]
_FindingsCheck = Callable[["Found", Change], Reports]


def _members(report: Report) -> tuple[object, ...]:
    return tuple(getattr(report, name) for name in report.__slots__)


class Found:
    """What a ``findings_rule`` is handed: the suppressions of NEW and those that silenced a
    finding of another rule."""

    __slots__ = ("suppressions", "used")

    def __init__(self, suppressions: list[Suppression], used: set[Suppression]) -> None:
        self.suppressions = suppressions
        self.used = used


class Rule(NamedTuple):
    """One rule of ``erc-lint``, as ``erc-lint rules`` lists it: its ID, one line on what it
    guards, its severity, the pairs it compares, the function that compares them (whose docstring
    is ``rules --explain``), and the categories it belongs to."""

    id: str
    purpose: str
    severity: Severity  # a tree rule's is "error", a warning where OLD has the damage too
    pairs: str  # what ``check`` is handed: a key of PAIRS, or "tree" (one revision)
    check: Callable[..., Reports]  # (pair, change) or (revision, change); its docstring: the docs
    categories: tuple[str, ...] = _WIRE  # keys of CATEGORIES
    errors_in: tuple[str, ...] = ()  # categories whose use makes this rule an error


RULES: dict[str, Rule] = {}

# How a change hands out each kind of pair.
PAIRS: dict[str, Callable[[Change], Iterable[Any]]] = {
    "field": Change.fields,
    "enum number": Change.numbers,
    "message": lambda change: change.messages,
    "enum": lambda change: change.enums,
    "message or enum": lambda change: [*change.messages, *change.enums],
    "deleted message": lambda change: change.deleted_messages,
    "method": Change.methods,
}


def _register(
    id: str,
    purpose: str,
    severity: Severity,
    pairs: str,
    categories: tuple[str, ...],
    errors_in: tuple[str, ...] = (),
) -> Callable[[_Check], _Check]:
    assert set(categories) | set(errors_in) <= set(CATEGORIES), id

    def register(check: _Check) -> _Check:
        RULES[id] = Rule(id, purpose, severity, pairs, check, categories, errors_in)
        return check

    return register


def field_rule(
    id: str,
    purpose: str,
    severity: Severity = "error",
    categories: tuple[str, ...] = _WIRE,
    errors_in: tuple[str, ...] = (),
) -> Callable[[_FieldCheck], _FieldCheck]:
    """Register a rule handed each field (and extension) of each paired message."""
    return _register(id, purpose, severity, "field", categories, errors_in)


def enum_number_rule(
    id: str,
    purpose: str,
    severity: Severity = "error",
    categories: tuple[str, ...] = _WIRE,
    errors_in: tuple[str, ...] = (),
) -> Callable[[_NumberCheck], _NumberCheck]:
    """Register a rule handed each number of each paired enum."""
    return _register(id, purpose, severity, "enum number", categories, errors_in)


def message_rule(
    id: str, purpose: str, severity: Severity = "error", categories: tuple[str, ...] = _WIRE
) -> Callable[[_MessageCheck], _MessageCheck]:
    """Register a rule handed each paired message."""
    return _register(id, purpose, severity, "message", categories)


def enum_rule(
    id: str, purpose: str, severity: Severity = "error", categories: tuple[str, ...] = _WIRE
) -> Callable[[_EnumCheck], _EnumCheck]:
    """Register a rule handed each paired enum."""
    return _register(id, purpose, severity, "enum", categories)


def definition_rule(
    id: str, purpose: str, severity: Severity = "error", categories: tuple[str, ...] = _WIRE
) -> Callable[[_DefinitionCheck], _DefinitionCheck]:
    """Register a rule handed each paired message and each paired enum."""
    return _register(id, purpose, severity, "message or enum", categories)


def deleted_message_rule(
    id: str, purpose: str, severity: Severity = "error", categories: tuple[str, ...] = _WIRE
) -> Callable[[_DeletedCheck], _DeletedCheck]:
    """Register a rule handed each OLD message that NEW no longer has (not even renamed)."""
    return _register(id, purpose, severity, "deleted message", categories)


def method_rule(
    id: str, purpose: str, severity: Severity = "error"
) -> Callable[[_MethodCheck], _MethodCheck]:
    """Register a rule handed each method of each service both revisions declare."""
    return _register(id, purpose, severity, "method", ("RPC",))


def tree_rule(
    id: str, purpose: str, categories: tuple[str, ...] = ("TREE",)
) -> Callable[[_TreeCheck], _TreeCheck]:
    """Register a rule handed one revision, OLD and then NEW."""
    return _register(id, purpose, "error", "tree", categories)


def field_prefix(
    field: Field, owner: str, number: int | None = None, name: str | None = None
) -> str:
    """``Field "2" with name "x" on message "M"`` (``Extension`` for an extension): how buf starts
    a message about a field, by OLD's ``number`` and ``name`` where the message names them."""
    return (
        f'{field.noun} "{field.number if number is None else number}" with name '
        f'"{name or field.name}" on message "{owner}"'
    )


def findings_rule(
    id: str, purpose: str, severity: Severity = "error"
) -> Callable[[_FindingsCheck], _FindingsCheck]:
    """Register a rule handed what the other rules found (and NEW's suppressions)."""
    return _register(id, purpose, severity, "findings", ("TREE",))


def select(config: Config, has_services: bool = False) -> dict[str, Severity]:
    """The rules a run applies, each with its severity: those of ``use`` (rule IDs and
    categories; without it ``DEFAULT_CATEGORIES``, and RPC when ``has_services``), less those
    of ``except_`` and ``ignore``."""
    known = RULES.keys() | CATEGORIES.keys()
    strange = [name for name in (*config.use, *config.except_) if name not in known]
    strange += [name for name in config.ignore if name not in RULES]
    if strange:
        first = sorted(strange)[0]
        raise ConfigError(
            f"[tool.erc-lint] names no rule or category {first!r}" + did_you_mean(first, known)
        )
    used = set(config.use or (*DEFAULT_CATEGORIES, *(("RPC",) if has_services else ())))
    dropped = set(config.except_) | config.ignore
    return {
        rule.id: "error" if set(rule.errors_in) & used else rule.severity
        for rule in RULES.values()
        if (rule.id in used or set(rule.categories) & used)
        and rule.id not in dropped
        and not set(rule.categories) & dropped
    }


def run(change: Change) -> list[Finding]:
    """Every finding of every rule the configuration selects, less those ``ignore_only`` or a
    suppression comment silences, sorted by location."""
    found: list[Finding] = []
    selected = select(change.config, change.has_services)
    for rule in RULES.values():
        severity = selected.get(rule.id)
        if severity is None or rule.pairs == "findings":
            continue
        if rule.pairs == "tree":
            existing = {report.key for report in rule.check(change.old, change)}
            for report in rule.check(change.new, change):
                graded: Severity = "warning" if report.key in existing else "error"
                if report.like and graded == "error":
                    graded = selected.get(report.like, "warning")
                found.append(_finding(report, rule.id, graded))
            continue
        for pair in PAIRS[rule.pairs](change):
            for report in rule.check(pair, change):
                found.append(_finding(report, rule.id, severity))
    if "COMPILE" in selected:
        found += _uncompared(change)
    found = [f for f in found if not _ignored_path(change, f)]
    given = suppressions(change.new.tree.texts, str(change.new.root))
    found, used = apply(found, given)
    found += _on_findings(change, selected, Found(given, used))
    return sorted(set(found), key=Finding.order)


def _on_findings(change: Change, selected: dict[str, Severity], found: Found) -> list[Finding]:
    """What the ``findings_rule``s say, less what ``ignore_only`` names for its path."""
    said = []
    for rule in RULES.values():
        severity = selected.get(rule.id)
        if severity is not None and rule.pairs == "findings":
            for report in rule.check(found, change):
                finding = _finding(report, rule.id, severity)
                if not _ignored_path(change, finding):
                    said.append(finding)
    return said


def _finding(report: Report, rule: str, severity: Severity) -> Finding:
    return Finding.at(
        report.where, rule, report.message, severity, report.in_old, report.container, report.fix
    )


def _ignored_path(change: Change, finding: Finding) -> bool:
    """Whether ``ignore_only`` names the finding's rule for its file (relative to its tree)."""
    if not change.config.ignore_only:
        return False
    root = change.old.root if finding.in_old else change.new.root
    return change.config.ignored_at(finding.rule, relative(root, finding.path))


def _uncompared(change: Change) -> list[Finding]:
    """``COMPILE``'s word on the change itself: a file OLD could not compile hides every change to
    it, so say so, once per file (a warning located in OLD)."""
    return [
        Finding(
            str(change.old.root / name),
            1,
            1,
            "COMPILE",
            f"OLD's {name} does not compile, so its messages could not be compared with NEW's "
            "(every file that compiles was).",
            "warning",
            in_old=True,
            in_new=Location(str(change.new.root / name), 1, 1)
            if name in change.new.tree.texts
            else None,
        )
        for name in sorted(change.old.tree.failed)
        if name not in change.new.tree.failed
    ]
