"""A proto tree, compiled in-process, as a descriptor pool with source locations.

Loading starts from the message the caller names as the root: the one file that defines it is
compiled with everything it imports, and nothing else. Unrelated files in the tree (a leftover enum
whose values collide with message names, a half-written draft) therefore never stop loading, while
any problem in a file the root depends on is a ``SchemaError`` carrying protoc's ``path:line:col``.
"""

import functools
import os
import re
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from google.protobuf.descriptor import Descriptor, EnumDescriptor, FieldDescriptor
from google.protobuf.message import Message

from ._errors import SchemaError
from ._protoc import compile_files

__all__ = ["Location", "Schema", "descriptor_of", "enum_of", "load_schema", "message_of"]

# Field numbers of FileDescriptorProto / DescriptorProto / EnumDescriptorProto members, as they
# appear in SourceCodeInfo paths.
_FILE_MESSAGE, _FILE_ENUM = 4, 5
_MESSAGE_FIELD, _MESSAGE_NESTED, _MESSAGE_ENUM = 2, 3, 4
_ENUM_VALUE = 2

_NOISE = re.compile(r'"(?:\\.|[^"\\\n])*"|\'(?:\\.|[^\'\\\n])*\'|//[^\n]*|/\*.*?\*/', re.DOTALL)


class Location(NamedTuple):
    """Where a definition stands: a path as the user can open it, 1-based line and column."""

    path: str
    line: int
    column: int

    def __str__(self) -> str:
        return f"{self.path}:{self.line}:{self.column}"


class Schema:
    """The files a root message depends on, their descriptors, locations and message classes."""

    def __init__(self, tree: Path, root: str, files: descriptor_pb2.FileDescriptorSet) -> None:
        self.tree = tree
        self.files = tuple(files.file)
        self.pool = descriptor_pool.DescriptorPool()
        for proto in self.files:
            self.pool.AddSerializedFile(proto.SerializeToString())
        self.root: Descriptor = self.pool.FindMessageTypeByName(root)
        self._classes: dict[str, type[Message]] = {}

    @functools.cached_property
    def locations(self) -> dict[str, Location]:
        """Full name → where a message, field, enum or enum value is defined."""
        return self._index[0]

    @functools.cached_property
    def comments(self) -> dict[str, str]:
        """Full name → the comment trailing a definition."""
        return self._index[1]

    @functools.cached_property
    def _index(self) -> tuple[dict[str, Location], dict[str, str]]:
        locations: dict[str, Location] = {}
        comments: dict[str, str] = {}
        for proto in self.files:
            _index(self.tree, proto, locations, comments)
        return locations, comments

    def message_class(self, name: str) -> type[Message]:
        """The message class for a full message name, e.g. ``SensorBoardGPSInfo``."""
        cls = self._classes.get(name)
        if cls is None:
            cls = self._classes[name] = message_factory.GetMessageClass(self.descriptor(name))
        return cls

    def descriptor(self, name: str) -> Descriptor:
        """The descriptor of a full message name, without building classes for it and every
        message it reaches."""
        try:
            return self.pool.FindMessageTypeByName(name)
        except KeyError:
            raise SchemaError(f"no message named {name!r} in the schema") from None

    def messages(self) -> Iterator[Descriptor]:
        """Every message the tree's loaded files define, nested ones included, in file order.

        Files found on protoc's other search paths (google/protobuf/*, erc-codec's stand-in
        nanopb.proto) are imports, not part of the tree, and are left out.
        """
        for proto in self.files:
            if not (self.tree / proto.name).is_file():
                continue
            file = self.pool.FindFileByName(proto.name)
            stack = list(file.message_types_by_name.values())[::-1]
            while stack:
                message = stack.pop()
                yield message
                stack.extend(reversed(message.nested_types))

    def where(self, full_name: str) -> str:
        """``path:line:col`` of a definition, or its name alone when protoc gave no location."""
        location = self.locations.get(full_name)
        return str(location) if location else full_name


def load_schema(tree: str | os.PathLike[str], root: str = "PBEnvelope") -> Schema:
    """Compile the file under ``tree`` that defines message ``root``, with what it imports."""
    base = Path(tree)
    if not base.is_dir():
        raise SchemaError(f"{base}: not a directory holding a proto tree")
    candidates = [
        path.relative_to(base).as_posix()
        for path in sorted(base.rglob("*.proto"))
        if _mentions_message(path, root.rpartition(".")[2])
    ]
    found: list[tuple[str, descriptor_pb2.FileDescriptorSet]] = []
    failure: SchemaError | None = None
    for name in candidates:
        try:
            compiled = compile_files(base, [name])
        except SchemaError as error:
            failure = failure or error
            continue
        if _defines(compiled.file[-1], root):
            found.append((name, compiled))
    if len(found) > 1:
        raise SchemaError(f"message {root} is defined in both {found[0][0]} and {found[1][0]}")
    if found:
        return Schema(base, root, found[0][1])
    if failure is not None:
        raise failure
    raise SchemaError(f"{base}: no .proto file defines message {root}")


def _mentions_message(path: Path, short_name: str) -> bool:
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as error:
        raise SchemaError(f"{path}: cannot read: {error.strerror}") from None
    code = _NOISE.sub(" ", text)
    return re.search(rf"\bmessage\s+{re.escape(short_name)}\s*\{{", code) is not None


def _defines(proto: descriptor_pb2.FileDescriptorProto, root: str) -> bool:
    prefix = f"{proto.package}." if proto.package else ""
    return root in {prefix + name for name, _ in _message_names(proto)}


def _message_names(
    proto: descriptor_pb2.FileDescriptorProto,
) -> Iterator[tuple[str, tuple[int, ...]]]:
    stack: list[tuple[str, descriptor_pb2.DescriptorProto, tuple[int, ...]]] = [
        (m.name, m, (_FILE_MESSAGE, i)) for i, m in enumerate(proto.message_type)
    ]
    while stack:
        name, message, path = stack.pop()
        yield name, path
        for j, nested in enumerate(message.nested_type):
            stack.append((f"{name}.{nested.name}", nested, (*path, _MESSAGE_NESTED, j)))


def _index(
    tree: Path,
    proto: descriptor_pb2.FileDescriptorProto,
    found: dict[str, Location],
    comments: dict[str, str],
) -> None:
    """Record the location and trailing comment of every message, field, enum and enum value.

    Enum values are keyed under their enum (``Enum.VALUE``), though C++ scoping puts them beside it.
    """
    sources = {tuple(loc.path): loc for loc in proto.source_code_info.location}
    path_text = str(tree / proto.name)
    prefix = f"{proto.package}." if proto.package else ""

    def put(name: str, path: tuple[int, ...]) -> None:
        source = sources.get(path)
        if source is not None:
            found[prefix + name] = Location(path_text, source.span[0] + 1, source.span[1] + 1)
            if source.trailing_comments.strip():
                comments[prefix + name] = source.trailing_comments.strip()

    def put_enum(
        name: str, enum: descriptor_pb2.EnumDescriptorProto, path: tuple[int, ...]
    ) -> None:
        put(name, path)
        for k, value in enumerate(enum.value):
            put(f"{name}.{value.name}", (*path, _ENUM_VALUE, k))

    for i, enum in enumerate(proto.enum_type):
        put_enum(enum.name, enum, (_FILE_ENUM, i))
    lookup = {path: name for name, path in _message_names(proto)}
    for path, name in lookup.items():
        put(name, path)
        message = _at(proto, path)
        for j, field in enumerate(message.field):
            put(f"{name}.{field.name}", (*path, _MESSAGE_FIELD, j))
        for j, enum in enumerate(message.enum_type):
            put_enum(f"{name}.{enum.name}", enum, (*path, _MESSAGE_ENUM, j))


def _at(
    proto: descriptor_pb2.FileDescriptorProto, path: tuple[int, ...]
) -> descriptor_pb2.DescriptorProto:
    message = proto.message_type[path[1]]
    for index in path[3::2]:
        message = message.nested_type[index]
    return message


def descriptor_of(cls: type[Message]) -> Descriptor:
    """The descriptor of a message class."""
    return cls.DESCRIPTOR  # type: ignore[return-value]  # stubs: upb's Descriptor is the same type


def message_of(field: FieldDescriptor) -> Descriptor:
    """The message type of a message field."""
    assert field.message_type is not None, f"{field.full_name} is not a message field"
    return field.message_type


def enum_of(field: FieldDescriptor) -> EnumDescriptor:
    """The enum type of an enum field."""
    assert field.enum_type is not None, f"{field.full_name} is not an enum field"
    return field.enum_type
