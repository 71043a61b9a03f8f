"""OLD and NEW, paired the way buf pairs them, plus what buf cannot see.

Messages and enums pair by full name; one that is gone from NEW pairs with a new one whose body is
identical (same fields, numbers, names and types), which makes it a rename, not a deletion; and one
that moved to another scope (``Mode`` to ``Status.Mode``: the same short name, the only one gone
and the only one added) pairs with it when every field or value name both have keeps its number,
whatever was added or removed on the way (the rules then compare them as they compare any pair).
Inside a message pair, each OLD field is seen twice in NEW: by number and by name, so a rule can
tell a field that moved from one that was deleted while another took its number; the message's
extensions are seen the same way, and so are those of messages the tree extends without defining.
Inside an enum pair, each OLD number is seen once with all its names (more than one with
``allow_alias``), in OLD and in NEW, and where NEW put the names that left it. Services pair by
full name, their methods by name.
"""

import functools
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any, Generic, NoReturn, TypeVar

from ._config import Config
from ._model import Enum, EnumValue, Field, Message, Method, Revision, Service

if TYPE_CHECKING:
    from ._ledger import Ledger

__all__ = [
    "WIRE_GROUPS",
    "Change",
    "FieldPair",
    "MethodPair",
    "NumberPair",
    "Paired",
    "wire_compatible",
]

Container = TypeVar("Container", Message, Enum)

# Scalar types that share a wire encoding (protobuf's encoding guide: int32, uint32, int64,
# uint64 and bool are one varint); string → bytes is checked apart.
WIRE_GROUPS = [
    {"int32", "int64", "uint32", "uint64", "bool"},
    {"sint32", "sint64"},
    {"fixed32", "sfixed32"},
    {"fixed64", "sfixed64"},
]


class Paired(Generic[Container]):
    """A message or enum of OLD and the same one in NEW (by full name, or renamed)."""

    # A plain class, which equals, hashes and reads only as a frozen dataclass would: a dataclass
    # costs an import and a slow class build at start-up. Not a NamedTuple: Python 3.10 cannot
    # make a NamedTuple generic.
    __slots__ = ("new", "old")
    old: Container
    new: Container

    def __init__(self, old: Container, new: Container) -> None:
        object.__setattr__(self, "old", old)
        object.__setattr__(self, "new", new)

    def __setattr__(self, name: str, value: object) -> NoReturn:
        raise AttributeError(f"cannot assign to field {name!r}")

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Paired):
            return NotImplemented
        return (self.old, self.new) == (other.old, other.new)

    def __hash__(self) -> int:
        return hash((self.old, self.new))

    def __repr__(self) -> str:
        return f"Paired(old={self.old!r}, new={self.new!r})"

    def __iter__(self) -> Iterator[Container]:  # ``old, new = pair``, as with a tuple
        yield self.old
        yield self.new


class FieldPair:
    """One OLD field (or extension) and what NEW has at its number and under its name (among the
    extensions of the same message, for an extension)."""

    # Plain classes, the three pairs: a rule reads a pair's members, never the pair as a tuple,
    # and a NamedTuple class is slow to build at import.
    __slots__ = ("by_name", "by_number", "new_owner", "old", "old_owner")

    def __init__(
        self,
        old_owner: Message,
        new_owner: Message,
        old: Field,
        by_number: Field | None,
        by_name: Field | None,
    ) -> None:
        self.old_owner = old_owner
        self.new_owner = new_owner
        self.old = old
        self.by_number = by_number
        self.by_name = by_name


class NumberPair:
    """One number of an OLD enum and what NEW makes of it: judged once per number, whatever the
    number of names ``allow_alias`` gives it."""

    __slots__ = ("after", "before", "by_number", "moved", "new_owner", "old", "old_owner")

    def __init__(
        self,
        old_owner: Enum,
        new_owner: Enum,
        old: EnumValue,
        by_number: EnumValue | None,
        before: list[str],
        after: list[str],
        moved: dict[str, int],
    ) -> None:
        self.old_owner = old_owner
        self.new_owner = new_owner
        self.old = old  # the number's first value in OLD
        self.by_number = by_number  # the number's first value in NEW, if it has one
        self.before = before  # the number's names in OLD, in declaration order
        self.after = after  # the number's names in NEW
        self.moved = moved  # OLD names NEW has at another number, with that number


class MethodPair:
    """One method of an OLD service and the method of that name in NEW's service."""

    __slots__ = ("new", "new_service", "old", "old_service")

    def __init__(
        self, old_service: Service, new_service: Service, old: Method, new: Method | None
    ) -> None:
        self.old_service = old_service
        self.new_service = new_service
        self.old = old
        self.new = new


class Change:
    """OLD and NEW, their messages, enums and services paired."""

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
        self.messages: list[Paired[Message]]
        self.messages, gone = _pair(old.messages, new.messages, self.renamed, hints)
        hints = {}  # the enums that renamed messages declare
        for before, after in self.renamed.items():
            _nest(hints, old.enums, new.enums, before, after)
        self.enums: list[Paired[Enum]]
        self.enums, _ = _pair(old.enums, new.enums, self.renamed, hints)
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
        found = [
            FieldPair(old, new, entry, new.fields.get(entry.number), new.by_name.get(entry.name))
            for old, new in self.messages
            for entry in old.fields.values()
        ]
        extended = [(old, new) for old, new in self.messages if old.extensions]
        for name, old in self.old.extended.items():  # messages from outside the tree
            new = self.new.extended.get(name) or Message(name, "", old.source, ())
            extended.append((old, new))
        found += [
            FieldPair(
                old,
                new,
                entry,
                new.extensions.get(entry.number),
                new.extensions_by_name.get(entry.name),
            )
            for old, new in extended
            for entry in old.extensions.values()
        ]
        return found

    @functools.cached_property
    def _methods(self) -> list[MethodPair]:
        return [
            MethodPair(old, new, method, new.methods.get(method.name))
            for name, old in self.old.services.items()
            if (new := self.new.services.get(name)) is not None
            for method in old.methods.values()
        ]

    @functools.cached_property
    def has_services(self) -> bool:
        """Whether either revision declares a service (then the RPC rules run by default)."""
        return bool(self.old.services or self.new.services)

    @functools.cached_property
    def compares_nanopb(self) -> bool:
        """Whether either revision sets any nanopb option: without any, every field has nanopb's
        defaults on both sides and no nanopb option can have changed. The shortcut spares
        resolving options, which compiles nanopb's vocabulary.
        test_a_tree_without_nanopb_options_resolves_to_defaults holds it."""
        return self.old.has_nanopb_options() or self.new.has_nanopb_options()

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

    def methods(self) -> Iterator[MethodPair]:
        """Every method of every service both revisions declare."""
        return iter(self._methods)

    def same_type(self, old: str, new: str) -> bool:
        """Whether NEW's message or enum ``new`` is OLD's ``old`` (or its rename)."""
        return self.renamed.get(old, old) == new

    def compatible(self, old: Field, new: Field) -> bool:
        """Whether NEW's field reads OLD's bytes as the same value kind."""
        if old.kind != "scalar" or new.kind != "scalar":
            return old.kind == new.kind and self.same_type(old.type, new.type)
        return wire_compatible(old.type, new.type)


def wire_compatible(old: str, new: str) -> bool:
    """Whether a field of type ``new`` reads the bytes of type ``old`` as the same kind of value
    (scalar keywords; a message or enum type only matches itself)."""
    if old == new or (old, new) == ("string", "bytes"):
        return True
    return any(old in group and new in group for group in WIRE_GROUPS)


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
    old: dict[str, Container],
    new: dict[str, Container],
    renamed: dict[str, str],
    hints: dict[str, str],
) -> tuple[list[Paired[Container]], list[Container]]:
    """Pairs by full name, then renames: first those ``hints`` name (map entries; what a
    renamed message declares), then by identical body, outermost NEW elements first, so that
    a message's rename brings its nested types before any other body can claim them, last by
    moves (``_moves``). A NEW element is the rename of one OLD element at most; renames and moves
    are added to ``renamed``. Returns the pairs and OLD's unpaired leftovers."""
    pairing = _Pairing(old, new, renamed, hints)
    pairing.follow_hints()
    for level in sorted({_level(new, name) for name in pairing.added}):
        pairing.by_body(level)
        pairing.follow_hints()
    for before, after in _moves(old, new, pairing.leftovers(), pairing.added, pairing.taken):
        pairing.link(before, after)
        pairing.follow_hints()
    return pairing.pairs, [old[name] for name in pairing.leftovers()]


class _Pairing(Generic[Container]):
    """One pairing in progress: what is paired, what OLD has left, what NEW added."""

    def __init__(
        self,
        old: dict[str, Container],
        new: dict[str, Container],
        renamed: dict[str, str],
        hints: dict[str, str],
    ) -> None:
        self.old: dict[str, Container] = old
        self.new: dict[str, Container] = new
        self.renamed = renamed
        self.hints = dict(hints)
        self.pairs: list[Paired[Container]] = [
            Paired(old[name], new[name]) for name in old if name in new
        ]
        self.left = [name for name in old if name not in new]
        self.added = [name for name in new if name not in old]
        self.done: set[str] = set()
        self.taken: set[str] = set()

    def leftovers(self) -> list[str]:
        return [name for name in self.left if name not in self.done]

    def link(self, before: str, after: str) -> None:
        if before in self.done or after in self.taken:  # a move an earlier one brought along
            return
        self.pairs.append(Paired(self.old[before], self.new[after]))
        self.renamed[before] = after
        self.done.add(before)
        self.taken.add(after)
        _nest(self.hints, self.old, self.new, before, after)

    def follow_hints(self) -> None:
        linked = True
        while linked:
            linked = False
            for name in self.leftovers():
                after = self.hints.get(name)
                if after is not None and after not in self.taken:
                    self.link(name, after)
                    linked = True

    def by_body(self, level: int) -> None:
        """Pair what is left with the NEW elements ``level`` deep that have its body."""
        bodies: dict[object, list[str]] = {}
        for name in self.added:
            if name not in self.taken and _level(self.new, name) == level:
                bodies.setdefault(self.new[name].body(), []).append(name)
        for name in self.left:
            body = self.old[name].body()
            twins = [twin for twin in bodies.get(body, []) if twin not in self.taken]
            if name not in self.done and body and len(twins) == 1:
                self.link(name, twins[0])


def _moves(
    old: dict[str, Container],
    new: dict[str, Container],
    left: list[str],
    added: list[str],
    taken: set[str],
) -> list[tuple[str, str]]:
    """Moves: the only OLD element ``left`` with a short name and the only NEW one ``added``
    with it (and not ``taken``), when their members agree."""
    gone: dict[str, list[str]] = {}
    for name in left:
        gone.setdefault(name.rsplit(".", 1)[-1], []).append(name)
    fresh: dict[str, list[str]] = {}
    for name in added:
        if name not in taken:
            fresh.setdefault(name.rsplit(".", 1)[-1], []).append(name)
    return [
        (before[0], after[0])
        for short, before in gone.items()
        if len(before) == len(after := fresh.get(short, [])) == 1
        and _agree(old[before[0]], new[after[0]])
    ]


def _agree(old: Message | Enum, new: Message | Enum) -> bool:
    """Whether two elements of the same kind share a member name and every member name both
    have keeps its number: what a moved message or enum keeps, whatever it gained or lost."""
    shared = old.by_name.keys() & new.by_name.keys()
    if type(old) is not type(new) or not shared:
        return False
    before: dict[str, Any] = old.by_name
    after: dict[str, Any] = new.by_name
    return all(before[name].number == after[name].number for name in shared)


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
