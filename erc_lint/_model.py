"""One revision of a proto tree as the rules see it: messages, enums, their members and locations,
and what nanopb makes of them (maximum sizes, bounds).

Built from the descriptors the loader compiled. Every element has the ``Location`` of its
definition, read from protoc's source info when first asked for (nearly none ever are: only
findings need one); names are full names (``Outer.Inner``; a package, if a file has one, in front).
Sizes and nanopb options are computed when a rule first asks, once per revision (and root).
"""

from collections.abc import Iterator
from pathlib import Path
from typing import Any, NamedTuple

from google.protobuf import descriptor_pb2

from erc_codec import SchemaError
from erc_codec.schema import (
    Declaration,
    FileError,
    Location,
    Schema,
    Sizes,
    SourceIndex,
    declarations,
    declared_names,
    file_exists,
    read_file,
    resolve_options,
)

from ._loader import LoadedTree, LoadProblem, relative

__all__ = [
    "Definition",
    "Enum",
    "EnumValue",
    "Field",
    "Message",
    "Revision",
    "build",
    "type_of",
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
_Files = dict[str, descriptor_pb2.FileDescriptorProto]


class Field(NamedTuple):
    owner: str
    name: str
    number: int
    type: str  # "float", "sint32", … or the full name of a message or enum
    kind: str  # "scalar", "message" or "enum"
    cardinality: str  # "optional", "repeated" or "required"
    oneof: str | None  # the real oneof it belongs to (not a proto3 `optional`'s)
    source: SourceIndex
    at: tuple[int, ...]  # its source-info path (a map entry's fields: their map field's)

    @property
    def location(self) -> Location:
        return self.source.where(self.at)


class EnumValue(NamedTuple):
    owner: str
    name: str
    number: int
    source: SourceIndex
    at: tuple[int, ...]

    @property
    def kind(self) -> str:
        return "enum value"

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

    kind = "message"

    def __init__(
        self,
        name: str,
        file: str,
        source: SourceIndex,
        at: tuple[int, ...],
        map_entry: bool = False,
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

    kind = "enum"

    def __init__(self, name: str, file: str, source: SourceIndex, at: tuple[int, ...]) -> None:
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
    """One side of a comparison: its messages, enums and global names, and the questions rules
    ask of them (what a root reaches, nanopb's bounds and sizes, what a broken file declares)."""

    __slots__ = ("_bounds", "_failed_names", "_files", "definitions", "enums", "messages", "tree")

    def __init__(self, tree: LoadedTree) -> None:
        self.tree = tree
        self.messages: dict[str, Message] = {}
        self.enums: dict[str, Enum] = {}
        # Every global name a definition takes (C++ scoping: enum values beside their enum).
        self.definitions: dict[str, list[Definition]] = {}
        self._files: dict[str, _Files] = {}  # by root: what protoc resolved its types in
        self._bounds: dict[str, Any] | None = None  # nanopb's options by field, when first asked
        self._failed_names: frozenset[str] | None = None  # what files that failed declare

    @property
    def root(self) -> Path:
        return self.tree.root

    @property
    def problems(self) -> list[LoadProblem]:
        """What loading the tree met (files that do not compile, ambiguous imports)."""
        return self.tree.problems

    def place(self, location: Location) -> tuple[str, int]:
        """Where ``location`` is in the tree (its path from the root, its line): the same
        declaration in another revision, of another folder, has the same place."""
        return relative(self.root, location.path), location.line

    def declared_in_failed_file(self, name: str) -> bool:
        """Whether a file that did not compile declares a message, enum or group with the short
        name of ``name`` (comments and strings are not declarations): then what ``name`` is in
        this revision is unknown, not missing."""
        if self._failed_names is None:
            texts = self.tree.texts
            self._failed_names = frozenset().union(
                *(declared_names(texts.get(file, "")) for file in self.tree.failed)
            )
        return name.rsplit(".", 1)[-1] in self._failed_names

    def reach(self, root: str) -> Iterator[tuple[str, Field]]:
        """Every field reachable from message ``root``, with its path (``Root.a.b``), once each,
        nearest first."""
        seen = {root}
        queue = [(root, root)]
        while queue:
            name, path = queue.pop(0)
            message = self.messages.get(name)
            if message is None:
                continue
            for entry in sorted(message.fields.values(), key=lambda f: f.number):
                here = f"{path}.{entry.name}"
                yield here, entry
                if entry.kind == "message" and entry.type not in seen:
                    seen.add(entry.type)
                    queue.append((entry.type, here))

    def bounded(self, field: Field) -> bool:
        """Whether nanopb gives a string or bytes field a maximum length (``max_size`` or
        ``max_length``, from a ``.options`` file or an annotation)."""
        if self._bounds is None:
            files = tuple(self.tree.imported.values())
            self._bounds = resolve_options(self.root, files).fields
        bound = self._bounds.get(f"{field.owner}.{field.name}")
        return bound is not None and (bound.HasField("max_size") or bound.HasField("max_length"))

    def max_size(self, root: str) -> int | None:
        """nanopb's ``<root>_size`` in this revision; ``None`` where nanopb has none (an
        unbounded field on the way) or the tree has no such message."""
        files = self._root_files(root)
        if not files:
            return None
        try:
            schema = Schema(self.root, root, descriptor_pb2.FileDescriptorSet(file=files.values()))
            return Sizes(schema).max_size(root)
        except FileError:
            raise  # a .options file that is no file stops the run; it is no missing size
        except SchemaError:
            return None

    def size_inputs(self, root: str) -> dict[tuple[str, str], object]:
        """What nanopb computes ``root``'s size from: the descriptor of every message and enum it
        reaches (without source locations, so comments and layout don't count) and, for each file
        holding one, its package, syntax, edition, file options and ``.options`` text. Equal
        inputs, equal sizes: comparing them spares two size computations."""
        files = self._root_files(root)
        index: dict[str, tuple[descriptor_pb2.FileDescriptorProto, Declaration]] = {}
        for file in files.values():
            for declared in declarations(file):
                index.setdefault(declared.name, (file, declared))
        found: dict[tuple[str, str], object] = {}
        pending = [root]
        while pending:
            name = pending.pop()
            if ("type", name) in found or name not in index:
                continue
            file, declared = index[name]
            proto = declared.proto
            found["type", name] = proto.SerializeToString(deterministic=True)
            if isinstance(proto, descriptor_pb2.DescriptorProto):
                pending.extend(f.type_name.lstrip(".") for f in proto.field if f.type_name)
            if ("file", file.name) not in found:
                options = self.root / Path(file.name).with_suffix(".options")
                text = read_file(options) if file_exists(options) else None
                settings = file.options.SerializeToString(deterministic=True)
                found["file", file.name] = (file.package, file.syntax, file.edition, settings, text)
        return found

    def _root_files(self, root: str) -> _Files:
        """The file defining message ``root`` and every file it imports, each after its imports:
        what protoc resolved the root's types in (the tree may define a name twice elsewhere)."""
        order = self._files.get(root)
        if order is not None:
            return order
        files, order = self.tree.imported, {}
        message = self.messages.get(root)
        # Depth first without recursion: an import chain may be thousands of files long. (protoc
        # refuses import cycles, so a file on the stack is never imported again below itself.)
        stack = [(message.file, iter(files[message.file].dependency))] if message else []
        while stack:
            name, pending = stack[-1]
            after = next((d for d in pending if d in files and d not in order), None)
            if after is None:
                stack.pop()
                order[name] = files[name]
            else:
                stack.append((after, iter(files[after].dependency)))
        self._files[root] = order
        return order


def build(tree: LoadedTree) -> Revision:
    """The model of a loaded tree."""
    revision = Revision(tree)
    for proto in tree.files.values():
        _add_file(revision, proto)
    return revision


def _add_file(revision: Revision, proto: descriptor_pb2.FileDescriptorProto) -> None:
    source = SourceIndex(str(revision.root / proto.name), proto)
    here: dict[str, Message] = {}  # this file's messages (another file may define a name too)
    for declaration in declarations(proto):
        if declaration.is_message:
            message = _message(proto.name, source, declaration, here.get(declaration.parent or ""))
            here[message.name] = message
            _define(revision, message.name, message)
            revision.messages.setdefault(message.name, message)
        else:
            _enum(revision, proto.name, source, declaration)


def _define(revision: Revision, name: str, definition: Definition) -> None:
    revision.definitions.setdefault(name, []).append(definition)


def _message(
    file: str, source: SourceIndex, declaration: Declaration, parent: Message | None
) -> Message:
    """The model of a declared message. A map entry and its key and value have no source of their
    own: they are located at the map field of ``parent`` that uses the entry."""
    proto = declaration.proto
    assert isinstance(proto, descriptor_pb2.DescriptorProto)
    name, map_entry = declaration.name, proto.options.map_entry
    users = [f for f in parent.fields.values() if f.type == name] if parent and map_entry else []
    declared = users[0].at if users else None
    model = Message(name, file, source, declared or declaration.path, map_entry)
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
            source=source,
            at=declared or declaration.member(j),
        )
        model.fields.setdefault(f.number, entry)
        model.by_name.setdefault(f.name, entry)
    # protoc's message ranges end before ``end``; enum ranges include it
    model.reserved.ranges.extend((r.start, r.end - 1) for r in proto.reserved_range)
    model.reserved.names.update(proto.reserved_name)
    return model


def _enum(revision: Revision, file: str, source: SourceIndex, declaration: Declaration) -> None:
    """Add a declared enum; its values take global names beside it (C++ scoping)."""
    proto = declaration.proto
    assert isinstance(proto, descriptor_pb2.EnumDescriptorProto)
    model = Enum(declaration.name, file, source, declaration.path)
    _define(revision, model.name, model)
    revision.enums.setdefault(model.name, model)
    for j, value in enumerate(proto.value):
        entry = EnumValue(model.name, value.name, value.number, source, declaration.member(j))
        _define(revision, declaration.scope + value.name, entry)
        model.values.setdefault(value.number, entry)
        model.by_name.setdefault(value.name, entry)
    model.reserved.ranges.extend((r.start, r.end) for r in proto.reserved_range)
    model.reserved.names.update(proto.reserved_name)


def type_of(f: descriptor_pb2.FieldDescriptorProto) -> tuple[str, str]:
    """A field's type as the rules name it (``float``, or a full name) and its kind."""
    kind = _KINDS.get(f.type, "scalar")
    return (f.type_name.lstrip(".") if kind != "scalar" else _SCALARS[f.type]), kind
