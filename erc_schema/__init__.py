"""erc_schema: a proto tree as protoc, nanopb's generator and the wire see it.

The foundation of both packages, and usable on its own: ``erc_codec`` loads a schema, sizes it and
checks messages against it; ``erc_lint`` compiles trees file by file, locates what it reports and
asks for sizes and nanopb limits. Nothing here encodes envelopes or talks to a network, and
nothing here imports either package.

- the errors both packages raise: ``CodecError`` and its subclasses ``SchemaError``,
  ``EncodeError``, ``DecodeError`` (with a ``reason``) and ``UnreadableKind``; and, in
  ``erc_schema.cli``, the one-line click group both command lines are made of;

- a tree as commands name it: ``open_tree`` (a folder, or a git revision in buf's spelling,
  ``GITDIR#ref=REF[,subdir=PATH]``, read from the repository's objects into a scratch folder:
  ``TreeSource``), ``parse_tree_spec`` and ``GitSpec``, ``Repository`` (a repository's objects,
  no checkout) and ``GitError``;
- a tree's files read without trusting them: ``read_file``/``read_text`` (regular files only,
  at most a limit: ``SOURCE_LIMIT`` for a ``.proto`` or ``.options``; else ``FileError``),
  ``file_exists`` and ``proto_files`` (the walk, never into a symlinked folder);
- protoc in-process: ``compile_files`` (a ``FileDescriptorSet``, or ``ProtocError`` with protoc's
  own ``path:line:col`` diagnostics);
- a tree's text before it compiles: ``imports`` (as protoc tokenizes them) and ``declared_names``;
- compiled files: ``declarations`` (every message and enum, nested ones too, with their source
  paths), ``extensions`` and ``services`` (likewise) and ``SourceIndex`` (a path's ``Location``
  and trailing comment);
- a loaded schema: ``load_schema`` and ``Schema`` (descriptor pool, classes, locations, include
  folders, and the messages protobuf's Python runtime refuses to build, with why);
- nanopb: ``resolve_options`` (``.options`` files, found as the generator finds them
  (``options_path``), its ``-f`` (``given_options_file``: one as a user gives it) and ``-s``,
  and annotations; patterns match ``nanopb_name``, the name under ``mangle_names``, and
  ``nanopb_finds`` says whether a field's type is found under them; ``is_nanopb_vocabulary``
  recognizes nanopb.proto under any name) and ``Sizes``
  (``<Message>_size`` as the generator computes it, by the rules of one of ``NANOPB_VERSIONS``,
  the fixed-size contract's limits; ``PYTHON_INT_RANGE``, what protobuf's Python runtime lets
  each integer type hold);
- the wire: varints, wire types, ``MAX_FIELD_NUMBER`` and ``next_field``, the one tag walker.
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
from ._errors import CodecError, DecodeError, EncodeError, SchemaError, UnreadableKind
from ._files import SOURCE_LIMIT, FileError, file_exists, proto_files, read_file, read_text
from ._git import GitError, Repository
from ._names import nanopb_finds, nanopb_name
from ._options import (
    Options,
    ResolvedOptions,
    given_options_file,
    is_nanopb_vocabulary,
    options_class,
    options_path,
    resolve_options,
)
from ._protoc import ProtocError, compile_files
from ._schema import Schema, descriptor_of, enum_of, load_schema, message_of
from ._sizes import NANOPB_VERSIONS, PYTHON_INT_RANGE, Sizes
from ._text import declared_names, imports
from ._tree import GitSpec, TreeSource, open_tree, parse_tree_spec
from ._wire import (
    EGROUP,
    I32,
    I64,
    LEN,
    MAX_FIELD_NUMBER,
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
    "MAX_FIELD_NUMBER",
    "NANOPB_VERSIONS",
    "PYTHON_INT_RANGE",
    "SGROUP",
    "SOURCE_LIMIT",
    "VARINT",
    "WIRE_TYPE_NAMES",
    "CodecError",
    "Declaration",
    "DecodeError",
    "EncodeError",
    "Extension",
    "FieldSpan",
    "FileError",
    "GitError",
    "GitSpec",
    "Location",
    "Options",
    "ProtocError",
    "Repository",
    "ResolvedOptions",
    "Schema",
    "SchemaError",
    "Service",
    "Sizes",
    "SourceIndex",
    "TreeSource",
    "UnreadableKind",
    "WireError",
    "compile_files",
    "declarations",
    "declared_names",
    "descriptor_of",
    "encode_varint",
    "enum_of",
    "extensions",
    "file_exists",
    "given_options_file",
    "imports",
    "is_nanopb_vocabulary",
    "load_schema",
    "message_of",
    "nanopb_finds",
    "nanopb_name",
    "next_field",
    "open_tree",
    "options_class",
    "options_path",
    "parse_tree_spec",
    "proto_files",
    "read_file",
    "read_text",
    "read_varint",
    "resolve_options",
    "services",
    "varint_size",
]
