"""The schema layer: a proto tree as protoc, nanopb's generator and the wire see it.

Both packages build on it, and so may users: ``erc_codec`` loads a schema, sizes it and checks
messages against it; ``erc_lint`` compiles trees file by file, locates what it reports and asks for
sizes and nanopb limits. Nothing here encodes envelopes or talks to a network.

- protoc in-process: ``compile_files`` (a ``FileDescriptorSet``, or ``ProtocError`` with protoc's
  own ``path:line:col`` diagnostics);
- a tree's text before it compiles: ``imports`` (as protoc tokenizes them) and ``declared_names``;
- compiled files: ``declarations`` (every message and enum, nested ones too, with their source
  paths), ``extensions`` and ``services`` (likewise) and ``SourceIndex`` (a path's ``Location``
  and trailing comment);
- a loaded schema: ``load_schema`` and ``Schema`` (descriptor pool, classes, locations);
- nanopb: ``resolve_options`` (``.options`` files and annotations, as the generator resolves them)
  and ``Sizes`` (``<Message>_size`` as the generator computes it, the fixed-size contract's limits);
- the wire: varints, wire types and ``next_field``, the one tag walker.
"""

from ._descriptors import (
    Declaration,
    Extension,
    Location,
    Service,
    SourceIndex,
    declarations,
    extensions,
    services,
)
from ._options import Options, ResolvedOptions, options_class, resolve_options
from ._protoc import ProtocError, compile_files
from ._schema import Schema, descriptor_of, enum_of, load_schema, message_of
from ._sizes import Sizes
from ._text import declared_names, imports
from ._wire import (
    EGROUP,
    I32,
    I64,
    LEN,
    SGROUP,
    VARINT,
    WIRE_TYPE_NAMES,
    FieldSpan,
    WireError,
    encode_varint,
    next_field,
    read_varint,
    varint_size,
)

__all__ = [
    "EGROUP",
    "I32",
    "I64",
    "LEN",
    "SGROUP",
    "VARINT",
    "WIRE_TYPE_NAMES",
    "Declaration",
    "Extension",
    "FieldSpan",
    "Location",
    "Options",
    "ProtocError",
    "ResolvedOptions",
    "Schema",
    "Service",
    "Sizes",
    "SourceIndex",
    "WireError",
    "compile_files",
    "declarations",
    "declared_names",
    "descriptor_of",
    "encode_varint",
    "enum_of",
    "extensions",
    "imports",
    "load_schema",
    "message_of",
    "next_field",
    "options_class",
    "read_varint",
    "resolve_options",
    "services",
    "varint_size",
]
