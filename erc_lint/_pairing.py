"""OLD and NEW, paired the way buf pairs them, plus what buf cannot see.

Messages and enums pair by full name; one that is gone from NEW pairs with a new one whose body is
identical (same fields, numbers, names and types), which makes it a rename, not a deletion. Inside
a message pair, each OLD field is seen twice in NEW: by number and by name, so a rule can tell a
field that moved from one that was deleted while another took its number. Inside an enum pair,
each OLD number is seen once with all its names (more than one with ``allow_alias``), in OLD and
in NEW, and where NEW put the names that left it.
"""

import functools
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, Any, NamedTuple, TypeVar

from ._config import Config
from ._model import Enum, EnumValue, Field, Message, Revision

if TYPE_CHECKING:
    from ._ledger import Ledger

__all__ = ["Change", "EnumPair", "FieldPair", "MessagePair", "NumberPair", "wire_compatible"]

# Scalar types that share a wire encoding (wire-facts §6); string → bytes is checked apart.
_WIRE_GROUPS = [
    {"int32", "int64", "uint32", "uint64", "bool"},
    {"sint32", "sint64"},
    {"fixed32", "sfixed32"},
    {"fixed64", "sfixed64"},
]


# Two named tuples, not one generic: Python 3.10 cannot make a NamedTuple generic.
class MessagePair(NamedTuple):
    """A message of OLD and the same one in NEW (by full name, or renamed)."""

    old: Message
    new: Message


class EnumPair(NamedTuple):
    """An enum of OLD and the same one in NEW (by full name, or renamed)."""

    old: Enum
    new: Enum


_Container = TypeVar("_Container", Message, Enum)
_Pair = TypeVar("_Pair", MessagePair, EnumPair)


class FieldPair(NamedTuple):
    """One OLD field and what NEW has at its number and under its name."""

    old_owner: Message
    new_owner: Message
    old: Field
    by_number: Field | None
    by_name: Field | None


class NumberPair(NamedTuple):
    """One number of an OLD enum and what NEW makes of it: judged once per number, whatever the
    number of names ``allow_alias`` gives it."""

    old_owner: Enum
    new_owner: Enum
    old: EnumValue  # the number's first value in OLD
    by_number: EnumValue | None  # the number's first value in NEW, if it has one
    before: list[str]  # the number's names in OLD, in declaration order
    after: list[str]  # the number's names in NEW
    moved: dict[str, int]  # OLD names NEW has at another number, with that number


class Change:
    """OLD and NEW, their messages and enums paired."""

    def __init__(
        self, old: Revision, new: Revision, config: Config, ledger: "Ledger | None" = None
    ) -> None:
        self.old = old
        self.new = new
        self.config = config
        self.ledger = ledger
        # OLD full name → NEW full name of each renamed message or enum
        self.renamed: dict[str, str] = {}
        hints = _map_entries(old.messages, new.messages)
        self.messages: list[MessagePair]
        self.messages, gone = _pair(MessagePair, old.messages, new.messages, self.renamed, hints)
        hints = {}  # the enums that renamed messages declare
        for before, after in self.renamed.items():
            _nest(hints, old.enums, new.enums, before, after)
        self.enums: list[EnumPair]
        self.enums, _ = _pair(EnumPair, old.enums, new.enums, self.renamed, hints)
        # A message whose file no longer compiles is unknown in NEW, not gone: COMPILE says so.
        self.deleted_messages = [m for m in gone if m.file not in self.new.tree.failed]

    def old_name(self, revision: Revision, name: str) -> str:
        """What OLD called ``name`` of ``revision`` (NEW's renamed messages and enums): so
        damage a rename carried over reads as old damage, not new."""
        if revision is not self.new:
            return name
        return self._old_names.get(name, name)

    @functools.cached_property
    def _old_names(self) -> dict[str, str]:
        return {after: before for before, after in self.renamed.items()}

    @functools.cached_property
    def _fields(self) -> list[FieldPair]:
        return [
            FieldPair(old, new, entry, new.fields.get(entry.number), new.by_name.get(entry.name))
            for old, new in self.messages
            for entry in old.fields.values()
        ]

    @functools.cached_property
    def _numbers(self) -> list[NumberPair]:
        found = []
        for old, new in self.enums:
            for number, first in old.values.items():
                before = old.names(number)
                elsewhere = [new.by_name.get(name) for name in before]
                moved = {v.name: v.number for v in elsewhere if v and v.number != number}
                now = new.values.get(number)
                found.append(NumberPair(old, new, first, now, before, new.names(number), moved))
        return found

    def fields(self) -> Iterator[FieldPair]:
        """Every field of every paired message, seen in NEW by number and by name."""
        return iter(self._fields)

    def numbers(self) -> Iterator[NumberPair]:
        """Every number of every paired enum, with its names before and after."""
        return iter(self._numbers)

    def compatible(self, old: Field, new: Field) -> bool:
        """Whether NEW's field reads OLD's bytes as the same value kind."""
        if old.kind != "scalar" or new.kind != "scalar":
            return old.kind == new.kind and self.renamed.get(old.type, old.type) == new.type
        return wire_compatible(old.type, new.type)


def wire_compatible(old: str, new: str) -> bool:
    """Whether a field of type ``new`` reads the bytes of type ``old`` as the same kind of value
    (scalar keywords; a message or enum type only matches itself)."""
    if old == new or (old, new) == ("string", "bytes"):
        return True
    return any(old in group and new in group for group in _WIRE_GROUPS)


def _map_entries(old: dict[str, Message], new: dict[str, Message]) -> dict[str, str]:
    """OLD map entry → NEW map entry of a map field that kept its number in a message that kept
    its name: renaming a map field renames its entry, however many other maps look alike."""
    renamed = {}
    for name, message in old.items():
        twin = new.get(name)
        if twin is None:
            continue
        for number, entry in message.fields.items():
            now = twin.fields.get(number)
            if now is None or now.type == entry.type or entry.type in new or now.type in old:
                continue
            before, after = old.get(entry.type), new.get(now.type)
            if before is not None and after is not None and before.map_entry and after.map_entry:
                renamed[entry.type] = now.type
    return renamed


def _pair(
    make: Callable[[_Container, _Container], _Pair],
    old: dict[str, _Container],
    new: dict[str, _Container],
    renamed: dict[str, str],
    hints: dict[str, str],
) -> tuple[list[_Pair], list[_Container]]:
    """Pairs by full name, then renames: first those ``hints`` name (map entries; what a
    renamed message declares), then by identical body, outermost NEW elements first, so that
    a message's rename brings its nested types before any other body can claim them. A NEW
    element is the rename of one OLD element at most; renames are added to ``renamed``.
    Returns the pairs (each made by ``make``) and OLD's unpaired leftovers."""
    pairs = [make(old[name], new[name]) for name in old if name in new]
    left = [name for name in old if name not in new]
    added = [name for name in new if name not in old]
    hints = dict(hints)
    done: set[str] = set()
    taken: set[str] = set()

    def link(before: str, after: str) -> None:
        pairs.append(make(old[before], new[after]))
        renamed[before] = after
        done.add(before)
        taken.add(after)
        _nest(hints, old, new, before, after)

    def follow_hints() -> None:
        linked = True
        while linked:
            linked = False
            for name in left:
                after = hints.get(name)
                if name not in done and after is not None and after not in taken:
                    link(name, after)
                    linked = True

    follow_hints()
    for level in sorted({_level(new, name) for name in added}):
        bodies: dict[object, list[str]] = {}
        for name in added:
            if name not in taken and _level(new, name) == level:
                bodies.setdefault(new[name].body(), []).append(name)
        for name in left:
            body = old[name].body()
            twins = [twin for twin in bodies.get(body, []) if twin not in taken]
            if name not in done and body and len(twins) == 1:
                link(name, twins[0])
        follow_hints()
    return pairs, [old[name] for name in left if name not in done]


def _level(elements: dict[str, Any], name: str) -> int:
    """How many of ``elements`` ``name`` is declared inside (0: at the top of its file)."""
    parts = name.split(".")
    return sum(".".join(parts[:k]) in elements for k in range(1, len(parts)))


def _nest(
    hints: dict[str, str], old: dict[str, Any], new: dict[str, Any], before: str, after: str
) -> None:
    """Hint that what OLD's ``before`` declares inside it (``before.Inner``) is now the same name
    inside ``after``, where NEW has it and it is not a name both sides have."""
    for inner in old:
        if inner.startswith(f"{before}.") and inner not in new:
            moved = after + inner[len(before) :]
            if moved in new and moved not in old:
                hints.setdefault(inner, moved)
