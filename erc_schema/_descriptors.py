"""The one walk over a compiled file's declarations, and where protoc says each one stands.

``declarations(file)`` yields every message and enum a ``FileDescriptorProto`` declares, nested
ones included, each with its full name and its path in the file's ``SourceCodeInfo``;
``extensions(file)`` every extension it declares (at the top or inside a message) and
``services(file)`` its services, each with its path too; a ``SourceIndex`` turns such a path into
a ``Location`` (and the comment trailing it). The numbers those paths are made of (the field
numbers of descriptor.proto's own messages) live here and nowhere else: a path to a member comes
from ``Declaration.member(j)``, ``Declaration.oneof(j)`` or ``Service.method(j)``.
"""

from collections.abc import Iterator, Sequence
from typing import NamedTuple

from google.protobuf import descriptor_pb2

__all__ = [
    "Declaration",
    "Extension",
    "Location",
    "Service",
    "SourceIndex",
    "declarations",
    "extensions",
    "services",
]

# Field numbers of FileDescriptorProto, DescriptorProto, EnumDescriptorProto and
# ServiceDescriptorProto, as SourceCodeInfo paths are made of them.
_FILE_MESSAGE, _FILE_ENUM, _FILE_SERVICE, _FILE_EXTENSION = 4, 5, 6, 7
_MESSAGE_FIELD, _MESSAGE_NESTED, _MESSAGE_ENUM, _MESSAGE_EXTENSION, _MESSAGE_ONEOF = 2, 3, 4, 6, 8
_ENUM_VALUE = 2
_SERVICE_METHOD = 2

Proto = descriptor_pb2.DescriptorProto | descriptor_pb2.EnumDescriptorProto
_MessageProto = descriptor_pb2.DescriptorProto  # a global, not a module attribute, per isinstance


class Location(NamedTuple):
    """Where a definition stands: a path as the user can open it, 1-based line and column."""

    path: str
    line: int
    column: int

    def __str__(self) -> str:
        return f"{self.path}:{self.line}:{self.column}"


class Declaration:
    """A message or enum declared in a file."""

    # Plain classes, this, Extension and Service: read by their attributes only, never as
    # tuples, and a NamedTuple class is slow to build at import.
    __slots__ = ("is_message", "name", "parent", "path", "proto", "scope")

    def __init__(
        self, name: str, proto: Proto, path: tuple[int, ...], parent: str | None, scope: str
    ) -> None:
        self.name = name  # full name: the package (if any), the enclosing messages, its own name
        self.proto = proto
        self.path = path  # its path in the file's SourceCodeInfo
        self.parent = parent  # the full name of the message it is declared in, None at the top
        self.scope = scope  # the prefix its enum values' global names take (C++: beside the enum)
        self.is_message = isinstance(proto, _MessageProto)

    def __repr__(self) -> str:
        return f"Declaration({self.name!r}, path={self.path!r})"

    def member(self, index: int) -> tuple[int, ...]:
        """The source path of the ``index``-th field of a message, or value of an enum."""
        return (*self.path, _MESSAGE_FIELD if self.is_message else _ENUM_VALUE, index)

    def oneof(self, index: int) -> tuple[int, ...]:
        """The source path of a message's ``index``-th oneof."""
        return (*self.path, _MESSAGE_ONEOF, index)

    def extensions(self) -> "list[Extension]":
        """The extensions declared inside a message (none for an enum)."""
        message = self.proto
        if not isinstance(message, descriptor_pb2.DescriptorProto) or not message.extension:
            return []
        return [
            Extension(
                f"{self.name}.{extension.name}",
                extension,
                (*self.path, _MESSAGE_EXTENSION, j),
                self.name,
            )
            for j, extension in enumerate(message.extension)
        ]


def declarations(file: descriptor_pb2.FileDescriptorProto) -> Iterator[Declaration]:
    """Every message and enum of ``file``: its top-level messages in order, each followed by what
    it declares (its messages, each with theirs, then its enums), then its top-level enums."""
    package = f"{file.package}." if file.package else ""
    for i, message in enumerate(file.message_type):
        yield from _message(package + message.name, message, (_FILE_MESSAGE, i), None, package)
    for i, enum in enumerate(file.enum_type):
        yield Declaration(package + enum.name, enum, (_FILE_ENUM, i), None, package)


def _message(
    name: str,
    proto: descriptor_pb2.DescriptorProto,
    path: tuple[int, ...],
    parent: str | None,
    scope: str,
) -> Iterator[Declaration]:
    # Depth first without recursion: messages nest as deeply as a file's author likes.
    pending: list[Declaration] = [Declaration(name, proto, path, parent, scope)]
    while pending:
        declaration = pending.pop()
        yield declaration
        outer, message = declaration.name, declaration.proto
        if not isinstance(message, _MessageProto):
            continue
        if not message.nested_type and not message.enum_type:
            continue  # most messages: nothing inside to walk
        inside: list[Declaration] = [
            Declaration(
                f"{outer}.{nested.name}",
                nested,
                (*declaration.path, _MESSAGE_NESTED, j),
                outer,
                f"{outer}.",
            )
            for j, nested in enumerate(message.nested_type)
        ]
        inside += [
            Declaration(
                f"{outer}.{enum.name}",
                enum,
                (*declaration.path, _MESSAGE_ENUM, j),
                outer,
                f"{outer}.",
            )
            for j, enum in enumerate(message.enum_type)
        ]
        pending.extend(reversed(inside))


class Extension:
    """An extension a file declares: ``extend Extendee { ... }`` at the top or inside a message."""

    __slots__ = ("name", "path", "proto", "scope")

    def __init__(
        self,
        name: str,
        proto: descriptor_pb2.FieldDescriptorProto,
        path: tuple[int, ...],
        scope: str | None,
    ) -> None:
        self.name = name  # full name: the package (if any), the message it is declared in, its own
        self.proto = proto  # its ``extendee``: the full name it extends
        self.path = path
        self.scope = scope  # the full name of the message it is declared in, None at the top

    def __repr__(self) -> str:
        return f"Extension({self.name!r}, path={self.path!r})"


def extensions(
    file: descriptor_pb2.FileDescriptorProto, nested: bool = True
) -> Iterator[Extension]:
    """Every extension of ``file``: those at its top first, then (unless ``nested`` is false)
    those of each message in the order ``declarations`` walks them (a caller walking the
    declarations anyway asks each one, ``Declaration.extensions()``)."""
    package = f"{file.package}." if file.package else ""
    for i, extension in enumerate(file.extension):
        yield Extension(package + extension.name, extension, (_FILE_EXTENSION, i), None)
    if nested:
        for declaration in declarations(file):
            yield from declaration.extensions()


class Service:
    """A service a file declares."""

    __slots__ = ("name", "path", "proto")

    def __init__(
        self, name: str, proto: descriptor_pb2.ServiceDescriptorProto, path: tuple[int, ...]
    ) -> None:
        self.name = name  # full name: the package (if any) and its own name
        self.proto = proto
        self.path = path

    def __repr__(self) -> str:
        return f"Service({self.name!r}, path={self.path!r})"

    def method(self, index: int) -> tuple[int, ...]:
        """The source path of the service's ``index``-th method."""
        return (*self.path, _SERVICE_METHOD, index)


def services(file: descriptor_pb2.FileDescriptorProto) -> Iterator[Service]:
    """Every service of ``file``, in order."""
    package = f"{file.package}." if file.package else ""
    for i, service in enumerate(file.service):
        yield Service(package + service.name, service, (_FILE_SERVICE, i))


class SourceIndex:
    """Where one file's declarations stand: protoc's source info, indexed on first use."""

    __slots__ = ("_locations", "_proto", "path")

    def __init__(self, path: str, proto: descriptor_pb2.FileDescriptorProto) -> None:
        self.path = path  # the file as locations name it
        self._proto: descriptor_pb2.FileDescriptorProto | None = proto
        self._locations: dict[tuple[int, ...], descriptor_pb2.SourceCodeInfo.Location] = {}

    def _index(self) -> dict[tuple[int, ...], descriptor_pb2.SourceCodeInfo.Location]:
        if self._proto is not None:
            # Declarations sit at even-length paths; the odd ones (names, numbers, types) are many.
            # Each location's path read once: every read of it makes a new container.
            locations = self._locations
            for loc in self._proto.source_code_info.location:
                path = loc.path
                if not len(path) % 2:
                    locations[tuple(path)] = loc
            self._proto = None
        return self._locations

    def find(self, at: Sequence[int]) -> Location | None:
        """The location of the declaration at source path ``at``, if protoc recorded one."""
        found = self._index().get(tuple(at))
        if found is None:
            return None
        return Location(self.path, found.span[0] + 1, found.span[1] + 1)

    def where(self, at: Sequence[int]) -> Location:
        """The location of the declaration at ``at``; the file's first line if protoc has none."""
        return self.find(at) or Location(self.path, 1, 1)

    def comment(self, at: Sequence[int]) -> str:
        """The comment trailing the declaration at ``at`` (``""`` if none)."""
        found = self._index().get(tuple(at))
        return found.trailing_comments.strip() if found is not None else ""
