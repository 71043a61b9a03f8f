"""A proto tree, compiled in-process, as a descriptor pool with source locations.

Loading starts from the message the caller names as the root: the one file that defines it is
compiled with everything it imports, and nothing else. Unrelated files in the tree (a leftover enum
whose values collide with message names, a half-written draft) therefore never stop loading, while
any problem in a file the root depends on is a ``SchemaError`` carrying protoc's ``path:line:col``.
Every ``.proto`` of the tree is read to find the root, each through ``read_file`` (a FIFO, a
device or a file over ``SOURCE_LIMIT`` is refused, naming it); symlinked folders are not entered.
"""

import functools
import os
from collections.abc import Iterator, Sequence
from pathlib import Path

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from google.protobuf.descriptor import Descriptor, EnumDescriptor, FieldDescriptor
from google.protobuf.message import Message

from .._errors import SchemaError
from ._descriptors import Location, SourceIndex, declarations
from ._files import FileError, proto_files, read_text
from ._protoc import compile_files
from ._text import declared_names

__all__ = ["Schema", "descriptor_of", "enum_of", "load_schema", "message_of"]


class Schema:
    """The files a root message depends on, their descriptors, locations and message classes."""

    def __init__(
        self,
        tree: Path,
        root: str,
        files: descriptor_pb2.FileDescriptorSet,
        shown: Path | None = None,
    ) -> None:
        self.tree = tree
        self.shown = tree if shown is None else shown  # where messages say the files are
        self.files = tuple(files.file)
        # The tree's own files, judged now: a git revision's scratch folder is gone once loaded.
        self._own = tuple(proto for proto in self.files if (tree / proto.name).is_file())
        self.pool = descriptor_pool.DescriptorPool()
        for proto in self.files:
            self.pool.AddSerializedFile(proto.SerializeToString())
        self.root: Descriptor = self.pool.FindMessageTypeByName(root)
        self._classes: dict[str, type[Message]] = {}

    @functools.cached_property
    def _declared(self) -> dict[str, tuple[SourceIndex, tuple[int, ...]]]:
        """Full name → the source index of its file and its path there, for every message,
        field, enum and enum value (values keyed under their enum: ``Enum.VALUE``)."""
        found: dict[str, tuple[SourceIndex, tuple[int, ...]]] = {}
        for proto in self.files:
            source = SourceIndex(str(self.shown / proto.name), proto)
            for declaration in declarations(proto):
                found[declaration.name] = (source, declaration.path)
                element = declaration.proto
                names = [
                    member.name
                    for member in (
                        element.field
                        if isinstance(element, descriptor_pb2.DescriptorProto)
                        else element.value
                    )
                ]
                for j, name in enumerate(names):
                    found[f"{declaration.name}.{name}"] = (source, declaration.member(j))
        return found

    def location(self, full_name: str) -> Location | None:
        """Where a message, field, enum or enum value is defined, if protoc recorded it."""
        found = self._declared.get(full_name)
        return found[0].find(found[1]) if found is not None else None

    def comment(self, full_name: str) -> str:
        """The comment trailing a definition (``""`` if none)."""
        found = self._declared.get(full_name)
        return found[0].comment(found[1]) if found is not None else ""

    def where(self, full_name: str) -> str:
        """``path:line:col`` of a definition, or its name alone when protoc gave no location."""
        location = self.location(full_name)
        return str(location) if location else full_name

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
        for proto in self._own:
            for declaration in declarations(proto):
                if declaration.is_message:
                    yield self.pool.FindMessageTypeByName(declaration.name)


def load_schema(
    tree: str | os.PathLike[str],
    root: str = "PBEnvelope",
    include: Sequence[str | os.PathLike[str]] = (),
    shown: str | os.PathLike[str] | None = None,
) -> Schema:
    """Compile the file under ``tree`` that defines message ``root``, with what it imports
    (searched in ``tree``, then in the ``include`` folders); ``shown`` is where messages and
    locations say the tree is (a git revision's repository, where ``tree`` is a scratch copy)."""
    base = Path(tree)
    if not base.is_dir():
        raise SchemaError(f"{base}: not a directory holding a proto tree")
    short = root.rpartition(".")[2]
    candidates = [
        name
        for name in proto_files(base)
        if short in declared_names(read_text(base / name, errors="replace"))
    ]
    found: list[tuple[str, descriptor_pb2.FileDescriptorSet]] = []
    failure: SchemaError | None = None
    for name in candidates:
        try:
            compiled = compile_files(base, [name], [Path(folder) for folder in include])
        except FileError:
            raise  # a file protoc would read is refused: the tree is, whatever defines the root
        except SchemaError as error:
            failure = failure or error
            continue
        if any(d.name == root and d.is_message for d in declarations(compiled.file[-1])):
            found.append((name, compiled))
    if len(found) > 1:
        raise SchemaError(f"message {root} is defined in both {found[0][0]} and {found[1][0]}")
    if found:
        return Schema(base, root, found[0][1], None if shown is None else Path(shown))
    if failure is not None:
        raise failure
    raise SchemaError(f"{base}: no .proto file defines message {root}")


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
