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
    from ._dispatch import Dispatcher, DispatchStats, Drop
    from ._envelope import Decoded, Mode
    from ._frames import AssemblerStats, Frame, FrameAssembler, FrameLoss, Rejected
    from ._framing import Deframer, DeframerStats, frame
    from ._transport import UdpEndpoint, open_udp, read_serial
    from ._watchdog import Liveness, Watchdog

__all__ = [
    "AssemblerStats",
    "Codec",
    "CodecError",
    "DecodeError",
    "Decoded",
    "Deframer",
    "DeframerStats",
    "DispatchStats",
    "Dispatcher",
    "Drop",
    "EncodeError",
    "Frame",
    "FrameAssembler",
    "FrameLoss",
    "Liveness",
    "Mode",
    "Rejected",
    "SchemaError",
    "UdpEndpoint",
    "Watchdog",
    "decode",
    "encode",
    "frame",
    "open_udp",
    "read_serial",
]

_LAZY = {
    "Codec": "._codec",
    "Decoded": "._envelope",
    "Mode": "._envelope",
    "Dispatcher": "._dispatch",
    "DispatchStats": "._dispatch",
    "Drop": "._dispatch",
    "Watchdog": "._watchdog",
    "Liveness": "._watchdog",
    "FrameAssembler": "._frames",
    "Frame": "._frames",
    "FrameLoss": "._frames",
    "Rejected": "._frames",
    "AssemblerStats": "._frames",
    "Deframer": "._framing",
    "DeframerStats": "._framing",
    "frame": "._framing",
    "UdpEndpoint": "._transport",
    "open_udp": "._transport",
    "read_serial": "._transport",
}


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
