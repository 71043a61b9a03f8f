"""erc_codec: the ERC rover's PBEnvelope codec with nanopb-identical sizes.

The public face is this module; everything it does not re-export is private and free to change.
"""

from google.protobuf.message import Message

from ._codec import Codec
from ._envelope import Decoded, Mode
from ._errors import CodecError, DecodeError, EncodeError, SchemaError

__all__ = [
    "Codec",
    "CodecError",
    "DecodeError",
    "Decoded",
    "EncodeError",
    "Mode",
    "SchemaError",
    "decode",
    "encode",
]


def encode(message: Message, mode: Mode = "strip") -> bytes:
    """``Codec.default().encode(message, mode)``: a datagram of the packaged rover schema."""
    return Codec.default().encode(message, mode)


def decode(data: bytes) -> Decoded:
    """``Codec.default().decode(data)``: the payload of a datagram of the packaged schema."""
    return Codec.default().decode(data)
