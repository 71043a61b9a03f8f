"""erc_codec: the ERC rover's PBEnvelope codec with nanopb-identical sizes.

This module is the codec and what a user of it needs first: ``Codec`` (a schema's envelope to and
from datagrams), ``Decoded``, ``Mode``, the errors, and ``encode``/``decode`` on the schema found.
The rest is in one public subpackage per layer, each importing only the ones listed before it:
``erc_codec.schema`` (a module re-exporting the schema layer, ``erc_schema``), ``erc_codec.codec``,
``erc_codec.runtime`` (sans-IO dispatch, watchdog, router, framing), ``erc_codec.transport`` (UDP
and serial), ``erc_codec.capture`` (MCAP, Foxglove, Wireshark), and on their own
``erc_codec.proton`` (Clearpath's Proton protocol), ``erc_codec.strategies`` (hypothesis) and
``erc_codec.cli``.
"""

from typing import TYPE_CHECKING

from google.protobuf.message import Message as _Message

from erc_schema import CodecError, DecodeError, EncodeError, SchemaError, UnreadableKind

from . import capture as capture
from . import codec as codec
from . import runtime as runtime
from . import schema as schema
from . import transport as transport
from .codec import (
    Codec,
    Decoded,
    Direction,
    EnvelopeCodec,
    Member,
    MessageCodec,
    Mode,
    UnknownField,
)

__all__ = [
    "Codec",
    "CodecError",
    "DecodeError",
    "Decoded",
    "Direction",
    "EncodeError",
    "EnvelopeCodec",
    "Member",
    "MessageCodec",
    "Mode",
    "SchemaError",
    "UnknownField",
    "UnreadableKind",
    "decode",
    "encode",
]


def encode(message: _Message, mode: "Mode" = "strip", /, **metadata: object) -> bytes:
    """``Codec.default().encode(message, mode, **metadata)``: a datagram of the schema found
    (``decode``; ``timeout=300``: the sender's timeout in milliseconds)."""
    return Codec.default().encode(message, mode, **metadata)


def decode(data: bytes, strict: bool = False) -> "Decoded":
    """``Codec.default().decode(data, strict)``: the payload of a datagram of the schema found
    (``ERC_CODEC_PROTO``, ``[tool.erc-codec]`` in a pyproject.toml, else the packaged one)."""
    return Codec.default().decode(data, strict)


# Names 0.1.0 had at the top level that now live in a room: reaching one here says where it is
# (an AttributeError, no alias).
_MOVED = {
    **dict.fromkeys(("Dispatcher", "DispatchStats", "Drop", "Watchdog", "Liveness"), "runtime"),
    **dict.fromkeys(("Deframer", "DeframerStats", "frame", "DetectionAssembler"), "runtime"),
    **dict.fromkeys(("DetectionFrame", "DetectionLoss", "AssemblerStats", "Rejected"), "runtime"),
    **dict.fromkeys(("Router", "Route", "Failsafe", "FailsafeEvent", "Outgoing"), "runtime"),
    **dict.fromkeys(("RouterStats",), "runtime"),
    **dict.fromkeys(("UdpEndpoint", "UdpStats", "open_udp", "read_serial"), "transport"),
    **dict.fromkeys(("McapWriter", "Recorded", "RecordingStats", "read_mcap"), "capture"),
    **dict.fromkeys(("FoxgloveView", "wireshark_dissector"), "capture"),
}
_RENAMED = {
    "Frame": "DetectionFrame",
    "FrameAssembler": "DetectionAssembler",
    "FrameLoss": "DetectionLoss",
}


if not TYPE_CHECKING:  # a type checker flags every name this module does not define

    def __getattr__(name: str) -> object:
        new = _RENAMED.get(name, name)
        if new in _MOVED:
            raise AttributeError(f"erc_codec.{name} is erc_codec.{_MOVED[new]}.{new}")
        raise AttributeError(f"module 'erc_codec' has no attribute {name!r}")


del TYPE_CHECKING
