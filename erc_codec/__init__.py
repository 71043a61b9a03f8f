"""erc_codec: the ERC rover's PBEnvelope codec with nanopb-identical sizes.

The public face is this module; everything it does not re-export is private and free to change.
The codec's modules load on first use, so a tool that needs only part of the package (erc-lint
uses the schema loader and the size model) does not pay for the rest at start-up.
"""

import importlib
from typing import TYPE_CHECKING, Any

from ._errors import CodecError, DecodeError, EncodeError, SchemaError

if TYPE_CHECKING:
    from google.protobuf.message import Message

    from ._codec import Codec
    from ._envelope import Decoded, Mode

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

_LAZY = {"Codec": "._codec", "Decoded": "._envelope", "Mode": "._envelope"}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def encode(message: "Message", mode: "Mode" = "strip") -> bytes:
    """``Codec.default().encode(message, mode)``: a datagram of the packaged rover schema."""
    from ._codec import Codec

    return Codec.default().encode(message, mode)


def decode(data: bytes) -> "Decoded":
    """``Codec.default().decode(data)``: the payload of a datagram of the packaged schema."""
    from ._codec import Codec

    return Codec.default().decode(data)
