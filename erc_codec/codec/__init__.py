"""The codec room: a schema's envelope (or any root message) to and from datagrams.

``Codec`` loads a tree and encodes and decodes its root in three forms (exact, strip, pad), with
nanopb's fixed-size contract checked on the way out and strict decoding on the way in; fields the
schema does not know are kept and found on demand (``UnknownField``); messages go to and from
protobuf's JSON mapping. Nothing here does I/O or keeps time.
"""

from ._codec import Codec, Direction, EnvelopeCodec, Member, MessageCodec
from ._envelope import Decoded, Mode
from ._forms import in_form
from ._unknown import MAX_UNKEPT_NUMBERS, UnkeptFields, UnknownField

__all__ = [
    "MAX_UNKEPT_NUMBERS",
    "Codec",
    "Decoded",
    "Direction",
    "EnvelopeCodec",
    "Member",
    "MessageCodec",
    "Mode",
    "UnkeptFields",
    "UnknownField",
    "in_form",
]
