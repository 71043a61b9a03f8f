"""What a recording and a live view are made of: topics, protobuf schemas, drops and times.

What it guarantees:
- an envelope member's topic is ``/erc/<kind>``; its schema is the payload's full name with a
  ``FileDescriptorSet`` of the payload's file and everything that file imports, dependencies
  first, as the MCAP protobuf profile and Foxglove's decoders read it: a reader needs nothing
  else to decode the messages, and finds the names and values of the .proto;
- what erc-codec adds itself lives under ``/erc-codec/``: a protobuf name never holds a dash, so
  no member's topic can ever be one of these;
- a drop (an ``erc_codec.DroppedDatagram``, protobuf too) keeps the datagram as it arrived, its
  length, the decoder's reason and words, and who sent it to whom: nothing received is lost;
- times are integer nanoseconds since the Unix epoch; a microsecond capture's come out exact.
No I/O here: names, bytes and descriptors.
"""

import functools
import importlib
from types import ModuleType

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from google.protobuf.descriptor import Descriptor
from google.protobuf.message import Message

from erc_schema import descriptor_of

__all__ = [
    "DROPS_TOPIC",
    "FIX_TOPIC",
    "MEMBER_PREFIX",
    "STATS_TOPIC",
    "drop_schema",
    "dropped_datagram",
    "file_descriptor_set",
    "kind_of",
    "member_topic",
    "nanoseconds",
    "require",
]

MEMBER_PREFIX = "/erc/"
DROPS_TOPIC = "/erc-codec/drops"
FIX_TOPIC = "/erc-codec/fix"
STATS_TOPIC = "/erc-codec/stats"

_F = descriptor_pb2.FieldDescriptorProto
# erc_codec/dropped_datagram.proto, as a descriptor (no protoc run at import):
#   syntax = "proto3"; package erc_codec;
#   message DroppedDatagram {
#     string reason = 1;       // DecodeError.reason: empty, too_long, unknown_member, ...
#     string error = 2;        // what the decoder said, one line
#     uint32 length = 3;       // bytes received
#     bytes data = 4;          // the datagram, exactly as received
#     string source = 5;       // the sender, address:port ("" when unknown)
#     string destination = 6;  // the receiver, address:port (captures; "" when unknown)
#   }
_DROP_FIELDS = (
    ("reason", _F.TYPE_STRING),
    ("error", _F.TYPE_STRING),
    ("length", _F.TYPE_UINT32),
    ("data", _F.TYPE_BYTES),
    ("source", _F.TYPE_STRING),
    ("destination", _F.TYPE_STRING),
)


def _drop_file() -> descriptor_pb2.FileDescriptorProto:
    file = descriptor_pb2.FileDescriptorProto(
        name="erc_codec/dropped_datagram.proto", package="erc_codec", syntax="proto3"
    )
    message = file.message_type.add(name="DroppedDatagram")
    for number, (name, kind) in enumerate(_DROP_FIELDS, start=1):
        message.field.add(name=name, number=number, type=kind, label=_F.LABEL_OPTIONAL)
    return file


@functools.cache
def dropped_datagram() -> type[Message]:
    """The ``erc_codec.DroppedDatagram`` message class (built on first use)."""
    pool = descriptor_pool.DescriptorPool()
    pool.Add(_drop_file())
    return message_factory.GetMessageClass(pool.FindMessageTypeByName("erc_codec.DroppedDatagram"))


def member_topic(kind: str) -> str:
    """The topic of envelope member ``kind``: ``/erc/<kind>``."""
    return MEMBER_PREFIX + kind


def kind_of(topic: str) -> str | None:
    """The envelope member a topic carries, or ``None`` for a topic that is not a member's."""
    if topic.startswith(MEMBER_PREFIX) and "/" not in topic[len(MEMBER_PREFIX) :]:
        return topic[len(MEMBER_PREFIX) :] or None
    return None


@functools.cache
def file_descriptor_set(descriptor: Descriptor) -> bytes:
    """The serialized ``FileDescriptorSet`` of ``descriptor``'s file and everything it imports,
    each file once, dependencies first (source locations and comments left out)."""
    files = descriptor_pb2.FileDescriptorSet()
    seen: set[str] = set()
    # Depth first without recursion: a file after all of its imports.
    pending = [(descriptor.file, False)]
    while pending:
        file, expanded = pending.pop()
        if file.name in seen:
            continue
        if expanded:
            seen.add(file.name)
            file.CopyToProto(files.file.add())
        else:
            pending.append((file, True))
            pending.extend((dependency, False) for dependency in reversed(file.dependencies))
    return files.SerializeToString()


def drop_schema() -> tuple[str, bytes]:
    """The full name and ``FileDescriptorSet`` of ``DroppedDatagram``, for a drops channel."""
    descriptor = descriptor_of(dropped_datagram())
    return descriptor.full_name, file_descriptor_set(descriptor)


def nanoseconds(seconds: float) -> int:
    """A capture's time (float seconds since the epoch) as integer nanoseconds.

    A float of today's seconds holds them to within 0.12 µs, so a time of a microsecond capture
    (pcap's kind, and pcapng's by default) reads back up to 0.12 µs off its microsecond; within a
    quarter of one it is put back on it. A nanosecond capture's times stay within 0.37 µs.
    """
    whole = int(seconds // 1)
    nanos = round((seconds - whole) * 1e9)  # exact: seconds and whole share their exponent
    off = (nanos + 500) % 1000 - 500  # how far from the nearest microsecond, -500..499
    return whole * 1_000_000_000 + (nanos - off if -250 <= off <= 250 else nanos)


def require(module: str, package: str, extra: str, what: str) -> ModuleType:
    """Import ``module`` of an optional dependency, or say in one line which extra brings it."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise ImportError(
            f"{what} needs the {package} package: pip install 'erc-codec[{extra}]'"
        ) from None
