"""erc_codec: the ERC rover's PBEnvelope codec with nanopb-identical sizes.

The public face is this module and ``erc_codec.schema`` (the schema layer: protoc, descriptors,
nanopb options and sizes, wire primitives), with ``erc_codec.strategies`` for hypothesis users,
``erc_codec.proton`` for Clearpath's Proton protocol and ``erc_codec.cli`` for what both command
lines share. Recording (``McapWriter``, ``read_mcap``), the live view (``FoxgloveView``) and the
Wireshark dissector (``wireshark_dissector``) import their optional libraries only when used.
Everything else is private and free to change.
"""

import warnings
from typing import Any

from google.protobuf.message import Message

from ._codec import Codec, Direction, Member
from ._detections import AssemblerStats, DetectionAssembler, DetectionFrame, FrameLoss, Rejected
from ._dispatch import Dispatcher, DispatchStats, Drop
from ._envelope import Decoded, Mode
from ._errors import CodecError, DecodeError, EncodeError, SchemaError
from ._foxglove import FoxgloveView
from ._framing import Deframer, DeframerStats, frame
from ._mcap import McapWriter, Recorded, RecordingStats, read_mcap
from ._router import Failsafe, FailsafeEvent, Outgoing, Route, Router, RouterStats
from ._transport import UdpEndpoint, UdpStats, open_udp, read_serial
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


def __getattr__(name: str) -> Any:
    if name in _DEPRECATED:
        new = _DEPRECATED[name]
        warnings.warn(
            f"erc_codec.{name} is deprecated: use erc_codec.{new.__name__}",
            DeprecationWarning,
            stacklevel=2,
        )
        return new
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def encode(message: Message, mode: Mode = "strip", /, **metadata: object) -> bytes:
    """``Codec.default().encode(message, mode, **metadata)``: a datagram of the packaged rover
    schema (``timeout=300``: the sender's timeout in milliseconds)."""
    return Codec.default().encode(message, mode, **metadata)


def decode(data: bytes) -> Decoded:
    """``Codec.default().decode(data)``: the payload of a datagram of the packaged schema."""
    return Codec.default().decode(data)
