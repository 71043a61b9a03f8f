"""nanopb's generator options for every field, oneof and message of a schema.

Options come from two places and are resolved exactly as nanopb's generator resolves them: a
``.options`` file beside each ``.proto`` (``<stem>.options``, lines ``PATTERN option:value ...``
matched with ``fnmatchcase`` against dotted names, or the file's own name) and in-file annotations
(``[(nanopb).max_size = 32]``, ``option (nanopb_msgopt)...``, ``option (nanopb_fileopt)...``).
Every message, nested or not, starts from its file's options; a field or oneof starts from its
message's. At each level matching ``.options`` lines merge in file order, then the annotation, which
wins.
"""

import functools
import re
from collections.abc import Iterator
from fnmatch import fnmatchcase
from pathlib import Path
from typing import Any

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from google.protobuf.message import DecodeError as ProtobufDecodeError
from google.protobuf.message import Message

from .._errors import SchemaError
from ._descriptors import declarations
from ._files import file_exists, read_text
from ._protoc import FALLBACK_INCLUDE, compile_files
from ._wire import LEN, WireError, next_field

__all__ = ["Options", "ResolvedOptions", "options_class", "resolve_options"]

_EXTENSION = 1010  # (nanopb), (nanopb_msgopt), (nanopb_fileopt) on the descriptor options
_COMMENTS = re.compile(r"/\*.*?\*/|//.*$|#.*$")

# NanoPBOptions is a message class built at run time: its instances are typed Any.
Options = Any
Rules = list[tuple[str, Options]]


class ResolvedOptions:
    """nanopb options resolved for a schema, by full name: ``messages["Msg"]``,
    ``fields["Msg.f"]``, ``oneofs["Msg.o"]``."""

    def __init__(self) -> None:
        self.messages: dict[str, Options] = {}
        self.fields: dict[str, Options] = {}
        self.oneofs: dict[str, Options] = {}


@functools.cache
def options_class() -> Any:
    """The NanoPBOptions message class, compiled from erc-codec's copy of the vocabulary.

    The descriptor.proto it imports is the one this protobuf runtime holds, given to protoc as a
    known file and to the pool as it is: parsing and writing out its thousand lines again took
    most of the compilation's time.
    """
    runtime = descriptor_pb2.DESCRIPTOR.serialized_pb
    known = descriptor_pb2.FileDescriptorSet(
        file=[descriptor_pb2.FileDescriptorProto.FromString(runtime)]
    )
    files = compile_files(
        Path(FALLBACK_INCLUDE),
        ["nanopb.proto"],
        known=known,
        locations=False,
        defaults=False,
        imports=False,
    )
    pool = descriptor_pool.DescriptorPool()
    for serialized in (runtime, *(proto.SerializeToString() for proto in files.file)):
        pool.AddSerializedFile(serialized)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName("NanoPBOptions"))


def resolve_options(
    tree: Path, files: tuple[descriptor_pb2.FileDescriptorProto, ...]
) -> ResolvedOptions:
    """Resolve the nanopb options of every message, field and oneof in ``files``."""
    resolved = ResolvedOptions()
    for proto in files:
        rules = _read_rules(tree / Path(proto.name).with_suffix(".options"))
        base = _merge(options_class()(), rules, proto.name, proto.options)
        for declaration in declarations(proto):
            message = declaration.proto
            if not isinstance(message, descriptor_pb2.DescriptorProto):
                continue
            name = declaration.name
            own = resolved.messages[name] = _merge(base, rules, name, message.options)
            for field in message.field:
                options = field.options if field.HasField("options") else None
                dotted = f"{name}.{field.name}"
                resolved.fields[dotted] = _merge(own, rules, dotted, options)
            for oneof in message.oneof_decl:
                # oneofs carry no (nanopb) annotation: only .options lines reach them
                dotted = f"{name}.{oneof.name}"
                resolved.oneofs[dotted] = _merge(own, rules, dotted, None)
    return resolved


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


def _read_rules(path: Path) -> Rules:
    if not file_exists(path):  # a FIFO or a device is there: read_text refuses it
        return []
    # Imported only when there is a file to read: text_format costs every erc-lint run some
    # milliseconds of start-up, and the rover's tree has no .options file (the erc-lint/buf
    # ratio of benchmarks/bench_lint.py, <= 1.0, counts that start-up).
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
