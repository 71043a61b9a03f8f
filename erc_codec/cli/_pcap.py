"""The UDP datagrams of a pcap or pcapng capture, read with dpkt (the ``pcap`` extra).

Guarantees: every packet is either handed on as a whole UDP datagram or counted as skipped, by
reason (``not UDP``, ``fragmented``, ``malformed``, ``cut short by the capture``); a capture cut
off or damaged after its header is noticed (``damage``) instead of ending as if it were whole.
"""

import importlib
import ipaddress
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType
from typing import Any, BinaryIO, NamedTuple

from ._shared import Fatal

__all__ = ["Capture", "CapturedDatagram"]

# Link types (tcpdump.org/linktypes.html) whose packets are read.
_ETHERNET, _LINUX_SLL, _LINUX_SLL2 = 1, 113, 276
_RAW_IP = {101, 228, 229}  # LINKTYPE_RAW, LINKTYPE_IPV4, LINKTYPE_IPV6
_LOOPBACK = {0, 108}  # LINKTYPE_NULL, LINKTYPE_LOOP: a 4-byte address family, then IP
_LINK_TYPES = {_ETHERNET, _LINUX_SLL, _LINUX_SLL2, *_RAW_IP, *_LOOPBACK}
_IPV6_FRAGMENT = 44
# Addresses shown, kept for the next datagram between the same two: formatting one with ipaddress
# costs about a quarter of reading a datagram, and a capture has a handful of senders
# (benchmarks/bench_record.py: a capture to MCAP >= 0.7x the bare libraries). Bounded: a capture
# of a flood of senders starts over when it is full.
_KNOWN_ENDPOINTS = 4096


class CapturedDatagram(NamedTuple):
    """One UDP payload of a capture, with when and between whom it travelled."""

    time: float  # capture time, seconds since the epoch
    source: str  # address:port ([address]:port for IPv6)
    destination: str
    data: bytes


class _Watched:
    """A capture file that notes reads stopping short inside it. dpkt hands a pcap record cut
    off by the end of the file over as a shorter (or empty) packet, without a word, and ends a
    pcapng capture quietly when a block's first 8 bytes are cut, or when a block cut short holds
    no packet. The end of the file is whole only where a read of a new record or block finds no
    byte at all, so: a read that returns some bytes but fewer than asked is a cut; a read that
    returns none is one too, if another read follows it or a packet comes out after it
    (``short``); and dpkt asks for everything left (a negative size) only when a block's length
    is shorter than its own header, which is damage as well."""

    def __init__(self, file: BinaryIO) -> None:
        self._file = file
        self.cut = False
        self.short = False

    def read(self, size: int = -1) -> bytes:
        self.cut = self.cut or self.short or size < 0
        data = self._file.read(size)
        self.short = len(data) < size
        self.cut = self.cut or (self.short and len(data) > 0)
        return data

    def seek(self, offset: int, whence: int = 0) -> int:
        self.cut = self.short = False  # dpkt rereads from the top when a capture is not pcap
        return self._file.seek(offset, whence)

    def tell(self) -> int:
        return self._file.tell()

    def close(self) -> None:
        self._file.close()


class Capture:
    """An open capture: ``datagrams()`` yields its UDP payloads; ``skipped`` counts the other
    packets by reason and ``damage`` says, once the datagrams are read, where it broke off."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._dpkt = _dpkt()
        try:
            self._file = _Watched(path.open("rb"))
        except OSError as error:
            raise Fatal(f"cannot read {path}: {error.strerror or error}") from None
        try:
            self._reader = self._dpkt.pcap.UniversalReader(self._file)
            self._linktype = self._reader.datalink()
        except Exception:  # dpkt raises ValueError, its own errors or struct.error on a bad header
            self._file.close()
            raise Fatal(f"{path} is not a pcap or pcapng capture") from None
        if self._linktype not in _LINK_TYPES:
            self._file.close()
            raise Fatal(
                f"{path}: link type {self._linktype} is not supported (Ethernet, Linux cooked "
                "(SLL, SLL2), raw IP and loopback are)"
            )
        self.packets = 0
        self.skipped: dict[str, int] = {}
        self._endpoints: dict[tuple[bytes, int], str] = {}
        self.damage = ""

    def __enter__(self) -> "Capture":
        return self

    def __exit__(self, *exc: object) -> None:
        self._file.close()

    def datagrams(self) -> Iterator[CapturedDatagram]:
        """Every whole UDP datagram, in capture order, up to the end or to the damage."""
        packets = iter(self._reader)
        endpoints = self._endpoints
        while True:
            try:
                timestamp, packet = next(packets)
            except StopIteration:
                if self._file.cut:
                    self.damage = f"{self.path} is cut off after packet {self.packets}"
                return
            except Exception as error:  # dpkt raises its own errors, ValueError or struct.error
                self.damage = (
                    f"{self.path} is damaged after packet {self.packets}: "
                    f"{type(error).__name__} {error}"
                )
                return
            if self._file.cut or self._file.short:
                self.damage = f"{self.path} is cut off inside packet {self.packets + 1}"
                return
            self.packets += 1
            why, ip, udp = self._udp(packet)
            if why:
                self.skipped[why] = self.skipped.get(why, 0) + 1
                continue
            source, destination = (ip.src, udp.sport), (ip.dst, udp.dport)
            if source not in endpoints or destination not in endpoints:
                if len(endpoints) >= _KNOWN_ENDPOINTS:
                    endpoints.clear()
                endpoints[source] = _endpoint(*source)
                endpoints[destination] = _endpoint(*destination)
            yield CapturedDatagram(
                float(timestamp),
                endpoints[source],
                endpoints[destination],
                bytes(udp.data[: udp.ulen - 8]),
            )

    def _udp(self, packet: bytes) -> tuple[str, Any, Any]:
        """``("", ip, udp)`` for a whole UDP datagram, else ``(why it is skipped, None, None)``."""
        dpkt, linktype = self._dpkt, self._linktype
        try:
            if linktype == _ETHERNET:
                ip = dpkt.ethernet.Ethernet(packet).data
            elif linktype == _LINUX_SLL:
                ip = dpkt.sll.SLL(packet).data
            elif linktype == _LINUX_SLL2:
                ip = dpkt.sll2.SLL2(packet).data
            else:
                raw = packet[4:] if linktype in _LOOPBACK else packet
                version = raw[0] >> 4 if raw else 0
                ip = (
                    dpkt.ip.IP(raw) if version == 4 else dpkt.ip6.IP6(raw) if version == 6 else None
                )
        except Exception:  # dpkt raises assorted errors on a packet too short for its headers
            return "malformed", None, None
        if isinstance(ip, dpkt.ip.IP):
            if ip.mf or ip.offset:
                return "fragmented", None, None
        elif isinstance(ip, dpkt.ip6.IP6):
            fragment = ip.extension_hdrs.get(_IPV6_FRAGMENT)
            if fragment is not None and (fragment.frag_off or fragment.m_flag):
                return "fragmented", None, None
        else:
            return "not UDP", None, None
        udp = ip.data
        if not isinstance(udp, dpkt.udp.UDP):
            return "not UDP", None, None
        if udp.ulen < 8:
            return "malformed", None, None
        if len(udp.data) < udp.ulen - 8:
            return "cut short by the capture", None, None
        return "", ip, udp


def _dpkt() -> ModuleType:
    try:
        return importlib.import_module("dpkt")
    except ImportError:
        raise Fatal("--pcap needs the dpkt package: pip install 'erc-codec[pcap]'") from None


def _endpoint(address: bytes, port: int) -> str:
    host = ipaddress.ip_address(address)
    return f"[{host}]:{port}" if host.version == 6 else f"{host}:{port}"
