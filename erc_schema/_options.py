"""nanopb's generator options for every field, oneof and message of a schema.

Options come from three places and are resolved exactly as nanopb's generator (run from the tree's
root, ``nanopb_generator -I DIR ... -f FILE -s OPTION:VALUE``) resolves them: generator settings
(``-s max_size:61``, every file starts from them); an options file per ``.proto``, found as the
generator finds it (``-f``'s pattern, by default ``%s.options``, ``%s`` the file's name without
``.proto``, looked for under the tree's root, then under each include folder in order; lines
``PATTERN option:value ...`` matched with ``fnmatchcase`` against dotted names, or the file's own
name); and in-file annotations (``[(nanopb).max_size = 32]``, ``option (nanopb_msgopt)...``,
``option (nanopb_fileopt)...``). Every message, nested or not, starts from its file's options; a
field or oneof starts from its message's; an extension, wherever declared, from its file's. At
each level matching options lines merge in file order, then the annotation, which wins.

A pattern matches the name nanopb gives an element under its file's ``mangle_names`` and
``(nanopb_fileopt).package`` (``nanopb_name``: ``Outer.Inner`` for ``pkg.Outer.Inner`` under
``M_STRIP_PACKAGE``, ...); a field or oneof is matched as that name and its own. Options stay
keyed by the real full names.
"""

import functools
import os
import re
from collections.abc import Iterator, Sequence
from fnmatch import fnmatchcase
from pathlib import Path
from typing import Any

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from google.protobuf.message import DecodeError as ProtobufDecodeError
from google.protobuf.message import Message

from ._descriptors import declarations, extensions
from ._errors import SchemaError
from ._files import file_exists, read_text
from ._names import nanopb_name
from ._protoc import FALLBACK_INCLUDE, compile_files
from ._wire import LEN, WireError, next_field

__all__ = [
    "VOCABULARY",
    "Options",
    "ResolvedOptions",
    "compile_vocabulary",
    "given_options_file",
    "is_nanopb_vocabulary",
    "options_class",
    "options_path",
    "resolve_options",
]

_EXTENSION = 1010  # (nanopb), (nanopb_msgopt), (nanopb_fileopt) on the descriptor options
_COMMENTS = re.compile(r"/\*.*?\*/|//.*$|#.*$")

# NanoPBOptions is a message class built at run time: its instances are typed Any.
Options = Any
Rules = list[tuple[str, Options]]


class ResolvedOptions:
    """nanopb options resolved for a schema, by full name: ``messages["Msg"]``,
    ``fields["Msg.f"]``, ``oneofs["Msg.o"]``, ``enums["Msg.Kind"]``, and each file's own by its
    name, ``files["a/b.proto"]`` (its ``mangle_names`` and ``package`` among them), and each
    extension's by its full name, ``extensions["pkg.Scope.ext"]``. ``unique``: no full name was
    declared by two of the files (a tree may hold two never compiled together), so the options
    of any of the files are those ``resolve_options`` gives for them alone."""

    def __init__(self) -> None:
        self.unique = True
        self.files: dict[str, Options] = {}
        self.messages: dict[str, Options] = {}
        self.fields: dict[str, Options] = {}
        self.oneofs: dict[str, Options] = {}
        self.enums: dict[str, Options] = {}
        self.extensions: dict[str, Options] = {}


# nanopb.proto compiled, as ``compile_vocabulary`` compiles it, shipped beside it: no process
# spends a protoc run compiling it again.
# test_shipped_vocabulary_is_protocs holds it to what protoc makes of the shipped nanopb.proto.
VOCABULARY = Path(FALLBACK_INCLUDE) / "nanopb.pb"


@functools.cache
def options_class() -> Any:
    """The NanoPBOptions message class, of erc-codec's copy of the vocabulary (``VOCABULARY``,
    compiled from it).

    The descriptor.proto it imports is the one this protobuf runtime holds, given to the pool as
    it is: parsing and writing out its thousand lines again took most of the compilation's time.
    """
    pool = descriptor_pool.DescriptorPool()
    pool.AddSerializedFile(descriptor_pb2.DESCRIPTOR.serialized_pb)
    for proto in descriptor_pb2.FileDescriptorSet.FromString(VOCABULARY.read_bytes()).file:
        pool.AddSerializedFile(proto.SerializeToString())
    return message_factory.GetMessageClass(pool.FindMessageTypeByName("NanoPBOptions"))


def is_nanopb_vocabulary(proto: descriptor_pb2.FileDescriptorProto) -> bool:
    """Whether ``proto`` is nanopb.proto, whatever it is called (``third_party/nanopb.proto``):
    the file extending protobuf's field options with ``(nanopb)``, number 1010."""
    return any(
        extension.extendee == ".google.protobuf.FieldOptions" and extension.number == _EXTENSION
        for extension in proto.extension
    )


def compile_vocabulary() -> descriptor_pb2.FileDescriptorSet:
    """erc-codec's copy of nanopb.proto compiled by protoc, alone: the descriptor.proto it
    imports given to protoc as a known file, the one this protobuf runtime holds."""
    runtime = descriptor_pb2.FileDescriptorProto.FromString(descriptor_pb2.DESCRIPTOR.serialized_pb)
    return compile_files(
        Path(FALLBACK_INCLUDE),
        ["nanopb.proto"],
        known=descriptor_pb2.FileDescriptorSet(file=[runtime]),
        locations=False,
        defaults=False,
        imports=False,
    )


def resolve_options(
    tree: Path,
    files: Sequence[descriptor_pb2.FileDescriptorProto],
    include: Sequence[Path] = (),
    options_file: str = "%s.options",
    settings: Sequence[str] = (),
) -> ResolvedOptions:
    """Resolve the nanopb options of every message, field, oneof and enum in ``files``, as
    nanopb's generator run in ``tree`` with ``-I`` for each of ``include``, ``-f options_file``
    and ``-s`` for each of ``settings`` resolves them. As the generator does, every message
    starts from its file's options, a nested enum from its message's (``enum_intsize``,
    ``long_names``, ...).

    The settings are checked, and an ``options_file`` without ``%s`` (one file for all) must be
    found, even for no ``files``: either is a ``SchemaError`` (nanopb's generator warns of a
    missing one and sizes without it)."""
    resolved = ResolvedOptions()
    top = _settings(settings)
    if _one_file(options_file) and options_path(tree, include, options_file, "") is None:
        where = ", ".join(str(folder) for folder in (tree, *include))
        raise SchemaError(f"options file {options_file}: not found (looked in {where})")
    for proto in files:
        rules = _read_rules(options_path(tree, include, options_file, proto.name))
        base = resolved.files[proto.name] = _merge(top, rules, proto.name, proto.options)
        extended = list(extensions(proto, nested=False))  # and each message's, below
        for declaration in declarations(proto):
            message = declaration.proto
            name = declaration.name
            # Where the file has no options lines and an element no annotation, it has its
            # parent's options: taken as they are, with no _merge call, and without working out
            # its nanopb name (only options lines are matched against it). The sizes are held
            # to nanopb's generator's by test_generator_inputs, test_sizes and test_nanopb_rules.
            annotated = message.HasField("options")
            seen = nanopb_name(proto.package, base, name) if rules else name
            if not isinstance(message, descriptor_pb2.DescriptorProto):
                parent = resolved.messages[declaration.parent] if declaration.parent else base
                resolved.unique = resolved.unique and name not in resolved.enums
                resolved.enums[name] = (
                    _merge(parent, rules, seen, message.options) if rules or annotated else parent
                )
                continue
            extended += declaration.extensions()
            resolved.unique = resolved.unique and name not in resolved.messages
            own = resolved.messages[name] = (
                _merge(base, rules, seen, message.options) if rules or annotated else base
            )
            fields, prefix = resolved.fields, f"{name}."
            for field in message.field:
                if not rules and not field.HasField("options"):
                    fields[prefix + field.name] = own  # nothing applies (see above)
                    continue
                options = field.options if field.HasField("options") else None
                dotted = f"{seen}.{field.name}"
                fields[prefix + field.name] = _merge(own, rules, dotted, options)
            if rules:  # oneofs carry no (nanopb) annotation: only .options lines reach them
                for oneof in message.oneof_decl:
                    dotted = f"{seen}.{oneof.name}"
                    resolved.oneofs[prefix + oneof.name] = _merge(own, rules, dotted, None)
            else:
                for oneof in message.oneof_decl:
                    resolved.oneofs[prefix + oneof.name] = own
        for extension in extended:
            # The generator starts an extension from its file's options (not its scope's) and
            # matches it as its full name: ``pkg.ext``, ``pkg.Scope.ext`` under M_NONE.
            declared = extension.proto
            if not rules and not declared.HasField("options"):
                resolved.extensions[extension.name] = base  # nothing applies (see above)
                continue
            annotation = declared.options if declared.HasField("options") else None
            seen = nanopb_name(proto.package, base, extension.name)
            resolved.extensions[extension.name] = _merge(base, rules, seen, annotation)
    return resolved


def _settings(settings: Sequence[str]) -> Options:
    """The options every file starts from: the generator's ``-s`` settings merged in order
    (``key=value`` read as ``key:value``, as the generator reads it)."""
    top = options_class()()
    if not settings:
        return top
    from google.protobuf import text_format  # see _read_rules

    for setting in settings:
        text = setting.replace("=", ":") if ":" not in setting and "=" in setting else setting
        try:
            text_format.Merge(text, top)
        except text_format.ParseError as error:
            raise SchemaError(f"generator setting {setting!r}: {error}") from None
    return top


def _one_file(pattern: str) -> bool:
    """Whether an options file pattern names one file for every .proto (it has no ``%s``)."""
    try:
        pattern % ""
    except TypeError:
        return True
    except ValueError:
        return False  # options_path says what is wrong with it
    return False


def options_path(tree: Path, include: Sequence[Path], pattern: str, name: str) -> Path | None:
    """Where nanopb's generator reads the options of file ``name`` (tree-relative) from, if
    anywhere: ``pattern`` (``-f``) with ``%s`` the name without its suffix (a pattern without
    ``%s`` names one file for all), under ``tree``, then under each include folder, the first
    that holds it (an absolute pattern is itself)."""
    try:
        wanted = pattern % os.path.splitext(name)[0]
    except TypeError:  # no %s in it (the generator's own test)
        wanted = pattern
    except ValueError as error:
        raise SchemaError(f"options file pattern {pattern!r}: {error}") from None
    for folder in (tree, *include):
        path = folder / wanted
        if file_exists(path):
            return path
    return None


def given_options_file(options_file: str, here: Path) -> str:
    """An options file as given where paths are relative to ``here`` (the working folder, a
    configuration's folder): one file (no ``%s``) that is there, as that path; anything else as
    given, for nanopb's search under the tree and its include folders."""
    if "%" in options_file or Path(options_file).is_absolute():
        return options_file
    beside = here / options_file
    return str(beside.absolute()) if beside.is_file() else options_file


def _merge(parent: Options, rules: Rules, dotted: str, options: Message | None) -> Options:
    """``parent`` with the matching rules, then the annotation, merged in. Where nothing applies
    (nearly every field) the result is ``parent`` itself: resolved options are shared, never
    modified after resolution."""
    matching = [values for pattern, values in rules if fnmatchcase(dotted, pattern)]
    data = options.SerializeToString() if options is not None else b""
    annotations = list(_annotations(data)) if data else []
    if not matching and not annotations:
        return parent
    merged = type(parent)()
    merged.CopyFrom(parent)
    for values in (*matching, *annotations):
        merged.MergeFrom(values)
    return merged


def _annotations(data: bytes) -> Iterator[Options]:
    """The NanoPBOptions carried as extension 1010 inside serialized descriptor options."""
    pos = 0
    cls = options_class()
    try:
        while pos < len(data):
            field = next_field(data, pos)
            if field.number == _EXTENSION and field.wire_type == LEN:
                yield cls.FromString(data[field.value : field.end])
            pos = field.end
    except (WireError, ProtobufDecodeError) as error:  # protoc wrote these bytes itself
        raise SchemaError(f"unreadable nanopb annotation: {error}") from None


def _read_rules(path: Path | None) -> Rules:
    if path is None:  # a FIFO or a device counts as found: read_text refuses it
        return []
    # Imported only when there is a file to read: text_format is slow to import, and a tree
    # without a .options file never needs it.
    from google.protobuf import text_format

    rules: Rules = []
    cls = options_class()
    text = read_text(path)
    for number, line in enumerate(text.splitlines(), 1):
        parts = _COMMENTS.sub("", line).split(None, 1)
        if not parts:
            continue
        if len(parts) == 1:
            raise SchemaError(
                f"{path}:{number}: '{parts[0]}' names no options (PATTERN option:value)"
            )
        values = cls()
        try:
            text_format.Merge(parts[1], values)
        except text_format.ParseError as error:
            raise SchemaError(f"{path}:{number}: {error}") from None
        rules.append((parts[0], values))
    return rules
