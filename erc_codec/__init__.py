"""erc_codec: the ERC rover's PBEnvelope codec with nanopb-identical sizes.

The public face is this module and ``erc_codec.schema`` (the schema layer: protoc, descriptors,
nanopb options and sizes, wire primitives), with ``erc_codec.strategies`` for hypothesis users,
``erc_codec.proton`` for Clearpath's Proton protocol and ``erc_codec.cli`` for what both command
lines share. Recording (``McapWriter``, ``read_mcap``), the live view (``FoxgloveView``) and the
Wireshark dissector (``wireshark_dissector``) import their optional libraries only when used.
Each name's own module loads on the name's first use, so ``erc_codec.schema`` (and erc-lint,
which uses nothing else of the package but its errors) does not load the codec. Everything else
is private and free to change.
"""

import importlib as _importlib
import warnings as _warnings
from typing import TYPE_CHECKING as _TYPE_CHECKING
from typing import Any as _Any

from google.protobuf.message import Message as _Message

from erc_schema import CodecError, DecodeError, EncodeError, SchemaError

from . import schema as schema  # the schema layer, as erc_codec.schema

if _TYPE_CHECKING:
    from ._codec import Codec, Direction, Member, MessageCodec
    from ._detections import (
        AssemblerStats,
        DetectionAssembler,
        DetectionFrame,
        DetectionLoss,
        Rejected,
    )
    from ._dispatch import Dispatcher, DispatchStats, Drop
    from ._envelope import Decoded, Mode
    from ._foxglove import FoxgloveView
    from ._framing import Deframer, DeframerStats, frame
    from ._mcap import McapWriter, Recorded, RecordingStats, read_mcap
    from ._router import Failsafe, FailsafeEvent, Outgoing, Route, Router, RouterStats
    from ._transport import UdpEndpoint, UdpStats, open_udp, read_serial
    from ._unknown import UnknownField
    from ._watchdog import Liveness, Watchdog
    from ._wireshark import wireshark_dissector

# Each name's module, imported on first use of the name: importing ``erc_codec.schema`` (which
# runs this file first) then costs the schema layer and the errors alone. That is all erc-lint
# uses of this package, and the codec's modules cost some 25-45 ms of every erc-lint run
# (bench_lint.py's 30-file ratio to buf breaking, target <= 1.00x). The names are the same
# objects, however and whenever they are imported.
_LAZY = {
    "Codec": "_codec",
    "Direction": "_codec",
    "Member": "_codec",
    "MessageCodec": "_codec",
    "AssemblerStats": "_detections",
    "DetectionAssembler": "_detections",
    "DetectionFrame": "_detections",
    "DetectionLoss": "_detections",
    "Rejected": "_detections",
    "Dispatcher": "_dispatch",
    "DispatchStats": "_dispatch",
    "Drop": "_dispatch",
    "Decoded": "_envelope",
    "Mode": "_envelope",
    "FoxgloveView": "_foxglove",
    "Deframer": "_framing",
    "DeframerStats": "_framing",
    "frame": "_framing",
    "McapWriter": "_mcap",
    "Recorded": "_mcap",
    "RecordingStats": "_mcap",
    "read_mcap": "_mcap",
    "Failsafe": "_router",
    "FailsafeEvent": "_router",
    "Outgoing": "_router",
    "Route": "_router",
    "Router": "_router",
    "RouterStats": "_router",
    "UdpEndpoint": "_transport",
    "UdpStats": "_transport",
    "open_udp": "_transport",
    "read_serial": "_transport",
    "UnknownField": "_unknown",
    "Liveness": "_watchdog",
    "Watchdog": "_watchdog",
    "wireshark_dissector": "_wireshark",
}

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
    "DetectionLoss",
    "Direction",
    "DispatchStats",
    "Dispatcher",
    "Drop",
    "EncodeError",
    "Failsafe",
    "FailsafeEvent",
    "FoxgloveView",
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
_DEPRECATED = {
    "Frame": "DetectionFrame",
    "FrameAssembler": "DetectionAssembler",
    "FrameLoss": "DetectionLoss",
}


def __getattr__(name: str) -> _Any:
    if name in _LAZY:
        value = getattr(_importlib.import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value  # once: later uses read the module's namespace directly
        return value
    if name in _DEPRECATED:
        new = _DEPRECATED[name]
        _warnings.warn(
            f"erc_codec.{name} is deprecated: use erc_codec.{new}",
            DeprecationWarning,
            stacklevel=2,
        )
        return __getattr__(new)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})


def encode(message: _Message, mode: "Mode" = "strip", /, **metadata: object) -> bytes:
    """``Codec.default().encode(message, mode, **metadata)``: a datagram of the schema found
    (``decode``; ``timeout=300``: the sender's timeout in milliseconds)."""
    from ._codec import Codec

    return Codec.default().encode(message, mode, **metadata)


def decode(data: bytes, strict: bool = False) -> "Decoded":
    """``Codec.default().decode(data, strict)``: the payload of a datagram of the schema found
    (``ERC_CODEC_PROTO``, ``[tool.erc-codec]`` in a pyproject.toml, else the packaged one)."""
    from ._codec import Codec

    return Codec.default().decode(data, strict)
