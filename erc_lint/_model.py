"""One revision of a proto tree as the rules see it: messages, enums, their members and locations.

Built from the descriptors the loader compiled. Every element has the ``Location`` of its
definition, read from protoc's source info when first asked for (nearly none ever are: only
findings need one); names are full names (``Outer.Inner``; a package, if a file has one, in front).
"""

from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import NamedTuple

from google.protobuf import descriptor_pb2

from erc_codec.schema import Location

from ._loader import LoadedTree, LoadProblem

__all__ = [
    "Definition",
    "Enum",
    "EnumValue",
    "Field",
    "Message",
    "Revision",
    "Source",
    "build",
    "type_of",
    "walk",
]

_FD = descriptor_pb2.FieldDescriptorProto
_SCALARS = {
    number: name.removeprefix("TYPE_").lower()
    for name, number in _FD.Type.items()
    if name not in ("TYPE_MESSAGE", "TYPE_ENUM", "TYPE_GROUP")
}
_LABELS = {number: name.removeprefix("LABEL_").lower() for name, number in _FD.Label.items()}
# A proto2 group is a message type as far as the wire and the rules go.
_KINDS = {_FD.TYPE_MESSAGE: "message", _FD.TYPE_GROUP: "message", _FD.TYPE_ENUM: "enum"}
# SourceCodeInfo path components.
_FILE_MESSAGE, _FILE_ENUM = 4, 5
_MESSAGE_FIELD, _MESSAGE_NESTED, _MESSAGE_ENUM, _MESSAGE_ONEOF = 2, 3, 4, 8
_ENUM_VALUE = 2


class Source:
    """Where one file's declarations are: protoc's source info, indexed on first use."""

    def __init__(self, path: str, proto: descriptor_pb2.FileDescriptorProto) -> None:
        self.path = path
        self._proto: descriptor_pb2.FileDescriptorProto | None = proto
        self._spans: dict[tuple[int, ...], Sequence[int]] = {}

    def where(self, at: tuple[int, ...]) -> Location:
        """The location of the declaration at source-info path ``at`` (1:1 if protoc has none)."""
        if self._proto is not None:
            # Declarations sit at even-length paths; the odd ones (names, numbers, types) are many.
            self._spans = {
                tuple(loc.path): loc.span
                for loc in self._proto.source_code_info.location
                if not len(loc.path) % 2
            }
            self._proto = None
        span = self._spans.get(at)
        return Location(self.path, span[0] + 1, span[1] + 1) if span else Location(self.path, 1, 1)


class Field(NamedTuple):
    owner: str
    name: str
    number: int
    type: str  # "float", "sint32", … or the full name of a message or enum
    kind: str  # "scalar", "message" or "enum"
    cardinality: str  # "optional", "repeated" or "required"
    oneof: str | None  # the real oneof it belongs to (not a proto3 `optional`'s)
    source: Source
    at: tuple[int, ...]  # its source-info path (a map entry's fields: their map field's)

    @property
    def location(self) -> Location:
        return self.source.where(self.at)


class EnumValue(NamedTuple):
    owner: str
    name: str
    number: int
    source: Source
    at: tuple[int, ...]

    @property
    def location(self) -> Location:
        return self.source.where(self.at)


class Reserved:
    """Reserved numbers (inclusive ranges) and names."""

    __slots__ = ("names", "ranges")

    def __init__(self) -> None:
        self.ranges: list[tuple[int, int]] = []
        self.names: set[str] = set()

    def covers(self, number: int) -> bool:
        return any(low <= number <= high for low, high in self.ranges)

    def first_free(self, low: int, high: int) -> int | None:
        """The lowest number from ``low`` to ``high`` that no range covers, if any."""
        number = low
        for start, end in sorted(self.ranges):
            if start > number:
                break
            number = max(number, end + 1)
        return number if number <= high else None


class Message:
    __slots__ = ("at", "by_name", "fields", "file", "map_entry", "name", "reserved", "source")

    def __init__(
        self, name: str, file: str, source: Source, at: tuple[int, ...], map_entry: bool = False
    ) -> None:
        self.name = name
        self.file = file
        self.source = source
        self.at = at  # a map entry's is its map field's
        self.map_entry = map_entry  # the message protoc writes for a map field: not declared
        self.fields: dict[int, Field] = {}
        self.by_name: dict[str, Field] = {}
        self.reserved = Reserved()

    @property
    def location(self) -> Location:
        return self.source.where(self.at)

    def oneof(self, name: str | None) -> frozenset[int]:
        """The field numbers of oneof ``name`` (none for ``None``)."""
        return frozenset(f.number for f in self.fields.values() if name and f.oneof == name)

    def body(self) -> frozenset[tuple[int, str, str, str, str | None]]:
        """What a renamed copy of this message must have to count as the same message (a type
        declared inside it named from the message: ``.Inner``, whatever the message is called)."""
        inside = f"{self.name}."
        return frozenset(
            (f.number, f.name, f.type.removeprefix(self.name), f.cardinality, f.oneof)
            if f.type.startswith(inside)
            else (f.number, f.name, f.type, f.cardinality, f.oneof)
            for f in self.fields.values()
        )


class Enum:
    __slots__ = ("at", "by_name", "file", "name", "reserved", "source", "values")

    def __init__(self, name: str, file: str, source: Source, at: tuple[int, ...]) -> None:
        self.name = name
        self.file = file
        self.source = source
        self.at = at
        self.values: dict[int, EnumValue] = {}  # the first name of each number
        self.by_name: dict[str, EnumValue] = {}
        self.reserved = Reserved()

    @property
    def location(self) -> Location:
        return self.source.where(self.at)

    def body(self) -> frozenset[tuple[int, str]]:
        return frozenset((v.number, v.name) for v in self.by_name.values())

    def names(self, number: int) -> list[str]:
        """Every name of ``number``, in declaration order: more than one with ``allow_alias``."""
        return [v.name for v in self.by_name.values() if v.number == number]


Definition = Message | Enum | EnumValue


class Revision:
    """One side of a comparison."""

    __slots__ = ("definitions", "enums", "messages", "tree")

    def __init__(self, tree: LoadedTree) -> None:
        self.tree = tree
        self.messages: dict[str, Message] = {}
        self.enums: dict[str, Enum] = {}
        # Every global name a definition takes (C++ scoping: enum values beside their enum),
        # with the kind of definition ("message", "enum", "enum value") and the definition.
        self.definitions: dict[str, list[tuple[str, Definition]]] = {}

    @property
    def root(self) -> Path:
        return self.tree.root

    @property
    def problems(self) -> list[LoadProblem]:
        """What loading the tree met (files that do not compile, ambiguous imports)."""
        return self.tree.problems


def build(tree: LoadedTree) -> Revision:
    """The model of a loaded tree."""
    revision = Revision(tree)
    for proto in tree.files.values():
        _File(revision, proto).add()
    return revision


class _File:
    def __init__(self, revision: Revision, proto: descriptor_pb2.FileDescriptorProto) -> None:
        self.revision = revision
        self.proto = proto
        self.source = Source(str(revision.root / proto.name), proto)
        self.package = f"{proto.package}." if proto.package else ""

    def define(self, name: str, kind: str, definition: Definition) -> None:
        self.revision.definitions.setdefault(name, []).append((kind, definition))

    def add(self) -> None:
        for i, message in enumerate(self.proto.message_type):
            self.message(self.package + message.name, message, (_FILE_MESSAGE, i))
        for i, enum in enumerate(self.proto.enum_type):
            self.enum(self.package + enum.name, self.package, enum, (_FILE_ENUM, i))

    def message(
        self,
        name: str,
        proto: descriptor_pb2.DescriptorProto,
        path: tuple[int, ...],
        declared: tuple[int, ...] | None = None,
    ) -> None:
        """Add message ``name``; ``declared`` is the path of the map field that a map entry and
        its key and value, which have no source of their own, are located at."""
        model = Message(
            name, self.proto.name, self.source, declared or path, proto.options.map_entry
        )
        self.define(name, "message", model)
        self.revision.messages.setdefault(name, model)
        oneofs = [oneof.name for oneof in proto.oneof_decl]
        for j, f in enumerate(proto.field):
            real_oneof = f.HasField("oneof_index") and not f.proto3_optional
            type_, kind = type_of(f)
            entry = Field(
                owner=name,
                name=f.name,
                number=f.number,
                type=type_,
                kind=kind,
                cardinality=_LABELS[f.label],
                oneof=oneofs[f.oneof_index] if real_oneof else None,
                source=self.source,
                at=declared or (*path, _MESSAGE_FIELD, j),
            )
            model.fields.setdefault(f.number, entry)
            model.by_name.setdefault(f.name, entry)
        # protoc's message ranges end before ``end``; enum ranges include it
        model.reserved.ranges.extend((r.start, r.end - 1) for r in proto.reserved_range)
        model.reserved.names.update(proto.reserved_name)
        for j, nested in enumerate(proto.nested_type):
            full = f"{name}.{nested.name}"
            users = [f for f in model.fields.values() if f.type == full]
            declared = users[0].at if nested.options.map_entry and users else None
            self.message(full, nested, (*path, _MESSAGE_NESTED, j), declared)
        for j, enum in enumerate(proto.enum_type):
            self.enum(f"{name}.{enum.name}", f"{name}.", enum, (*path, _MESSAGE_ENUM, j))

    def enum(
        self,
        name: str,
        scope: str,
        proto: descriptor_pb2.EnumDescriptorProto,
        path: tuple[int, ...],
    ) -> None:
        model = Enum(name, self.proto.name, self.source, path)
        self.define(name, "enum", model)
        self.revision.enums.setdefault(name, model)
        for j, value in enumerate(proto.value):
            entry = EnumValue(name, value.name, value.number, self.source, (*path, _ENUM_VALUE, j))
            self.define(scope + value.name, "enum value", entry)
            model.values.setdefault(value.number, entry)
            model.by_name.setdefault(value.name, entry)
        model.reserved.ranges.extend((r.start, r.end) for r in proto.reserved_range)
        model.reserved.names.update(proto.reserved_name)


def type_of(f: descriptor_pb2.FieldDescriptorProto) -> tuple[str, str]:
    """A field's type as the rules name it (``float``, or a full name) and its kind."""
    kind = _KINDS.get(f.type, "scalar")
    return (f.type_name.lstrip(".") if kind != "scalar" else _SCALARS[f.type]), kind


def walk(revision: Revision, root: str) -> Iterator[tuple[str, Field]]:
    """Every field reachable from message ``root``, with its path (``Root.a.b``), once each."""
    seen = {root}
    queue = [(root, root)]
    while queue:
        name, path = queue.pop(0)
        message = revision.messages.get(name)
        if message is None:
            continue
        for entry in sorted(message.fields.values(), key=lambda f: f.number):
            here = f"{path}.{entry.name}"
            yield here, entry
            if entry.kind == "message" and entry.type not in seen:
                seen.add(entry.type)
                queue.append((entry.type, here))
