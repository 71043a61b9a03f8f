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
import re
from collections.abc import Iterator, Sequence
from pathlib import Path

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from google.protobuf.descriptor import Descriptor, EnumDescriptor, FieldDescriptor
from google.protobuf.message import Message

from ._descriptors import Location, SourceIndex, declarations
from ._errors import SchemaError
from ._files import FileError, proto_files, read_text
from ._options import is_nanopb_vocabulary
from ._protoc import ProtocError, compile_files
from ._text import declared_names, package_name

__all__ = ["Schema", "descriptor_of", "enum_of", "load_schema", "message_of"]


class Schema:
    """The files a root message depends on, their descriptors, locations and message classes.

    ``files`` are the descriptors as protoc wrote them. The pool holds them too, except where
    protobuf's Python runtime refuses what protoc accepts (a message with more than 63 required
    fields, fields whose JSON names clash): there it holds a copy it can build (those required
    fields made optional, JSON names made the field names), sized like the original, and
    ``refused`` says why such a message has no class. ``include`` are the import folders
    searched after ``tree``; ``shown`` is where messages say the files are. ``files``: a set
    protoc wrote, or its files (each after its imports), which the schema reads and never
    changes.
    """

    def __init__(
        self,
        tree: Path,
        root: str,
        files: descriptor_pb2.FileDescriptorSet | Sequence[descriptor_pb2.FileDescriptorProto],
        include: Sequence[Path] = (),
        shown: Path | None = None,
    ) -> None:
        self.tree = tree
        self.include = tuple(include)
        self.shown = tree if shown is None else shown  # where messages say the files are
        # A sequence of files is taken as it is: a caller holding them need not copy them into a
        # FileDescriptorSet.
        if isinstance(files, descriptor_pb2.FileDescriptorSet):
            files = files.file
        self.files = tuple(files)
        # The tree's own files, judged now: a git revision's scratch folder is gone once loaded;
        # a copy of nanopb.proto or descriptor.proto it ships is a vocabulary, not its schema.
        self._own = tuple(
            proto
            for proto in self.files
            if (tree / proto.name).is_file() and not _vocabulary(proto)
        )
        self.pool = descriptor_pool.DescriptorPool()
        self.refused: dict[str, str] = {}  # full message name -> why the runtime has no class
        for proto in self.files:
            _add(self.pool, proto, self.refused)
        self.root: Descriptor = self.pool.FindMessageTypeByName(root)
        self._classes: dict[str, type[Message]] = {}
        # full message name -> its longest chain of message fields: length, first field
        self._depths: dict[str, tuple[int, FieldDescriptor | None]] = {}

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

    def message_class(self, name: str, lenient: bool = False) -> type[Message]:
        """The message class for a full message name, e.g. ``SensorBoardGPSInfo``;
        ``SchemaError`` when protobuf's Python runtime cannot build it (see ``refused``), unless
        ``lenient``: then the class of the copy the pool holds (required fields optional, JSON
        names the field names), for a caller that refuses to encode or decode such a message
        itself (a codec)."""
        cls = self._classes.get(name)
        if cls is None:
            descriptor = self.descriptor(name)
            if self.refused and not lenient:
                self._buildable(descriptor)
            self._decodable(descriptor)
            try:
                cls = message_factory.GetMessageClass(descriptor)
            except RecursionError:  # the runtime builds the classes a message reaches recursively
                raise SchemaError(
                    f"{self.where(name)}: {name} nests messages too deeply for protobuf's Python "
                    "runtime to build its class (nanopb's sizes still hold)"
                ) from None
            if not (lenient and self.refused):  # unchecked: a strict call must still check
                self._classes[name] = cls
        return cls

    def _decodable(self, descriptor: Descriptor) -> None:
        """``SchemaError`` if messages nest deeper in ``descriptor`` than protobuf's runtime
        decodes (upb and the pure-Python runtime alike stop at ``_LIMIT_DEPTH``: "Exceeded
        upb_DecodeOptions_MaxDepth"). nanopb decodes any depth, so such a codec would send what
        it cannot read back; refusing it at load names the path once instead of failing on the
        first deep datagram. Lifting the limit is no way out: upb's only switch,
        ``SetAllowOversizeProtos``, is global to the process (every other user of protobuf in it)
        and the other runtimes have none."""
        chain = self._deepest(descriptor)
        if len(chain) <= _LIMIT_DEPTH:
            return
        names = [field.name for field in chain]
        shown = ".".join(names[:3]) + f".(... {len(names) - 5} more ...)." + ".".join(names[-2:])
        raise SchemaError(
            f"{self.where(chain[-1].full_name)}: {descriptor.full_name} nests messages too deeply "
            f"for protobuf's Python runtime to decode: {descriptor.full_name}.{shown} is "
            f"{len(chain)} messages deep, it decodes at most {_LIMIT_DEPTH} (nanopb's sizes "
            "still hold)"
        )

    def _deepest(self, descriptor: Descriptor) -> list[FieldDescriptor]:
        """The longest chain of message fields from ``descriptor`` (a field leading back into
        the chain, a message containing itself, is not followed)."""
        best = self._depths
        pending: list[tuple[Descriptor, bool]] = [(descriptor, False)]
        open_now: set[str] = set()  # on the current path, without recursion: nesting is deep
        while pending:
            message, inside_done = pending.pop()
            name = message.full_name
            if inside_done:
                open_now.discard(name)
                deepest: tuple[int, FieldDescriptor | None] = (0, None)
                for field in message.fields:
                    sub = field.message_type
                    below = best.get(sub.full_name) if sub is not None else None
                    if below is not None and below[0] + 1 > deepest[0]:
                        deepest = (below[0] + 1, field)
                best[name] = deepest
            elif name not in best and name not in open_now:
                open_now.add(name)
                pending.append((message, True))
                for field in message.fields:
                    sub = field.message_type
                    if (
                        sub is not None
                        and sub.full_name not in best
                        and sub.full_name not in open_now
                    ):
                        pending.append((sub, False))
        chain: list[FieldDescriptor] = []
        step = best[descriptor.full_name][1]
        while step is not None:
            chain.append(step)
            step = best[message_of(step).full_name][1]
        return chain

    def _buildable(self, descriptor: Descriptor) -> None:
        """``SchemaError`` if ``descriptor`` is, or reaches, a message the runtime refused."""
        pending, seen = [(descriptor, descriptor.full_name)], {descriptor.full_name}
        while pending:
            message, path = pending.pop()
            why = self.refused.get(message.full_name)
            if why is not None:
                reached = "" if path == descriptor.full_name else f" (reached as {path})"
                raise SchemaError(
                    f"{self.where(message.full_name)}: {message.full_name}{reached}: {why}; "
                    "protobuf's Python runtime cannot encode or decode it (nanopb's sizes "
                    "still hold)"
                )
            for field in message.fields:
                sub = field.message_type
                if sub is not None and sub.full_name not in seen:
                    seen.add(sub.full_name)
                    pending.append((sub, f"{path}.{field.name}"))

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
        nanopb.proto) are imports, not part of the tree, and are left out, as are the option
        vocabularies a tree ships itself (its nanopb.proto, its google/protobuf/descriptor.proto):
        nanopb's generator is run on a tree's own files, not on those.
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
    """Compile the file under ``tree`` that defines message ``root`` (its full name, package
    included), with what it imports; ``include`` are further import folders, searched after
    ``tree`` (protoc's and nanopb's ``-I``). Where two files of the tree define ``root`` (copies
    never compiled together), ``root`` may name the file: ``"copies/b.proto:Env"``. ``shown`` is
    where messages and locations say the tree is (a git revision's repository, where ``tree`` is
    a scratch copy)."""
    base = Path(tree)
    if not base.is_dir():
        raise SchemaError(f"{base}: not a directory holding a proto tree")
    folders = [Path(folder) for folder in include]
    for folder in folders:
        if not folder.is_dir():
            raise SchemaError(f"{folder}: include folder is not a directory")
    file, colon, root = root.rpartition(":")
    short = root.rpartition(".")[2]
    # A map's entry type (Msg.CountsEntry: nanopb generates it, with its size) is written in no
    # file's text: the message holding the map is.
    outer = root.rpartition(".")[0].rpartition(".")[2] if short.endswith("Entry") else short
    names = [file] if colon else proto_files(base)
    if colon and not (base / file).is_file():
        raise SchemaError(f"{base / file}: no such .proto file in the tree")
    candidates = [
        name
        for name in names
        if {short, outer} & declared_names(read_text(base / name, errors="replace"))
    ]
    found: list[tuple[str, descriptor_pb2.FileDescriptorSet]] = []
    failure: SchemaError | None = None
    for name in candidates:
        try:
            compiled = compile_files(base, [name], includes=folders)
        except FileError:
            raise  # a file protoc would read is refused: the tree is, whatever defines the root
        except SchemaError as error:
            _require_one_root(error, name, root, named=bool(colon))
            failure = failure or error
            continue
        if any(d.name == root and d.is_message for d in declarations(compiled.file[-1])):
            found.append((name, compiled))
    if len(found) > 1:
        raise SchemaError(
            f"message {root} is defined in both {found[0][0]} and {found[1][0]}: "
            f"name the file, e.g. {found[0][0]}:{root}"
        )
    if found:
        return Schema(base, root, found[0][1], folders, None if shown is None else Path(shown))
    if failure is not None:
        raise failure
    raise SchemaError(f"{base}: no .proto file defines message {root}{_hint(base, root)}")


def _require_one_root(error: SchemaError, name: str, root: str, named: bool) -> None:
    """``SchemaError`` when protoc refused ``name`` because it defines ``root`` again beside a
    file it imports (the two copies are compiled together), unless the caller ``named`` the
    file: which copy is meant is the caller's to say. Any other refusal is left to the caller."""
    if named:
        return
    clash = re.compile(rf'^(.*?): "{re.escape(root)}" is already defined in file "(.+)"\.$')
    lines = error.lines if isinstance(error, ProtocError) else []
    twice = next((found for found in map(clash.match, lines) if found), None)
    if twice is not None:
        where, other = twice[1], twice[2]
        raise SchemaError(
            f"message {root} is defined in both {name} and {other}, which are compiled together "
            f"({where}: {root} is already defined in {other}): name the file, e.g. {other}:{root}"
        )


def _hint(base: Path, root: str) -> str:
    """``" (did you mean pkg.Root?)"`` when ``root`` is a short name some package declares."""
    if "." in root:
        return ""
    for name in proto_files(base):
        text = read_text(base / name, errors="replace")
        package = package_name(text)
        if package and root in declared_names(text):
            return f" (did you mean {package}.{root}? a root is named in full)"
    return ""


_LIMIT_REQUIRED = 63  # upb's mini tables hold at most this many required fields per message
_LIMIT_DEPTH = 100  # protobuf's runtimes decode messages nested at most this deep


def _vocabulary(proto: descriptor_pb2.FileDescriptorProto) -> bool:
    """Whether ``proto`` is an option vocabulary, not part of a schema: protobuf's
    descriptor.proto, or a copy of nanopb.proto under any name (the file that extends
    ``google.protobuf.FieldOptions`` with nanopb's ``(nanopb)``, number 1010)."""
    return proto.name == "google/protobuf/descriptor.proto" or is_nanopb_vocabulary(proto)


def _add(
    pool: descriptor_pool.DescriptorPool,
    proto: descriptor_pb2.FileDescriptorProto,
    refused: dict[str, str],
) -> None:
    """Add ``proto`` to ``pool``; where the runtime refuses it, a copy it builds, noting in
    ``refused`` which messages differ and why."""
    try:
        pool.AddSerializedFile(proto.SerializeToString())
        return
    except TypeError as error:
        first = str(error)
    copy = descriptor_pb2.FileDescriptorProto()
    copy.CopyFrom(proto)
    for declaration in declarations(copy):
        message = declaration.proto
        if not isinstance(message, descriptor_pb2.DescriptorProto):
            continue
        required = [f for f in message.field if f.label == f.LABEL_REQUIRED]
        if len(required) > _LIMIT_REQUIRED:
            for field in required:
                field.label = field.LABEL_OPTIONAL
            refused[declaration.name] = (
                f"{len(required)} required fields, more than the {_LIMIT_REQUIRED} protobuf's "
                "Python runtime builds a class with"
            )
        by_json: dict[str, str] = {}
        for field in message.field:
            other = by_json.setdefault(field.json_name, field.name)
            if other != field.name:
                refused.setdefault(
                    declaration.name,
                    f"fields {other} and {field.name} share the JSON name {field.json_name!r}",
                )
        if declaration.name in refused:
            for field in message.field:
                field.json_name = field.name
    try:
        pool.AddSerializedFile(copy.SerializeToString())
    except TypeError:
        raise SchemaError(
            f"{proto.name}: protobuf's Python runtime cannot load it: {first}"
        ) from None


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
