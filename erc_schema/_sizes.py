"""nanopb-identical maximum encoded sizes, and the fixed-size contract they imply.

``max_size(name)`` equals the ``<name>_size`` nanopb's generator (0.4.x) writes into the ``.pb.h``:
the sum over fields of tag bytes plus the widest value, oneofs counting their widest member,
submessages their own size plus its length prefix, strings ``varint(max_size) + max_size - 1``,
bytes ``varint(max_size) + max_size``, repeated fields ``(tag + item) * max_count`` (plus one when
``max_count`` is 1), and nothing for ignored fields. A message with a field nanopb cannot bound (a
string, bytes or repeated field with no limit, a callback or pointer field, a type that contains
itself) has no size, exactly where nanopb writes "depends on runtime parameters". nanopb reads the
descriptors as written: an editions field with ``message_encoding = DELIMITED`` is sized as the
message field it is written as. nanopb's generator refuses a file holding a proto2 ``group`` it must
generate (``NotImplementedError``: it has no groups) or an enum or message ``type_override`` of a
field of no such type (it fails on the missing type), and with it every file importing that file:
their messages have no size and are not listed. A message it writes no code for (``skip_message``,
deprecated under ``discard_deprecated``) has no size either.

Generator versions differ in two rules (``NANOPB_VERSIONS``). Up to 0.4.9.1 (``"0.4.9"``, the rules
of every 0.4.x release) a ``FT_CALLBACK`` or ``FT_POINTER`` field has no size; nanopb's master
after 0.4.9.1 (``"1.0.0-dev"``, as its headers name it; the ERC firmware pins commit d68cd4e) sizes
every field whose bound is known whatever its allocation (its ``Field.encoded_size`` asks
``can_be_static``: a ``max_count`` for a repeated field, a ``max_size`` or ``max_length`` for a
string or bytes), so a callback or pointer field counts as the static field it could have been.
A type that contains itself still has no size there (master writes an expression naming the
message's own size, which no compiler can evaluate). And master looks a field's type up otherwise
from a file without a package but with a ``(nanopb_fileopt).package`` (see ``_names``). Each rule
set is checked against its generator, PyPI's nanopb 0.4.9.1 and 1.0.0.dev1621, over the test
corpus (whether the firmware's d68cd4e is older or newer than 1.0.0.dev1621, the 1621st commit of
master, is not known here: the package names no commit); the older 0.4.x releases size alike,
0.4.7 but for the type lookup from a file with a ``(nanopb_fileopt).package`` (it looks every
type up under that name, where 0.4.8 and later look a type outside the file's package up by its
full name).
"""

from collections.abc import Sequence

from google.protobuf import descriptor_pb2
from google.protobuf.descriptor import Descriptor, FieldDescriptor, OneofDescriptor

from ._descriptors import declarations, extensions
from ._errors import SchemaError
from ._names import nanopb_finds
from ._options import Options, ResolvedOptions, resolve_options
from ._schema import Schema, enum_of, message_of
from ._wire import varint_size

__all__ = ["NANOPB_VERSIONS", "PYTHON_INT_RANGE", "Sizes"]

# The generator rules a ``Sizes`` can follow, the default first (see the module's docstring).
NANOPB_VERSIONS = ("0.4.9", "1.0.0-dev")

_T = FieldDescriptor
_FT_CALLBACK, _FT_STATIC, _FT_IGNORE, _FT_POINTER = 1, 2, 3, 4

_FIXED_WIDTH = {
    _T.TYPE_BOOL: 1,
    _T.TYPE_FLOAT: 4,
    _T.TYPE_FIXED32: 4,
    _T.TYPE_SFIXED32: 4,
    _T.TYPE_DOUBLE: 8,
    _T.TYPE_FIXED64: 8,
    _T.TYPE_SFIXED64: 8,
    _T.TYPE_INT32: 10,  # negative int32 values are sign-extended to ten bytes
    _T.TYPE_INT64: 10,
}
# Varint types whose width follows nanopb's int_size option (IS_DEFAULT is 0).
_SIZED_VARINTS = {
    _T.TYPE_UINT32: {0: 5, 8: 2, 16: 3, 32: 5, 64: 10},
    _T.TYPE_SINT32: {0: 5, 8: 2, 16: 3, 32: 5, 64: 10},
    _T.TYPE_UINT64: {0: 10, 8: 2, 16: 3, 32: 5, 64: 10},
    _T.TYPE_SINT64: {0: 10, 8: 2, 16: 3, 32: 5, 64: 10},
}
# A field protobuf writes as a group where nanopb's generator, taking the descriptor as written,
# has a length-prefixed message: an editions DELIMITED field (or a proto2 group whose nanopb
# type_override is TYPE_MESSAGE). nanopb's C library answers protobuf's bytes "wrong wire type"
# and protobuf keeps nanopb's as an unknown field, so no bytes are right for both: the codec
# refuses to encode or decode a message holding it rather than pick one side (its size stays
# nanopb's). Without the feature nanopb's code is the same.
# nanopb's int_size values (IS_8 .. IS_64; IS_DEFAULT is 0) as bits.
_INT_BITS = {8: 8, 16: 16, 32: 32, 64: 64}
_NO_GROUPS = "which nanopb's generator does not implement"
# Varint integer types: how nanopb's decoder reads them (pb_dec_varint), and their own width.
_VARINT_KIND = {
    _T.TYPE_INT32: ("signed", 32),
    _T.TYPE_INT64: ("signed", 64),
    _T.TYPE_UINT32: ("unsigned", 32),
    _T.TYPE_UINT64: ("unsigned", 64),
    _T.TYPE_SINT32: ("zigzag", 32),
    _T.TYPE_SINT64: ("zigzag", 64),
}
# What protobuf's Python runtime lets an integer field hold.
PYTHON_INT_RANGE = {
    _T.TYPE_INT32: (-(2**31), 2**31 - 1),
    _T.TYPE_SINT32: (-(2**31), 2**31 - 1),
    _T.TYPE_SFIXED32: (-(2**31), 2**31 - 1),
    _T.TYPE_INT64: (-(2**63), 2**63 - 1),
    _T.TYPE_SINT64: (-(2**63), 2**63 - 1),
    _T.TYPE_SFIXED64: (-(2**63), 2**63 - 1),
    _T.TYPE_UINT32: (0, 2**32 - 1),
    _T.TYPE_FIXED32: (0, 2**32 - 1),
    _T.TYPE_UINT64: (0, 2**64 - 1),
    _T.TYPE_FIXED64: (0, 2**64 - 1),
}
# Types written alike on the wire: a type_override within one class changes no byte.
_WIRE_CLASS = {
    **dict.fromkeys((_T.TYPE_INT64, _T.TYPE_UINT32, _T.TYPE_UINT64, _T.TYPE_BOOL), _T.TYPE_INT32),
    _T.TYPE_ENUM: _T.TYPE_INT32,
    _T.TYPE_SINT64: _T.TYPE_SINT32,
    **dict.fromkeys((_T.TYPE_SFIXED32, _T.TYPE_FLOAT), _T.TYPE_FIXED32),
    **dict.fromkeys((_T.TYPE_SFIXED64, _T.TYPE_DOUBLE), _T.TYPE_FIXED64),
    _T.TYPE_BYTES: _T.TYPE_STRING,
}
_UNPACKABLE = {_T.TYPE_STRING, _T.TYPE_BYTES, _T.TYPE_MESSAGE, _T.TYPE_GROUP}
_TYPE_NAMES = {
    number: name[len("TYPE_") :]
    for name, number in vars(_T).items()
    if name.startswith("TYPE_") and isinstance(number, int)
}


def _generator_stops(declared: int, kind: int) -> str | None:
    """Why nanopb's generator stops on a field it generates, declared ``declared`` and typed
    ``kind`` by nanopb (its ``type_override``), if it does: a proto2 group
    (``NotImplementedError``), or an override to an enum or a message of a field that is neither
    (0.4.9.1 and master fail on the missing or wrong type: ``IndexError``, "Expected enum type",
    ``TypeError``)."""
    if kind == _T.TYPE_GROUP:
        return f"is a proto2 group, {_NO_GROUPS}"
    if kind == _T.TYPE_ENUM and declared != _T.TYPE_ENUM:
        missing = "enum"
    elif kind == _T.TYPE_MESSAGE and declared not in (_T.TYPE_MESSAGE, _T.TYPE_GROUP):
        missing = "message"
    else:
        return None
    return (
        f"is declared {_TYPE_NAMES[declared]} with type_override {_TYPE_NAMES[kind]}: it has no "
        f"{missing} type, and nanopb's generator cannot generate it"
    )


def _packed_enum_bits(values: list[int], signed: bool) -> int:
    """The width of a ``packed_enum``'s C type: GCC's smallest holding every value."""
    for bits in (8, 16, 32):
        low, high = (-(2 ** (bits - 1)), 2 ** (bits - 1) - 1) if signed else (0, 2**bits - 1)
        if low <= min(values) and max(values) <= high:
            return bits
    return 64


class Sizes:
    """Maximum sizes and field limits of one schema, computed once per message."""

    def __init__(
        self,
        schema: Schema,
        options_file: str = "%s.options",
        settings: Sequence[str] = (),
        nanopb_version: str = NANOPB_VERSIONS[0],
        resolved: ResolvedOptions | None = None,
    ) -> None:
        """nanopb's sizes for ``schema``, its generator run from the tree's root with the
        schema's include folders (``-I``), ``-f options_file`` and ``-s`` for each setting
        (``"max_size:61"``), by the rules of generator ``nanopb_version`` (``NANOPB_VERSIONS``;
        another value is a ``SchemaError``). ``resolved``: the options ``resolve_options`` gave
        with these inputs for the schema's files or more (``unique``), which a caller holding
        them spares resolving again."""
        if nanopb_version not in NANOPB_VERSIONS:
            raise SchemaError(
                f"nanopb_version {nanopb_version!r}: erc-codec knows the generator rules of "
                f"{' and '.join(NANOPB_VERSIONS)} (0.4.x up to 0.4.9.1, and master after it)"
            )
        self.nanopb_version = nanopb_version
        # master after 0.4.9.1: it sizes callback and pointer fields whose bound is known, and
        # looks types up otherwise (``nanopb_finds``)
        self._master = nanopb_version != NANOPB_VERSIONS[0]
        self._schema = schema
        if resolved is None or not resolved.unique:
            resolved = resolve_options(
                schema.tree, schema.files, schema.include, options_file, settings
            )
        self._options: ResolvedOptions = resolved
        self._optional: set[str] | None = None  # proto3 `optional` fields: ``real_oneof``
        self._refused = self._refused_files()
        self._memo: dict[str, int | None] = {}
        self._lookups: dict[str, bool] = {}  # field -> whether nanopb finds its type

    def _refused_files(self) -> dict[str, tuple[str, str, str]]:
        """File name -> why nanopb's generator writes no code for it: what stops it (``field``,
        ``file`` or ``import``), where (a field's full name, the file's, the import's: for
        ``_located``) and in plain words. A message it generates
        holds a field it does not leave out (by ``FT_IGNORE`` or ``discard_deprecated``) that
        stops it (``_generator_stops``: a proto2 group, an enum or message ``type_override`` of
        a field of no such type), or the file imports such a file (the generator parses every
        import). Locations are looked up only for an error (``_located``): a refused file that
        no error names costs no lookup."""
        refused: dict[str, tuple[str, str, str]] = {}
        for proto in self._schema.files:  # protoc lists a file's imports before the file
            grouped = [e for e in extensions(proto, nested=False) if e.proto.type == _T.TYPE_GROUP]
            for declaration in declarations(proto):
                message = declaration.proto
                if not isinstance(message, descriptor_pb2.DescriptorProto):
                    continue
                grouped += (e for e in declaration.extensions() if e.proto.type == _T.TYPE_GROUP)
                if proto.name in refused:
                    continue
                stop = self._stop(declaration.name, message)
                if stop is not None and self._wanted(self._schema.descriptor(declaration.name)):
                    refused[proto.name] = ("field", *stop)
            # An extension that is a group fails the generator too, unless its FT_IGNORE spares
            # the file (the generator then builds nothing of it).
            extension = next(
                (e for e in grouped if self._options.extensions[e.name].type != _FT_IGNORE), None
            )
            if extension is not None and proto.name not in refused:
                why = f"extension {extension.name} is a proto2 group, {_NO_GROUPS}"
                refused[proto.name] = ("file", proto.name, why)
            imported = next((name for name in proto.dependency if name in refused), None)
            if imported is not None and proto.name not in refused:
                plain = f"it imports {imported}, where {refused[imported][2]}"
                refused[proto.name] = ("import", imported, plain)
        return refused

    def _stop(self, name: str, message: descriptor_pb2.DescriptorProto) -> tuple[str, str] | None:
        """The first field of message ``name`` that stops nanopb's generator, if it keeps it:
        its full name and why (``A.g is a proto2 group, ...``)."""
        for field in message.field:  # as written: a DELIMITED field is TYPE_MESSAGE here
            dotted = f"{name}.{field.name}"
            options = self._options.fields[dotted]
            kind = options.type_override if options.HasField("type_override") else field.type
            why = _generator_stops(field.type, kind)
            if why is None or options.type == _FT_IGNORE:
                continue  # nothing stops the generator, or it leaves the field out
            if not (options.discard_deprecated and field.options.deprecated):
                return dotted, f"{dotted} {why}"
        return None

    def _located(self, file: str) -> str:
        """Why nanopb's generator refuses ``file`` (one ``_refused`` lists), with the location of
        what stops it: ``a.proto:4:3: A.g is a proto2 group, ...``, or through an import."""
        what, where, why = self._refused[file]
        if what == "import":
            return f"it imports {where}, and {self._located(where)}"
        shown = self._schema.shown / where if what == "file" else self._schema.where(where)
        return f"{shown}: {why}"

    def refusal(self, name: str) -> str | None:
        """Why nanopb's generator writes no code for message ``name``, if it refuses its file
        (``nanopb's generator refuses a.proto: A.g is a proto2 group, ...``), in words that
        name files as the tree does and no location."""
        file = self._schema.descriptor(name).file.name
        refused = self._refused.get(file)
        return None if refused is None else f"nanopb's generator refuses {file}: {refused[2]}"

    # -- field limits --------------------------------------------------------------------------

    def options(self, field: FieldDescriptor) -> Options:
        """nanopb's resolved options for ``field`` (defaults when nothing applies)."""
        return self._options.fields[field.full_name]

    def ignored(self, field: FieldDescriptor) -> bool:
        """Whether nanopb leaves ``field`` out (``type:FT_IGNORE`` on it or its oneof)."""
        options = self.options(field)
        if options.type == _FT_IGNORE:
            return True
        if options.discard_deprecated and field.GetOptions().deprecated:
            return True
        oneof = self.real_oneof(field)
        return oneof is not None and self._oneof_options(oneof).type == _FT_IGNORE

    def real_oneof(self, field: FieldDescriptor) -> OneofDescriptor | None:
        """The oneof ``field`` belongs to, unless it is the synthetic one of an ``optional``."""
        if self._optional is None:  # walked on first use: a refused root needs no oneof
            self._optional = {
                f"{declaration.name}.{member.name}"
                for proto in self._schema.files
                for declaration in declarations(proto)
                if isinstance(declaration.proto, descriptor_pb2.DescriptorProto)
                for member in declaration.proto.field
                if member.proto3_optional
            }
        if field.full_name in self._optional:
            return None
        return field.containing_oneof

    def max_count(self, field: FieldDescriptor) -> int | None:
        """nanopb's ``max_count`` for a repeated field, ``None`` where unbounded."""
        options = self.options(field)
        return int(options.max_count) if options.HasField("max_count") else None

    def max_bytes(self, field: FieldDescriptor) -> int | None:
        """The most bytes a string (without its NUL) or bytes value may hold, as nanopb types
        the field (``field_type``): a string's ``max_length`` sizes its C array (length + 1)
        whatever its ``type_override``."""
        options = self.options(field)
        if field.type == _T.TYPE_STRING and options.HasField("max_length"):
            limit = int(options.max_length) + 1
        elif options.HasField("max_size"):
            limit = int(options.max_size)
        else:
            return None
        return limit - 1 if self.field_type(field) == _T.TYPE_STRING else limit

    # -- the field as nanopb's generator sees it -----------------------------------------------
    # The one model of a field's nanopb-effective cardinality and type: sizes, the contract,
    # strict decoding and erc_codec.strategies all ask these, never the raw descriptor.

    def field_type(self, field: FieldDescriptor) -> int:
        """The type nanopb gives ``field``: its ``type_override``, else the declared type."""
        options = self.options(field)
        return int(options.type_override) if options.HasField("type_override") else field.type

    def repeated(self, field: FieldDescriptor) -> bool:
        """Whether nanopb sees ``field`` as repeated (its ``label_override``, else the label)."""
        options = self.options(field)
        if options.HasField("label_override"):
            return bool(options.label_override == _T.LABEL_REPEATED)
        return field.is_repeated

    def required(self, field: FieldDescriptor) -> bool:
        """Whether nanopb's decoder demands ``field`` ("missing required field"): a proto2
        ``required`` field, or any field whose ``label_override`` is ``LABEL_REQUIRED``."""
        options = self.options(field)
        if options.HasField("label_override"):
            return bool(options.label_override == _T.LABEL_REQUIRED)
        return field.is_required

    def wire_mismatch(self, field: FieldDescriptor) -> str | None:
        """Why protobuf's runtime, following the declaration, writes ``field`` in bytes nanopb's
        decoder, following its overrides, reads otherwise or refuses; ``None`` when they agree
        (a ``type_override`` within one wire encoding, a ``label_override`` on a field protobuf
        does not pack)."""
        declared, nanopb = field.type, self.field_type(field)
        if _WIRE_CLASS.get(declared, declared) != _WIRE_CLASS.get(nanopb, nanopb):
            return (
                f"type_override {_TYPE_NAMES[nanopb]} of a {_TYPE_NAMES[declared]} field: "
                "the two are written differently on the wire"
            )
        if field.is_repeated and not self.repeated(field) and field.is_packed:
            return (
                "label_override makes a packed repeated field single: protobuf writes it "
                "packed, which nanopb refuses for a single value (wrong wire type)"
            )
        if not field.is_repeated and self.repeated(field) and nanopb not in _UNPACKABLE:
            return (
                "label_override makes a single number an array: nanopb writes it packed, "
                "which protobuf does not read into a single field"
            )
        return None

    def c_integer(self, field: FieldDescriptor) -> tuple[str, int] | None:
        """How nanopb's decoder stores a varint field's value, for its "integer too large":
        ``("unsigned", bits)`` (uint32, uint64, an enum without negative values), ``("zigzag",
        bits)`` (sint32, sint64) or ``("signed", bits)`` (int32, int64, an enum with negative
        values), ``bits`` the width of the C type (``int_size``, else the type's own; an enum's
        C type: ``enum_intsize``, else an ``int``, or the smallest type holding its values
        when ``packed_enum``). ``None`` for a field that is no such integer (bool included)."""
        kind = self.field_type(field)
        if kind == _T.TYPE_ENUM and field.enum_type is not None:
            values = [value.number for value in enum_of(field).values]
            enum = self._options.enums[enum_of(field).full_name]
            signed = min(values) < 0
            bits = _INT_BITS.get(int(enum.enum_intsize), 0)
            if not bits:
                bits = _packed_enum_bits(values, signed) if enum.packed_enum else 32
            return ("signed" if signed else "unsigned"), bits
        if kind not in _VARINT_KIND:
            return None
        family, natural = _VARINT_KIND[kind]
        return family, _INT_BITS.get(int(self.options(field).int_size), 0) or natural

    def int_range(self, field: FieldDescriptor) -> tuple[int, int] | None:
        """The values of an integer field nanopb's decoder takes unchanged, when narrower than
        what protobuf's runtime lets the field hold (an ``int_size``, a ``type_override`` to a
        narrower or unsigned type), else ``None``."""
        if field.type not in PYTHON_INT_RANGE:
            return None
        declared = PYTHON_INT_RANGE[field.type]
        stored = self.c_integer(field) if self.field_type(field) != _T.TYPE_ENUM else None
        if self.field_type(field) == _T.TYPE_BOOL:
            effective = (0, 1)
        elif stored is None:
            return None
        else:
            family, bits = stored
            effective = (
                (0, 2**bits - 1)
                if family == "unsigned"
                else (-(2 ** (bits - 1)), 2 ** (bits - 1) - 1)
            )
        low, high = max(declared[0], effective[0]), min(declared[1], effective[1])
        return None if (low, high) == declared else (low, high)

    # -- sizes ---------------------------------------------------------------------------------

    def max_size(self, name: str) -> int:
        """nanopb's ``<name>_size``; ``SchemaError`` when nanopb has none for it."""
        descriptor = self._schema.descriptor(name)
        self._require_generated(descriptor)
        size = self._size(descriptor)
        if size is None:
            self.require_fixed(descriptor)
        assert size is not None, name  # require_fixed raised otherwise
        return size

    def all(self) -> dict[str, int | None]:
        """The size of every message nanopb generates code for in the tree's own files (not in
        imported option vocabularies such as nanopb.proto), ``None`` where nanopb writes
        "depends on runtime parameters"."""
        return {
            message.full_name: self._size(message)
            for message in self._schema.messages()
            if self._generated(message)
        }

    def _generated(self, message: Descriptor) -> bool:
        return message.file.name not in self._refused and self._wanted(message)

    def _wanted(self, message: Descriptor) -> bool:
        """Whether the generator makes code for ``message`` where it takes its file."""
        options = self._options.messages[message.full_name]
        if options.skip_message:
            return False
        if options.discard_deprecated and message.GetOptions().deprecated:
            return False
        parent = message.containing_type
        if message.GetOptions().map_entry and parent is not None:
            # discard_unused_automatic_types (on by default): a map's entry type is generated
            # only for a map field the generator keeps, in a message it generates
            file = self._options.files.get(message.file.name)
            if (
                file is None
                or not file.HasField("discard_unused_automatic_types")
                or file.discard_unused_automatic_types
            ):
                used = any(f.message_type is message and not self.ignored(f) for f in parent.fields)
                return used and self._wanted(parent)
        return True

    def _require_generated(self, message: Descriptor) -> None:
        """``SchemaError`` when nanopb's generator refuses the file of ``message``."""
        if message.file.name in self._refused:
            raise SchemaError(
                f"nanopb's generator refuses {message.file.name} "
                f"({self._located(message.file.name)}): it writes no code for "
                f"{message.full_name}, so no size"
            )
        left_out = self._left_out(message)
        if left_out is not None:
            written = message  # a map's entry type is written nowhere: its message is
            while self._schema.location(written.full_name) is None and written.containing_type:
                written = written.containing_type
            raise SchemaError(
                f"{self._schema.where(written.full_name)}: nanopb generates no code for "
                f"{message.full_name} ({left_out}), so no size"
            )

    def _left_out(self, message: Descriptor) -> str | None:
        """Why the generator writes no code for ``message`` in a file it takes, if it does not
        (``_wanted``): a map's entry type says so of the message holding the map."""
        options = self._options.messages[message.full_name]
        if options.skip_message:
            return "it has skip_message"
        if options.discard_deprecated and message.GetOptions().deprecated:
            return "it is deprecated, under discard_deprecated"
        parent = message.containing_type
        if self._wanted(message) or parent is None:
            return None
        if not self._wanted(parent):
            return f"the entry type of a map in {parent.full_name}, which it generates no code for"
        return "the entry type of a map field it leaves out, under discard_unused_automatic_types"

    def require_fixed(self, root: Descriptor) -> None:
        """``SchemaError`` naming the first field, and its path from ``root``, nanopb can't size."""
        self._require_generated(root)  # the files root reaches are all imported by its own
        # Depth first with a stack of its own: messages nest as deeply as protoc lets them.
        pending: list[tuple[Descriptor, str, tuple[str, ...]]] = [
            (root, root.full_name, (root.full_name,))
        ]
        while pending:
            message, path, stack = pending.pop()
            inner: list[tuple[Descriptor, str, tuple[str, ...]]] = []
            for field in message.fields:
                if self.ignored(field):
                    continue
                here = f"{path}.{field.name}"
                problem = self._problem(field)
                if field.message_type is not None and problem is None:
                    sub = message_of(field)
                    if sub.full_name in stack:
                        problem = f"{sub.full_name} contains itself"
                    else:
                        inner.append((sub, here, (*stack, sub.full_name)))
                if problem is not None:
                    raise SchemaError(
                        f"{self._schema.where(field.full_name)}: {field.full_name}: {problem}; "
                        f"nanopb cannot size it (reached from {stack[0]} as {here})"
                    )
            pending.extend(reversed(inner))

    def _problem(self, field: FieldDescriptor) -> str | None:
        """Why ``field`` itself (not what it contains) has no static size, if it hasn't."""
        options = self.options(field)
        if options.type in (_FT_CALLBACK, _FT_POINTER) and not self._master:
            kind = "FT_CALLBACK" if options.type == _FT_CALLBACK else "FT_POINTER"
            return f"nanopb type {kind} (sized from nanopb_version 1.0.0-dev on, if bounded)"
        if self.repeated(field) and self.max_count(field) is None:
            return "repeated field without nanopb max_count"
        sub = field.message_type
        if sub is not None and not self._generated(sub):
            # the generator writes "#if defined(Sub_size)" around a size that never is defined
            return f"its type {sub.full_name} is not generated (skip_message, or deprecated)"
        if sub is not None and not self._found(field):
            return (
                f"nanopb's generator does not find its type {sub.full_name}: the two files' "
                "mangle_names or (nanopb_fileopt).package disagree"
            )
        if field.enum_type is not None and self._enum_stops_generator(field):
            return (
                f"nanopb's generator does not find its enum type {field.enum_type.full_name} (the "
                "two files' mangle_names or (nanopb_fileopt).package disagree) and stops"
            )
        if field.type in (_T.TYPE_STRING, _T.TYPE_BYTES) and self.max_bytes(field) is None:
            kind = "string" if field.type == _T.TYPE_STRING else "bytes"
            return f"{kind} field without nanopb max_size"
        return None

    def _size(self, message: Descriptor) -> int | None:
        """The size of ``message``, every message it contains sized first (after the messages
        they contain, depth first, with a stack of its own: nesting may be deep). A message that
        contains itself, or reaches one that does, has none: nanopb makes such fields callbacks."""
        memo = self._memo
        if message.full_name in memo:
            return memo[message.full_name]
        pending: list[tuple[Descriptor, bool]] = [(message, False)]
        open_now: set[str] = set()  # on the current path: sized as None by what they contain
        while pending:
            descriptor, contents_sized = pending.pop()
            name = descriptor.full_name
            if contents_sized:
                open_now.discard(name)
                memo[name] = self._own_size(descriptor)
                continue
            if name in memo:
                continue
            open_now.add(name)
            pending.append((descriptor, True))
            for field in descriptor.fields:
                sub = field.message_type
                if (
                    sub is not None
                    and sub.full_name not in memo
                    and sub.full_name not in open_now
                    and not self.ignored(field)
                    and self._problem(field) is None
                ):
                    pending.append((sub, False))
        return memo[message.full_name]

    def _own_size(self, message: Descriptor) -> int | None:
        """The size of ``message``, the messages it contains being sized (or open: None)."""
        total = 0
        for oneof, fields in self._groups(message):
            sizes = [self._field_size(field) for field in fields]
            known = [size for size in sizes if size is not None]
            if len(known) < len(sizes):
                return None
            total += max(known, default=0) if oneof else sum(known)
        return total

    def _groups(
        self, message: Descriptor
    ) -> list[tuple[OneofDescriptor | None, list[FieldDescriptor]]]:
        """Fields sized together: each union oneof as one group, every other field alone."""
        groups: list[tuple[OneofDescriptor | None, list[FieldDescriptor]]] = []
        unions: dict[str, list[FieldDescriptor]] = {}
        for field in message.fields:
            if self.ignored(field):
                continue
            oneof = self.real_oneof(field)
            if oneof is None or self._oneof_options(oneof).no_unions:
                groups.append((None, [field]))
            elif oneof.full_name in unions:
                unions[oneof.full_name].append(field)
            else:
                unions[oneof.full_name] = [field]
                groups.append((oneof, unions[oneof.full_name]))
        return groups

    def _field_size(self, field: FieldDescriptor) -> int | None:
        if self._problem(field) is not None:
            return None
        options = self.options(field)
        kind = self.field_type(field)
        payload: int | None
        if kind in (_T.TYPE_MESSAGE, _T.TYPE_GROUP):  # a group here: written DELIMITED
            sub = self._memo.get(message_of(field).full_name)  # absent: open, contains itself
            payload = None if sub is None else sub + varint_size(sub)
        elif kind in (_T.TYPE_STRING, _T.TYPE_BYTES):
            limit = self.max_bytes(field)  # the C array's size, less a string's NUL
            assert limit is not None  # _problem said otherwise
            array = limit + 1 if kind == _T.TYPE_STRING else limit
            payload = varint_size(array) + limit
        elif kind == _T.TYPE_ENUM and not self._found(field):
            payload = 10  # the generator's guess for an enum it does not find (see _names)
        elif kind == _T.TYPE_ENUM:
            payload = max(varint_size(value.number) for value in enum_of(field).values)
        elif kind in _SIZED_VARINTS:
            payload = _SIZED_VARINTS[kind][options.int_size]
        else:
            payload = _FIXED_WIDTH[kind]
        if payload is None:
            return None
        tag = varint_size(field.number << 3)
        if not self.repeated(field):
            return tag + payload
        count = int(options.max_count)
        return (tag + payload) * count + (1 if count == 1 else 0)

    def _enum_stops_generator(self, field: FieldDescriptor) -> bool:
        """Whether an enum field whose type nanopb does not find stops its generator ("Could not
        find enum type", raised while it writes the defaults of singular static fields); in a
        oneof, repeated, a callback or a pointer it counts as a guessed 10 bytes instead."""
        return (
            not self._found(field)
            and not self.repeated(field)
            and field.containing_oneof is None
            and self.options(field).type not in (_FT_CALLBACK, _FT_POINTER)
        )

    def _found(self, field: FieldDescriptor) -> bool:
        """Whether nanopb's generator finds the message or enum type of ``field`` under the
        mangle_names and package options of the file that refers to it and of the one that
        declares it (always, where the two agree)."""
        found = self._lookups.get(field.full_name)
        if found is None:
            kind = field.message_type or field.enum_type
            assert kind is not None, field.full_name
            assert field.containing_type is not None, field.full_name
            referring, defining = field.containing_type.file, kind.file
            files = self._options.files
            found = self._lookups[field.full_name] = nanopb_finds(
                (referring.package, files[referring.name]),
                (defining.package, files[defining.name]),
                kind.full_name,
                master_lookup=self._master,
            )
        return found

    def _oneof_options(self, oneof: OneofDescriptor) -> Options:
        return self._options.oneofs[oneof.full_name]
