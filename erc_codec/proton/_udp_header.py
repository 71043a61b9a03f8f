"""The header Proton 2.0's UDP transport may put before a message, and how a receiver tells.

Facts (``2.0-d269668/core/src/transport/udp4.c``): ``{version, node_id, flags, reserved}``, one
byte each, version 1 (``UDP4_VERSION_2``); a datagram whose first byte is anything else has no
header (Proton 1.0 and header-less 2.0 peers). No message starts with byte 1 (a 2.0 message starts
with its bundle's tag 0x0a, a 1.0 one with 0x08 or 0x12), so the two never mix up.
"""

from typing import NamedTuple

__all__ = ["UdpHeader", "split_udp_header"]

_VERSION = 1
_SIZE = 4


class UdpHeader(NamedTuple):
    """The header's fields, as Proton's ``proton_udp4_fill_header`` writes them: ``node_id`` is
    the sending node's id (0 is a node id like any other: a datagram without a header has no
    ``UdpHeader`` here, where Proton's C core reports node id 0 for it)."""

    version: int
    node_id: int
    flags: int
    reserved: int


def split_udp_header(datagram: bytes) -> tuple[UdpHeader | None, bytes]:
    """The datagram's header (``None`` if it has none) and the message after it."""
    if len(datagram) >= _SIZE and datagram[0] == _VERSION:
        return UdpHeader(*datagram[:_SIZE]), datagram[_SIZE:]
    return None, datagram
