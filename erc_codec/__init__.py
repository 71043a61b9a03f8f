"""erc_codec: the ERC rover's PBEnvelope codec with nanopb-identical sizes.

The public face is this module and ``erc_codec.schema`` (the schema layer: protoc, descriptors,
nanopb options and sizes, wire primitives), with ``erc_codec.strategies`` for hypothesis users,
``erc_codec.proton`` for Clearpath's Proton protocol and ``erc_codec.cli`` for what both command
lines share. Recording (``McapWriter``, ``read_mcap``), the live view (``FoxgloveView``) and the
Wireshark dissector (``wireshark_dissector``) import their optional libraries only when used.
Everything else is private and free to change.
"""

import warnings as _warnings
from typing import Any as _Any

from google.protobuf.message import Message as _Message

from ._codec import Codec, Direction, Member, MessageCodec
from ._detections import AssemblerStats, DetectionAssembler, DetectionFrame, FrameLoss, Rejected
from ._dispatch import Dispatcher, DispatchStats, Drop
from ._envelope import Decoded, Mode
from ._errors import CodecError, DecodeError, EncodeError, SchemaError
from ._foxglove import FoxgloveView
from ._framing import Deframer, DeframerStats, frame
from ._mcap import McapWriter, Recorded, RecordingStats, read_mcap
from ._router import Failsafe, FailsafeEvent, Outgoing, Route, Router, RouterStats
from ._transport import UdpEndpoint, UdpStats, open_udp, read_serial
from ._unknown import UnknownField
from ._watchdog import Liveness, Watchdog
from ._wireshark import wireshark_dissector

__all__ = [
    "AssemblerStats",
    "Codec",
    "CodecError",
    "DecodeError",
    "Decoded",
    "Deframer",
    "DeframerStats",
    "DetectionAssembler",
    "DetectionFrame",
    "Direction",
    "DispatchStats",
    "Dispatcher",
    "Drop",
    "EncodeError",
    "Failsafe",
    "FailsafeEvent",
    "FoxgloveView",
    "FrameLoss",
    "Liveness",
    "McapWriter",
    "Member",
    "MessageCodec",
    "Mode",
    "Outgoing",
    "Recorded",
    "RecordingStats",
    "Rejected",
    "Route",
    "Router",
    "RouterStats",
    "SchemaError",
    "UdpEndpoint",
    "UdpStats",
    "UnknownField",
    "Watchdog",
    "decode",
    "encode",
    "frame",
    "open_udp",
    "read_mcap",
    "read_serial",
    "wireshark_dissector",
]

# Names renamed in 0.2, kept for one release: the detection side had the serial framing's words.
_DEPRECATED = {"Frame": DetectionFrame, "FrameAssembler": DetectionAssembler}


def __getattr__(name: str) -> _Any:
    if name in _DEPRECATED:
        new = _DEPRECATED[name]
        _warnings.warn(
            f"erc_codec.{name} is deprecated: use erc_codec.{new.__name__}",
            DeprecationWarning,
            stacklevel=2,
        )
        return new
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def encode(message: _Message, mode: Mode = "strip", /, **metadata: object) -> bytes:
    """``Codec.default().encode(message, mode, **metadata)``: a datagram of the schema found
    (``decode``; ``timeout=300``: the sender's timeout in milliseconds)."""
    return Codec.default().encode(message, mode, **metadata)


def decode(data: bytes, strict: bool = False) -> Decoded:
    """``Codec.default().decode(data, strict)``: the payload of a datagram of the schema found
    (``ERC_CODEC_PROTO``, ``[tool.erc-codec]`` in a pyproject.toml, else the packaged one)."""
    return Codec.default().decode(data, strict)
