"""Proton in Python: Clearpath's protobuf protocol for MCU <-> PC links, byte for byte with Proton's
own C libraries, in protocol 2.0 and in 1.0 (the one Proton's documentation describes).

- Configurations: ``load_config``/``parse_config`` read Proton's YAML into ``Config`` records.
  They read it as Proton's generator reads it.
  A mistake is a ``ProtonConfigError`` naming the file, line and key.
- Bundles: ``BundleCodec(config, version)`` encodes a bundle's values.
  It decodes a message to a ``Bundle``, with every ``UnknownField`` it skipped.
- A node: ``Node`` is sans-IO, with an injected clock.
  It holds the registry, says what is due (``Sent``) and applies what arrives.
  It counts heartbeats and watches its peers (as ``erc_codec.runtime.Liveness``).
- Links: ``open_proton_udp`` and ``run_proton_serial`` use asyncio, loaded only inside a loop.
  ``split_udp_header`` reads a 2.0 sender's UDP header.

Mistakes, one kind each:
- a configuration that cannot be used is a ``ProtonConfigError``;
- a name the configuration (or a node's part in it) does not have is a ``KeyError``;
- a value that cannot be sent is an ``EncodeError``;
- a message that cannot be read is a ``DecodeError``;
- any other bad argument (a version, a clock reading, a tick) is a ``ValueError``.

Reading a configuration needs the ``proton`` extra (pyyaml); nothing else here does.
"""

from ._codec import Bundle, BundleCodec, UnknownField
from ._config import (
    BundleConfig,
    Config,
    ConnectionConfig,
    EndpointConfig,
    EndpointType,
    NodeConfig,
    ProtonConfigError,
    SignalConfig,
    load_config,
    parse_config,
)
from ._node import Node, Sent
from ._transport import LinkStats, ProtonUdp, open_proton_udp, run_proton_serial
from ._types import SignalType, Value, Version
from ._udp_header import UdpHeader, split_udp_header

__all__ = [
    "Bundle",
    "BundleCodec",
    "BundleConfig",
    "Config",
    "ConnectionConfig",
    "EndpointConfig",
    "EndpointType",
    "LinkStats",
    "Node",
    "NodeConfig",
    "ProtonConfigError",
    "ProtonUdp",
    "Sent",
    "SignalConfig",
    "SignalType",
    "UdpHeader",
    "UnknownField",
    "Value",
    "Version",
    "load_config",
    "open_proton_udp",
    "parse_config",
    "run_proton_serial",
    "split_udp_header",
]
