"""One revision of a proto tree as the rules see it: messages, enums, services, their members and
locations, and what nanopb makes of them (maximum sizes, bounds, options).

Built from the descriptors the loader compiled, whatever their syntax: proto2, proto3 and every
edition protoc compiles read the same. What decides how bytes are read is resolved per element as
protoc resolves it (``_features``): a field is ``required`` when its presence is
``LEGACY_REQUIRED`` (proto2's ``required`` or the editions feature), a message field is a group
when it is ``DELIMITED``, an enum is closed or open, a string field verifies UTF-8 or not.
Extensions are fields of the message they extend (``Message.extensions``), located where they are
declared; a message the tree extends without defining it is held in ``Revision.extended``.

Every element has the ``Location`` of its definition, read from protoc's source info when first
asked for (nearly none ever are: only findings need one); names are full names (``Outer.Inner``;
a package, if a file has one, in front). Sizes and nanopb options are computed when a rule first
asks, once per revision (and root).
"""

from collections import deque
from collections.abc import Iterator, Sequence
from itertools import zip_longest
from pathlib import Path
from typing import NamedTuple

from google.protobuf import descriptor_pb2

from erc_schema import (
    NANOPB_VERSIONS,
    Declaration,
    Extension,
    FileError,
    Location,
    Options,
    ResolvedOptions,
    Schema,
    SchemaError,
    Sizes,
    SourceIndex,
    declarations,
    declared_names,
    extensions,
    is_nanopb_vocabulary,
    options_path,
    read_file,
    resolve_options,
    services,
)
from erc_schema import Service as DeclaredService

from ._features import Features, edition_of, file_features
from ._loader import LoadedTree, LoadProblem, relative

__all__ = [
    "Definition",
    "Enum",
    "EnumValue",
    "Field",
    "Message",
    "Method",
    "Revision",
    "Service",
    "allocation",
    "build",
    "type_of",
]

_FD = descriptor_pb2.FieldDescriptorProto
_SCALARS = {
    number: name.removeprefix("TYPE_").lower()
    for name, number in _FD.Type.items()
    if name not in ("TYPE_MESSAGE", "TYPE_ENUM", "TYPE_GROUP")
}
# A proto2 group is a message type as far as the wire and the rules go.
_KINDS = {_FD.TYPE_MESSAGE: "message", _FD.TYPE_GROUP: "message", _FD.TYPE_ENUM: "enum"}
_IDEMPOTENCY = descriptor_pb2.MethodOptions.IdempotencyLevel
_new_field = tuple.__new__
_Files = dict[str, descriptor_pb2.FileDescriptorProto]
_Proto = descriptor_pb2.DescriptorProto | descriptor_pb2.EnumDescriptorProto
# How a message field's encoding is named, as buf names it in a type: a proto2 group, an editions
# field with ``message_encoding = DELIMITED`` (the same bytes), or a length-prefixed message.
_GROUP, _DELIMITED, _LENGTH_PREFIXED = "group", "message (delimited encoding)", "message"


class Field(NamedTuple):
    owner: str  # the message it is a field of (an extension: the message it extends)
    name: str  # an extension's is its full name (``Scope.ext``), as buf names it
    number: int
    type: str  # "float", "sint32", … or the full name of a message or enum
    kind: str  # "scalar", "message" or "enum"
    cardinality: str  # "optional", "repeated" or "required" (presence LEGACY_REQUIRED)
    oneof: str | None  # the real oneof it belongs to (not a proto3 `optional`'s)
    source: SourceIndex
    at: tuple[int, ...]  # its source-info path (a map entry's fields: their map field's)
    encoding: str = ""  # a message field's: "group", "message (delimited encoding)", "message"
    default: str | None = None  # an explicit default, as protoc writes it
    utf8: bool = False  # a string field's readers reject what is not UTF-8 (VERIFY)
    json_name: str = ""
    extension: bool = False

    @property
    def location(self) -> Location:
        return self.source.where(self.at)

    @property
    def delimited(self) -> bool:
        """Whether the field's message travels between start- and end-group tags."""
        return self.encoding in (_GROUP, _DELIMITED)

    @property
    def noun(self) -> str:
        """How a message names it: ``Field`` or ``Extension`` (buf's words)."""
        return "Extension" if self.extension else "Field"


class EnumValue:
    # Plain classes, this and Method, as Message and Enum are: nothing reads one as a tuple, and
    # a NamedTuple class is slow to build at import.
    __slots__ = ("at", "name", "number", "owner", "source")

    kind = "enum value"

    def __init__(
        self, owner: str, name: str, number: int, source: SourceIndex, at: tuple[int, ...]
    ) -> None:
        self.owner = owner
        self.name = name
        self.number = number
        self.source = source
        self.at = at

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
    __slots__ = (
        "at",
        "by_name",
        "extension_ranges",
        "extensions",
        "extensions_by_name",
        "fields",
        "file",
        "map_entry",
        "name",
        "oneofs",
        "reserved",
        "reserved_extensions",
        "source",
    )

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
        self.oneofs: dict[str, tuple[int, ...]] = {}  # real oneofs, with their source paths
        self.extension_ranges: list[tuple[int, int]] = []  # inclusive
        self.reserved_extensions: set[int] = set()  # declared `reserved: true` in a range
        self.extensions: dict[int, Field] = {}  # the tree's extensions of this message
        self.extensions_by_name: dict[str, Field] = {}

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
    __slots__ = ("at", "by_name", "closed", "file", "name", "reserved", "source", "values")

    kind = "enum"

    def __init__(
        self, name: str, file: str, source: SourceIndex, at: tuple[int, ...], closed: bool = False
    ) -> None:
        self.name = name
        self.file = file
        self.source = source
        self.at = at
        self.closed = closed  # an undeclared number is an unknown field, not a value
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


class Method:
    __slots__ = (
        "at",
        "client_streaming",
        "idempotency",
        "input",
        "name",
        "output",
        "server_streaming",
        "service",
        "source",
    )

    def __init__(
        self,
        service: str,
        name: str,
        input: str,
        output: str,
        client_streaming: bool,
        server_streaming: bool,
        idempotency: str,
        source: SourceIndex,
        at: tuple[int, ...],
    ) -> None:
        self.service = service
        self.name = name
        self.input = input  # full names of the request and response messages
        self.output = output
        self.client_streaming = client_streaming
        self.server_streaming = server_streaming
        self.idempotency = idempotency  # "IDEMPOTENCY_UNKNOWN", "NO_SIDE_EFFECTS" or "IDEMPOTENT"
        self.source = source
        self.at = at

    @property
    def location(self) -> Location:
        return self.source.where(self.at)


class Service:
    __slots__ = ("at", "file", "methods", "name", "source")

    def __init__(self, name: str, file: str, source: SourceIndex, at: tuple[int, ...]) -> None:
        self.name = name
        self.file = file
        self.source = source
        self.at = at
        self.methods: dict[str, Method] = {}

    @property
    def location(self) -> Location:
        return self.source.where(self.at)


Definition = Message | Enum | EnumValue


class Revision:
    """One side of a comparison: its messages, enums, services and global names, and the
    questions rules ask of them (what a root reaches, nanopb's options and sizes, what a field
    reads as while absent, what a broken file declares)."""

    __slots__ = (
        "_failed_names",
        "_files",
        "_grouped",
        "_has_options",
        "_nanopb",
        "_nanopb_version",
        "_options_file",
        "_options_paths",
        "_refusals",
        "_settings",
        "_sizes",
        "definitions",
        "enums",
        "extended",
        "messages",
        "services",
        "tree",
    )

    def __init__(
        self,
        tree: LoadedTree,
        options_file: str = "%s.options",
        settings: Sequence[str] = (),
        nanopb_version: str = NANOPB_VERSIONS[0],
    ) -> None:
        self.tree = tree
        # nanopb's generator's -f and -s (its -I are the tree's include folders), and whose
        # generator's sizing rules apply
        self._options_file = options_file
        self._settings = tuple(settings)
        self._nanopb_version = nanopb_version
        self.messages: dict[str, Message] = {}
        self.enums: dict[str, Enum] = {}
        self.services: dict[str, Service] = {}
        # Messages the tree extends but does not define, each holding only its extensions here.
        self.extended: dict[str, Message] = {}
        # Every global name a definition takes (C++ scoping: enum values beside their enum).
        self.definitions: dict[str, list[Definition]] = {}
        self._files: dict[str, _Files] = {}  # by root: what protoc resolved its types in
        self._grouped: dict[str, bool] = {}  # by file: whether it declares a proto2 group
        self._options_paths: dict[str, Path | None] = {}  # by file: its .options file, if any
        self._nanopb: ResolvedOptions | None = None  # nanopb's options, when first asked
        self._has_options: bool | None = None  # whether anything sets one, when first asked
        self._sizes: dict[str, int | None] = {}  # by root: nanopb's size, when first asked
        self._refusals: dict[str, str] = {}  # by root without a size: the generator refuses it
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
        queue = deque([(root, root)])
        while queue:
            name, path = queue.popleft()
            message = self.messages.get(name)
            if message is None:
                continue
            for entry in sorted(message.fields.values(), key=lambda f: f.number):
                here = f"{path}.{entry.name}"
                yield here, entry
                if entry.kind == "message" and entry.type not in seen:
                    seen.add(entry.type)
                    queue.append((entry.type, here))

    def allocation(self, field: Field) -> str:
        """How nanopb stores ``field`` (``allocation``): ``static``, ``callback``, ``pointer`` or
        ``ignore``."""
        options = self._field_options(field)
        return "static" if options is None else allocation(field, options)

    def enum_options(self, name: str) -> Options | None:
        """nanopb's resolved options for enum ``name`` (its file's or message's included), if
        the tree or what it imports declares it."""
        return self.nanopb().enums.get(name)

    def nanopb(self) -> ResolvedOptions:
        """nanopb's options for every message, field and oneof of the tree (and what it
        imports), resolved from ``.options`` files and annotations as the generator does."""
        if self._nanopb is None:
            self._nanopb = resolve_options(
                self.root,
                tuple(self.tree.imported.values()),
                self.tree.includes,
                self._options_file,
                self._settings,
            )
        return self._nanopb

    def has_nanopb_options(self) -> bool:
        """Whether anything sets a nanopb option: a generator setting, an options file of one of
        the files (found as the generator finds it), or nanopb.proto under any name among the
        files protoc read (annotations: what imports it may set options). Without any, every
        option of every field is nanopb's default, and resolving them would show nothing."""
        if self._has_options is None:
            files = self.tree.imported.values()
            self._has_options = (
                bool(self._settings)
                or any(map(is_nanopb_vocabulary, files))
                or any(self._options_path(file.name) is not None for file in files)
            )
        return self._has_options

    def field_options(self, field: Field) -> Options:
        """nanopb's resolved options for a field or extension (defaults where nothing
        applies)."""
        options = self._field_options(field)
        assert options is not None, field  # every field and extension of the tree has some
        return options

    def _field_options(self, field: Field) -> Options | None:
        resolved = self.nanopb()
        if field.extension:  # an extension's name is its full name
            return resolved.extensions.get(field.name)
        return resolved.fields.get(f"{field.owner}.{field.name}")

    def oneof_options(self, message: str, oneof: str) -> Options:
        """nanopb's resolved options for a oneof (its message's and file's included)."""
        return self.nanopb().oneofs[f"{message}.{oneof}"]

    def default(self, field: Field) -> tuple[object, str]:
        """What a reader of ``field`` holds while the field is absent, as a value to compare and
        as buf writes it: the explicit default, else the type's own (an enum's first value)."""
        if field.kind == "enum":
            short = field.type.rsplit(".", 1)[-1]
            values = self._enum_values(field.type)
            number = values.get(field.default or "", next(iter(values.values()), None))
            if number is None:  # no such enum among what protoc read: compare the names
                return field.default, f"{short}.{field.default}"
            name = field.default if field.default in values else next(iter(values))
            return number, f"{short}.{name}"
        if field.default is not None:
            text = field.default
        else:
            text = {"bool": "false", "string": "", "bytes": ""}.get(field.type, "0")
        if field.type in ("string", "bytes"):
            return text, f'"{text}"'
        if field.type in ("float", "double"):
            return text, text  # protoc writes them normalized: "1e+10", "inf", "nan"
        return {"false": 0, "true": 1}.get(text) if field.type == "bool" else int(text), text

    def _enum_values(self, name: str) -> dict[str, int]:
        """Enum ``name``'s values, by name in declaration order: the tree's, else those of a file
        it imports (from an include folder); none if protoc read no such enum."""
        enum = self.enums.get(name)
        if enum is not None:
            return {value.name: value.number for value in enum.by_name.values()}
        for file in self.tree.imported.values():
            if file.name not in self.tree.files:
                for declared in declarations(file):
                    proto = declared.proto
                    if declared.name == name and isinstance(
                        proto, descriptor_pb2.EnumDescriptorProto
                    ):
                        return {value.name: value.number for value in proto.value}
        return {}

    def max_size(self, root: str) -> int | None:
        """nanopb's ``<root>_size`` in this revision; ``None`` where nanopb has none (an
        unbounded field on the way) or the tree has no such message. Computed once per root:
        each computation builds a Schema."""
        if root in self._sizes:
            return self._sizes[root]
        files = self._root_files(root)
        size = None
        if files:
            try:
                schema = Schema(self.root, root, tuple(files.values()), self.tree.includes)
                # The tree's options, resolved once for the rules, are the root files' too (when
                # no name is declared twice): Sizes does not resolve them again. test_lint_model
                # holds the sizes to Sizes' own.
                sizes = Sizes(
                    schema,
                    self._options_file,
                    self._settings,
                    self._nanopb_version,
                    self.nanopb(),
                )
                refusal = sizes.refusal(root)
                if refusal is not None:  # no size; max_size would say so in located words
                    self._refusals[root] = refusal
                else:
                    size = sizes.max_size(root)
            except FileError:
                raise  # a .options file that is no file stops the run; it is no missing size
            except SchemaError:
                size = None
        self._sizes[root] = size
        return size

    def refusal(self, root: str) -> str | None:
        """Why nanopb's generator writes no code for message ``root``, if it refuses its file
        (a proto2 group in it, or in a file it imports): ``nanopb's generator refuses a.proto:
        A.g is a proto2 group, ...``. Sized only where a file ``root`` needs holds a group:
        sizing a root builds a Schema."""
        files = self._root_files(root).values()
        if not any(self._has_group(file) for file in files):
            return None
        self.max_size(root)
        return self._refusals.get(root)

    def size_inputs(self, root: str) -> Iterator[tuple[tuple[str, str], object]]:
        """What nanopb computes ``root``'s size from, one input at a time: every file it needs
        that declares a proto2 group, whole (by file name); the descriptor of every message and
        enum it reaches (without source locations, so comments and layout don't count), as the
        root reaches them; then, for each file holding one, its package, syntax, edition, file
        options and ``.options`` text (by file name). Equal inputs, equal sizes: comparing them
        spares two size computations. Two revisions with the same inputs give them in the same
        order, so a comparison stops at the first that differs (``same_size_inputs``)."""
        files = self._root_files(root)
        for name in sorted(files):
            # A group anywhere in a file the root needs may make the generator refuse it (and
            # what it leaves out is decided by options of messages the root may not reach).
            if self._has_group(files[name]):
                yield ("grouped", name), _without_source(files[name])
        index: dict[str, tuple[descriptor_pb2.FileDescriptorProto, _Proto]] = {}
        for file in files.values():
            for declared in declarations(file):
                index.setdefault(declared.name, (file, declared.proto))
        holding: dict[str, descriptor_pb2.FileDescriptorProto] = {}
        pending, seen = [root], set()
        while pending:
            name = pending.pop()
            if name in seen or name not in index:
                continue
            seen.add(name)
            file, proto = index[name]
            yield ("type", name), proto.SerializeToString(deterministic=True)
            if isinstance(proto, descriptor_pb2.DescriptorProto):
                pending.extend(f.type_name.lstrip(".") for f in proto.field if f.type_name)
            holding.setdefault(file.name, file)
        for name in sorted(holding):
            file = holding[name]
            options = self._options_path(name)
            text = read_file(options) if options is not None else None
            settings = file.options.SerializeToString(deterministic=True)
            yield ("file", name), (file.package, file.syntax, file.edition, settings, text)

    def same_size_inputs(self, other: "Revision", root: str) -> bool:
        """Whether ``root``'s size inputs (``size_inputs``) are the same in both revisions,
        compared one by one until one differs: a differing file that holds a group is found
        before any type is serialized. test_same_size_inputs_is_the_plain_comparison holds it to
        comparing them all."""
        pairs = zip_longest(self.size_inputs(root), other.size_inputs(root))
        same = all(mine == theirs for mine, theirs in pairs)
        if not same:  # what went uncompared is read all the same, as comparing it all reads it
            self.read_options_files(root)
            other.read_options_files(root)
        return same

    def read_options_files(self, root: str) -> None:
        """Read the options file of every file ``root`` needs: one that is no regular file (a
        FIFO) stops the run (``FileError``), whether the root is sized or not."""
        for name in self._root_files(root):
            options = self._options_path(name)
            if options is not None:
                read_file(options)

    def _has_group(self, file: descriptor_pb2.FileDescriptorProto) -> bool:
        """Whether a file declares a proto2 group, asked once per file."""
        grouped = self._grouped.get(file.name)
        if grouped is None:
            grouped = self._grouped[file.name] = _has_group(file)
        return grouped

    def _options_path(self, name: str) -> Path | None:
        """The options file nanopb's generator reads for file ``name``, if any (looked for once)."""
        if name not in self._options_paths:
            self._options_paths[name] = options_path(
                self.root, self.tree.includes, self._options_file, name
            )
        return self._options_paths[name]

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


def _without_source(file: descriptor_pb2.FileDescriptorProto) -> bytes:
    """A file's descriptor without its source locations, serialized."""
    whole = descriptor_pb2.FileDescriptorProto()
    whole.CopyFrom(file)
    whole.ClearField("source_code_info")
    return whole.SerializeToString(deterministic=True)


def _has_group(file: descriptor_pb2.FileDescriptorProto) -> bool:
    """Whether a file declares a proto2 group: a field of one of its messages, or an extension."""
    fields = [file.extension]
    for declared in declarations(file):
        proto = declared.proto
        if isinstance(proto, descriptor_pb2.DescriptorProto):
            fields += (proto.field, proto.extension)
    return any(f.type == _FD.TYPE_GROUP for declared in fields for f in declared)


# nanopb's FieldType values as the generator stores them (FT_INLINE is static fixed_length).
_ALLOCATIONS = {1: "callback", 2: "static", 3: "ignore", 4: "pointer", 5: "static"}


def allocation(field: Field, options: Options) -> str:
    """How nanopb's generator stores a field with ``options``: its ``type``, else (``FT_DEFAULT``)
    static where a limit allows it (a string or bytes value needs ``max_size`` or ``max_length``,
    a repeated field ``max_count``), else its ``fallback_type`` (a callback unless set)."""
    kind = int(options.type)
    if not kind:
        bounded = field.cardinality != "repeated" or options.HasField("max_count")
        if field.type in ("string", "bytes"):
            bounded = bounded and (options.HasField("max_size") or options.HasField("max_length"))
        fallback = int(options.fallback_type) if options.HasField("fallback_type") else 1
        kind = 2 if bounded else fallback
    return _ALLOCATIONS.get(kind, str(kind))


def build(
    tree: LoadedTree,
    options_file: str = "%s.options",
    settings: Sequence[str] = (),
    nanopb_version: str = NANOPB_VERSIONS[0],
) -> Revision:
    """The model of a loaded tree, its nanopb options and sizes those of nanopb's generator
    ``nanopb_version`` run with the tree's include folders, ``-f options_file`` and ``-s`` for
    each of ``settings``."""
    revision = Revision(tree, options_file, settings, nanopb_version)
    pending: list[tuple[Field, str]] = []  # extensions and the messages they extend
    for proto in tree.files.values():
        _add_file(revision, proto, pending)
    for entry, extendee in pending:
        extended = revision.messages.get(extendee)
        if extended is None:
            extended = revision.extended.get(extendee)
        if extended is None:
            extended = revision.extended[extendee] = Message(extendee, "", entry.source, ())
        extended.extensions.setdefault(entry.number, entry)
        extended.extensions_by_name.setdefault(entry.name, entry)
    return revision


def _add_file(
    revision: Revision, proto: descriptor_pb2.FileDescriptorProto, pending: list[tuple[Field, str]]
) -> None:
    """Add a file's messages, enums and services; its extensions go to ``pending`` until every
    file's messages are known."""
    source = SourceIndex(str(revision.root / proto.name), proto)
    edition = edition_of(proto)
    top = file_features(proto)  # what no field or enum of the file overrides
    here: dict[str, Message] = {}  # this file's messages (another file may define a name too)
    for declaration in declarations(proto):
        if declaration.is_message:
            parent = here.get(declaration.parent or "")
            message = _message(proto.name, source, declaration, parent, top, edition)
            here[message.name] = message
            _define(revision, message.name, message)
            revision.messages.setdefault(message.name, message)
            for extension in declaration.extensions():
                pending.append(_extension(source, extension, top, edition))
        else:
            _enum(revision, proto.name, source, declaration, top)
    for extension in extensions(proto, nested=False):
        pending.append(_extension(source, extension, top, edition))
    for service in services(proto):
        _service(revision, proto.name, source, service)


def _service(revision: Revision, file: str, source: SourceIndex, service: DeclaredService) -> None:
    model = Service(service.name, file, source, service.path)
    for j, method in enumerate(service.proto.method):
        model.methods.setdefault(
            method.name,
            Method(
                service.name,
                method.name,
                method.input_type.lstrip("."),
                method.output_type.lstrip("."),
                method.client_streaming,
                method.server_streaming,
                _IDEMPOTENCY.Name(method.options.idempotency_level),
                source,
                service.method(j),
            ),
        )
    revision.services.setdefault(model.name, model)


def _define(revision: Revision, name: str, definition: Definition) -> None:
    revision.definitions.setdefault(name, []).append(definition)


def _message(
    file: str,
    source: SourceIndex,
    declaration: Declaration,
    parent: Message | None,
    features: Features,
    edition: int,
) -> Message:
    """The model of a declared message. A map entry and its key and value have no source of their
    own: they are located at the map field of ``parent`` that uses the entry."""
    proto = declaration.proto
    assert isinstance(proto, descriptor_pb2.DescriptorProto)
    name, map_entry = declaration.name, proto.options.map_entry
    users = [f for f in parent.fields.values() if f.type == name] if parent and map_entry else []
    declared = users[0].at if users else None
    model = Message(name, file, source, declared or declaration.path, map_entry)
    # Most messages have no oneof, nested type or reserved range: no comprehension for them.
    declared_oneofs, nested_types = proto.oneof_decl, proto.nested_type
    oneofs = [oneof.name for oneof in declared_oneofs] if declared_oneofs else []
    maps = (
        {f"{name}.{nested.name}" for nested in nested_types if nested.options.map_entry}
        if nested_types
        else set()
    )
    for j, f in enumerate(proto.field):
        # (a field of a message that declares no oneof is in none: no question to protobuf)
        real_oneof = bool(oneofs) and f.HasField("oneof_index") and not f.proto3_optional
        if real_oneof:
            model.oneofs.setdefault(oneofs[f.oneof_index], declaration.oneof(f.oneof_index))
        plain = map_entry or (bool(maps) and f.type_name.lstrip(".") in maps)  # never delimited
        entry = _field(
            name,
            f,
            features.of_field(f, edition),
            source,
            declared or declaration.member(j),
            oneofs[f.oneof_index] if real_oneof else None,
            plain,
        )
        model.fields.setdefault(entry.number, entry)  # the model's, not protobuf's, attributes:
        model.by_name.setdefault(entry.name, entry)  # each upb read makes a new object
    # protoc's message ranges end before ``end``; enum ranges include it
    ranges, names = proto.reserved_range, proto.reserved_name
    if ranges:
        model.reserved.ranges.extend((r.start, r.end - 1) for r in ranges)
    if names:
        model.reserved.names.update(names)
    for extension_range in proto.extension_range:
        model.extension_ranges.append((extension_range.start, extension_range.end - 1))
        model.reserved_extensions.update(
            d.number for d in extension_range.options.declaration if d.reserved
        )
    return model


def _field(
    owner: str,
    f: descriptor_pb2.FieldDescriptorProto,
    features: Features,
    source: SourceIndex,
    at: tuple[int, ...],
    oneof: str | None = None,
    plain: bool = False,
    name: str | None = None,
) -> Field:
    """The model of a field (or, given its full ``name``, an extension) with its resolved
    features; ``plain``: a map entry or a map field, never delimited."""
    type_, kind = type_of(f)
    if f.label == _FD.LABEL_REPEATED:
        cardinality = "repeated"
    else:
        cardinality = "required" if features.required else "optional"
    encoding = ""
    if kind == "message":
        if f.type == _FD.TYPE_GROUP:
            encoding = _GROUP
        else:
            encoding = _DELIMITED if features.delimited and not plain else _LENGTH_PREFIXED
    # tuple.__new__ rather than Field(...), whose __new__ is a Python function of 14 parameters
    # called for every field. test_lint_model holds the fields made so to those Field(...) makes.
    return _new_field(
        Field,
        (
            owner,
            name or f.name,
            f.number,
            type_,
            kind,
            cardinality,
            oneof,
            source,
            at,
            encoding,
            f.default_value if f.HasField("default_value") else None,
            type_ == "string" and features.verifies_utf8,
            f.json_name,
            name is not None,
        ),
    )


def _extension(
    source: SourceIndex, extension: Extension, top: Features, edition: int
) -> tuple[Field, str]:
    """An extension as a field of the message it extends (and that message's name)."""
    f = extension.proto
    extendee = f.extendee.lstrip(".")
    features = top.of_field(f, edition)
    return _field(extendee, f, features, source, extension.path, name=extension.name), extendee


def _enum(
    revision: Revision,
    file: str,
    source: SourceIndex,
    declaration: Declaration,
    features: Features,
) -> None:
    """Add a declared enum; its values take global names beside it (C++ scoping)."""
    proto = declaration.proto
    assert isinstance(proto, descriptor_pb2.EnumDescriptorProto)
    own = features.merged(proto.options.features) if proto.HasField("options") else features
    model = Enum(declaration.name, file, source, declaration.path, own.closed)
    _define(revision, model.name, model)
    revision.enums.setdefault(model.name, model)
    for j, value in enumerate(proto.value):
        entry = EnumValue(model.name, value.name, value.number, source, declaration.member(j))
        _define(revision, declaration.scope + entry.name, entry)  # the model's attributes, as
        model.values.setdefault(entry.number, entry)  # for a field: each upb read makes an object
        model.by_name.setdefault(entry.name, entry)
    ranges, names = proto.reserved_range, proto.reserved_name
    if ranges:
        model.reserved.ranges.extend((r.start, r.end) for r in ranges)
    if names:
        model.reserved.names.update(names)


def type_of(f: descriptor_pb2.FieldDescriptorProto) -> tuple[str, str]:
    """A field's type as the rules name it (``float``, or a full name) and its kind."""
    number = f.type
    kind = _KINDS.get(number, "scalar")
    return (f.type_name.lstrip(".") if kind != "scalar" else _SCALARS[number]), kind
