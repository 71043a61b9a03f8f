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
from ._types import Value, Version

__all__ = [
    "Bundle",
    "BundleCodec",
    "BundleConfig",
    "Config",
    "ConnectionConfig",
    "EndpointConfig",
    "Node",
    "NodeConfig",
    "ProtonConfigError",
    "Sent",
    "SignalConfig",
    "Value",
    "Version",
    "load_config",
    "parse_config",
]
