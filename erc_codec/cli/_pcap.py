"""The UDP datagrams of a pcap or pcapng capture, read with dpkt (the ``pcap`` extra).

Guarantees: every packet is either handed on as a whole UDP datagram or counted as skipped, by
reason (``not UDP``, ``fragmented``, ``malformed``, ``cut short by the capture``, ``other port``
when only some ports are asked for); a capture cut
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
# A CapturedDatagram built without NamedTuple's Python-level __new__ (bench_record, as above);
# tests/test_cli_codec.py reads every field back from the datagrams of a capture.
_datagram = tuple.__new__


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
        data = self._file.read(size)
        # A whole read after a whole read changes nothing, so only the others set the flags:
        # two reads a packet (benchmarks/bench_record.py: a capture to MCAP >= 0.7x the bare
        # libraries); tests/test_cli_codec.py cuts a capture at every byte.
        if self.short or size < 0 or len(data) < size:
            self.cut = self.cut or self.short or size < 0 or 0 < len(data) < size
            self.short = len(data) < size
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

    def __init__(self, path: Path, ports: frozenset[int] = frozenset()) -> None:
        """``ports``: if any, only datagrams from or to one of them are handed on (the others
        are skipped as ``other port``)."""
        self.path = path
        self._ports = ports
        self._dpkt = dpkt = _dpkt()
        self._ethernet, self._ipv4, self._ipv6 = dpkt.ethernet.Ethernet, dpkt.ip.IP, dpkt.ip6.IP6
        self._udp_class = dpkt.udp.UDP
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
        self._endpoints: dict[tuple[bytes, int, bytes, int], tuple[str, str]] = {}
        self.damage = ""

    def __enter__(self) -> "Capture":
        return self

    def __exit__(self, *exc: object) -> None:
        self._file.close()

    def datagrams(self) -> Iterator[CapturedDatagram]:
        """Every whole UDP datagram, in capture order, up to the end or to the damage."""
        # Names looked up once, not per packet, and the datagram built as _datagram builds it:
        # benchmarks/bench_record.py (a capture to MCAP >= 0.7x the bare libraries).
        packets, file, udp_of = iter(self._reader), self._file, self._udp
        endpoints, ports, skipped = self._endpoints, self._ports, self.skipped
        while True:
            try:
                timestamp, packet = next(packets)
            except StopIteration:
                if file.cut:
                    self.damage = f"{self.path} is cut off after packet {self.packets}"
                return
            except Exception as error:  # dpkt raises its own errors, ValueError or struct.error
                self.damage = (
                    f"{self.path} is damaged after packet {self.packets}: "
                    f"{type(error).__name__} {error}"
                )
                return
            if file.cut or file.short:
                self.damage = f"{self.path} is cut off inside packet {self.packets + 1}"
                return
            self.packets += 1
            why, ip, udp, data = udp_of(packet)
            if not why and ports and not {udp.sport, udp.dport} & ports:
                why = "other port"
            if why:
                skipped[why] = skipped.get(why, 0) + 1
                continue
            key = (ip.src, udp.sport, ip.dst, udp.dport)
            shown = endpoints.get(key)
            if shown is None:
                if len(endpoints) >= _KNOWN_ENDPOINTS:
                    endpoints.clear()
                shown = endpoints[key] = (
                    _endpoint(ip.src, udp.sport),
                    _endpoint(ip.dst, udp.dport),
                )
            yield _datagram(CapturedDatagram, (float(timestamp), shown[0], shown[1], data))

    def _udp(self, packet: bytes) -> tuple[str, Any, Any, bytes]:
        """``("", ip, udp, payload)`` for a whole UDP datagram, else ``(why it is skipped, None,
        None, b"")``."""
        try:
            if self._linktype == _ETHERNET:
                ip = self._ethernet(packet).data
            else:
                ip = self._network(packet)
        except Exception:  # dpkt raises assorted errors on a packet too short for its headers
            return "malformed", None, None, b""
        if isinstance(ip, self._ipv4):
            if ip.mf or ip.offset:
                return "fragmented", None, None, b""
        elif isinstance(ip, self._ipv6):
            fragment = ip.extension_hdrs.get(_IPV6_FRAGMENT)
            if fragment is not None and (fragment.frag_off or fragment.m_flag):
                return "fragmented", None, None, b""
        else:
            return "not UDP", None, None, b""
        udp = ip.data
        if not isinstance(udp, self._udp_class):
            return "not UDP", None, None, b""
        data, size = udp.data, udp.ulen - 8
        if len(data) != size:
            if size < 0:
                return "malformed", None, None, b""
            if len(data) < size:
                return "cut short by the capture", None, None, b""
            data = data[:size]
        return "", ip, udp, bytes(data)

    def _network(self, packet: bytes) -> Any:
        """The network layer of a packet of a link type other than Ethernet, as dpkt reads it
        (``None`` when it is not IP)."""
        dpkt, linktype = self._dpkt, self._linktype
        if linktype == _LINUX_SLL:
            return dpkt.sll.SLL(packet).data
        if linktype == _LINUX_SLL2:
            return dpkt.sll2.SLL2(packet).data
        raw = packet[4:] if linktype in _LOOPBACK else packet
        version = raw[0] >> 4 if raw else 0
        return self._ipv4(raw) if version == 4 else self._ipv6(raw) if version == 6 else None


def _dpkt() -> ModuleType:
    try:
        return importlib.import_module("dpkt")
    except ImportError:
        raise Fatal("--pcap needs the dpkt package: pip install 'erc-codec[pcap]'") from None


def _endpoint(address: bytes, port: int) -> str:
    host = ipaddress.ip_address(address)
    return f"[{host}]:{port}" if host.version == 6 else f"{host}:{port}"
