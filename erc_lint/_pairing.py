"""OLD and NEW, paired the way buf pairs them, plus what buf cannot see.

Messages and enums pair by full name; one that is gone from NEW pairs with a new one whose body is
identical (same fields, numbers, names and types), which makes it a rename, not a deletion. Inside
a pair, each OLD member is seen twice in NEW: by number and by name, so a rule can tell a field
that moved from one that was deleted while another took its number.
"""

import functools
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any, Generic, NamedTuple, TypeVar

from ._config import Config
from ._model import Enum, EnumValue, Field, Message, Revision

if TYPE_CHECKING:
    from ._ledger import Ledger

__all__ = ["Change", "MemberPair", "wire_compatible"]

Member = TypeVar("Member", Field, EnumValue)
Container = TypeVar("Container", Message, Enum)

# Scalar types that share a wire encoding (wire-facts §6); string → bytes is checked apart.
_WIRE_GROUPS = [
    {"int32", "int64", "uint32", "uint64", "bool"},
    {"sint32", "sint64"},
    {"fixed32", "sfixed32"},
    {"fixed64", "sfixed64"},
]


class MemberPair(NamedTuple, Generic[Container, Member]):
    """One OLD member and what NEW has at its number and under its name."""

    old_owner: Container
    new_owner: Container
    old: Member
    by_number: Member | None
    by_name: Member | None


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
        self.renamed = _map_entries(old.messages, new.messages)
        self.messages, gone = _pair(old.messages, new.messages, self.renamed)
        for before, after in list(self.renamed.items()):  # enums declared in renamed messages
            _nest(self.renamed, old.enums, new.enums, before, after)
        # A message whose file no longer compiles is unknown in NEW, not gone: COMPILE says so.
        self.deleted_messages = [m for m in gone if m.file not in self.new.tree.failed]
        self.enums, _ = _pair(self.old.enums, self.new.enums, self.renamed)

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
    def _fields(self) -> list[MemberPair[Message, Field]]:
        return [
            MemberPair(old, new, entry, new.fields.get(entry.number), new.by_name.get(entry.name))
            for old, new in self.messages
            for entry in old.fields.values()
        ]

    @functools.cached_property
    def _values(self) -> list[MemberPair[Enum, EnumValue]]:
        return [
            MemberPair(old, new, entry, new.values.get(entry.number), new.by_name.get(entry.name))
            for old, new in self.enums
            for entry in old.by_name.values()
        ]

    def fields(self) -> Iterator[MemberPair[Message, Field]]:
        """Every field of every paired message, seen in NEW by number and by name."""
        return iter(self._fields)

    def values(self) -> Iterator[MemberPair[Enum, EnumValue]]:
        """Every value of every paired enum, seen in NEW by number and by name."""
        return iter(self._values)

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
    old: dict[str, Container], new: dict[str, Container], renamed: dict[str, str]
) -> tuple[list[tuple[Container, Container]], list[Container]]:
    """Pairs by full name, then by the renames already known (``renamed``: map entries, types
    declared inside a renamed message), then renames by identical body; and OLD's unpaired
    leftovers. A rename found renames what the element declares inside it too; every rename
    is added to ``renamed``."""
    pairs = [(old[name], new[name]) for name in old if name in new]
    added: dict[object, list[Container]] = {}
    for name, element in new.items():
        if name not in old:
            added.setdefault(element.body(), []).append(element)
    taken: set[str] = set()  # NEW names already paired by a rename: one OLD element each
    gone = []
    for name, element in old.items():
        if name in new:
            continue
        twin = new.get(renamed.get(name, ""))
        if twin is None or twin.name in taken:
            twins = [e for e in added.get(element.body(), []) if e.name not in taken]
            twin = twins[0] if len(twins) == 1 and element.body() else None
        if twin is None:
            gone.append(element)
            continue
        taken.add(twin.name)
        renamed[name] = twin.name
        pairs.append((element, twin))
        _nest(renamed, old, new, name, twin.name)
    return pairs, gone


def _nest(
    renamed: dict[str, str], old: dict[str, Any], new: dict[str, Any], before: str, after: str
) -> None:
    """Rename what OLD's ``before`` declares inside it (``before.Inner``) to the same name
    inside ``after``, where NEW has it and it is not a name both sides have."""
    for inner in old:
        if inner.startswith(f"{before}.") and inner not in new:
            moved = after + inner[len(before) :]
            if moved in new and moved not in old:
                renamed.setdefault(inner, moved)
