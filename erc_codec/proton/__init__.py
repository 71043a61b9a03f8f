"""Proton in Python: Clearpath's protobuf protocol for MCU <-> PC links (placeholder)."""

from ._codec import Bundle, BundleCodec
from ._config import (
    BundleConfig,
    Config,
    ConnectionConfig,
    EndpointConfig,
    NodeConfig,
    ProtonConfigError,
    SignalConfig,
    load_config,
    parse_config,
)
from ._node import Node, Sent
from ._transport import LinkStats, ProtonUdp, open_proton_udp, run_proton_serial
from ._types import Value, Version
from ._udp_header import UdpHeader, split_udp_header

__all__ = [
    "Bundle",
    "BundleCodec",
    "BundleConfig",
    "Config",
    "ConnectionConfig",
    "EndpointConfig",
    "LinkStats",
    "Node",
    "NodeConfig",
    "ProtonConfigError",
    "ProtonUdp",
    "Sent",
    "SignalConfig",
    "UdpHeader",
    "Value",
    "Version",
    "load_config",
    "open_proton_udp",
    "parse_config",
    "run_proton_serial",
    "split_udp_header",
]
