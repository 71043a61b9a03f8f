"""The UDP datagrams of a pcap or pcapng capture: pcap read with dpkt (the ``pcap`` extra),
pcapng block by block here (dpkt's reader knows a capture's first interface only).

Guarantees: every packet is either handed on as a whole UDP datagram or counted as skipped, by
reason (``not UDP``, ``fragmented``, ``malformed``, ``cut short by the capture``, ``link type N
not supported`` for a pcapng interface of a link type not read, ``no such interface`` for a
pcapng packet naming an interface its section does not describe, ``other port`` when only some
ports are asked for); a capture cut off or damaged after its header is noticed (``damage``)
instead of ending as if it were whole. A pcapng packet is read with its own interface's link
type, time resolution (``if_tsresol``) and offset (``if_tsoffset``); a Simple Packet Block is
interface 0's, cut to its snapshot length, and carries no time: its datagram's ``time`` is
``None``.
"""

import importlib
import ipaddress
import struct
from collections.abc import Iterator
from itertools import repeat
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
# pcapng (IETF draft-ietf-opsawg-pcapng): block types, the section's byte-order magic as little-
# and big-endian bytes, and the interface options read.
_PCAPNG_MAGIC = b"\x0a\x0d\x0d\x0a"
_SHB, _IDB, _PB, _SPB, _EPB = 0x0A0D0D0A, 1, 2, 3, 6
_PACKET_BLOCKS = frozenset({_PB, _SPB, _EPB})
_BYTE_ORDERS = {b"\x4d\x3c\x2b\x1a": "<", b"\x1a\x2b\x3c\x4d": ">"}
_END_OF_OPTIONS, _IF_TSRESOL, _IF_TSOFFSET = 0, 9, 14
# Addresses shown, kept for the next datagram between the same two: formatting one with ipaddress
# costs about a quarter of reading a datagram, and a capture has a handful of senders
# (benchmarks/bench_record.py: a capture to MCAP >= 0.7x the bare libraries). Bounded: a capture
# of a flood of senders starts over when it is full.
_KNOWN_ENDPOINTS = 4096
# A CapturedDatagram built without NamedTuple's Python-level __new__ (bench_record, as above);
# tests/cli/test_cli_codec.py reads every field back from the datagrams of a capture.
_datagram = tuple.__new__


class CapturedDatagram(NamedTuple):
    """One UDP payload of a capture, with when and between whom it travelled."""

    time: float | None  # capture time, seconds since the epoch; None: a Simple Packet Block's
    source: str  # address:port ([address]:port for IPv6)
    destination: str
    data: bytes


class _Watched:
    """A capture file that notes reads stopping short inside it, for dpkt's pcap reader, which
    hands a record cut off by the end of the file over as a shorter (or empty) packet, without a
    word (the pcapng reader here says where a block is cut itself). The end of the file is whole
    only where a read of a new record finds no byte at all, so: a read that returns some bytes
    but fewer than asked is a cut; a read that returns none is one too, if another read follows
    it or a packet comes out after it (``short``); and a read of everything left (a negative
    size) is damage as well."""

    def __init__(self, file: BinaryIO) -> None:
        self._file = file
        self.cut = False
        self.short = False

    def read(self, size: int = -1) -> bytes:
        data = self._file.read(size)
        # A whole read after a whole read changes nothing, so only the others set the flags:
        # two reads a packet (benchmarks/bench_record.py: a capture to MCAP >= 0.7x the bare
        # libraries); tests/cli/test_cli_codec.py cuts a capture at every byte.
        if self.short or size < 0 or len(data) < size:
            self.cut = self.cut or self.short or size < 0 or 0 < len(data) < size
            self.short = len(data) < size
        return data

    def seek(self, offset: int, whence: int = 0) -> int:
        self.cut = self.short = False  # dpkt rereads from the top when a capture is not pcap
        return self._file.seek(offset, whence)

    def tell(self) -> int:
        return self._file.tell()

    def peek(self, size: int) -> bytes:
        """The first ``size`` bytes of the file, read again after (the flags untouched)."""
        where = self._file.tell()
        head = self._file.read(size)
        self._file.seek(where)
        return head

    def close(self) -> None:
        self._file.close()


class _Damaged(Exception):
    """Where a pcapng capture breaks off: ``inside`` a packet's block or after the packets
    before it, and ``why`` when it is not simply cut off there."""

    def __init__(self, inside: bool, why: str = "") -> None:
        super().__init__(why)
        self.inside = inside
        self.why = why


class _Interface(NamedTuple):
    """What a pcapng Interface Description Block says of the packets captured on it."""

    link: int | str  # the link type, or why its packets are skipped (one not read)
    snaplen: int  # 0: no limit
    ticks: float  # time units per second (if_tsresol; microseconds unless it says)
    offset: int  # seconds added to every time (if_tsoffset)


# A packet as a capture's reader hands it on: (time, bytes) and the link type to read it with,
# or, for a packet that cannot be read, why it is skipped.
_Packet = tuple[tuple[Any, bytes], int | str]


class _Pcapng:
    """The packets of a pcapng capture, read block by block: ``((time, bytes), link type)``, or
    ``((None, b""), why)`` for a packet skipped (``no such interface``, ``malformed``, ``link
    type N not supported``).

    Each section (a Section Header Block, with its own byte order) describes its interfaces in
    Interface Description Blocks, numbered from 0 in their order; an Enhanced (or the obsolete
    Packet) Block names its interface, whose link type, time resolution and offset read it; a
    Simple Packet Block is interface 0's, its bytes the packet's original length cut to that
    interface's snapshot length, and its time ``None`` (it carries none). Other blocks hold no
    packet and are passed over. A block cut short, or whose lengths do not hold together, raises
    ``_Damaged``; so does a capture that ends without describing any interface.
    """

    def __init__(self, file: "_Watched") -> None:
        """Read the first section's header; a ValueError if the file does not start with one."""
        self._read = file.read
        self._interfaces: list[_Interface] = []
        self._described = False
        head = self._read(8)
        if len(head) < 8 or head[:4] != _PCAPNG_MAGIC:
            raise ValueError("no pcapng section header")
        try:
            self._section(head)
        except _Damaged as damage:
            raise ValueError(damage.why or "its section header is cut off") from None

    def __iter__(self) -> Iterator[_Packet]:
        read = self._read
        while True:
            head = read(8)
            if len(head) < 8:
                if head:  # a block's first bytes only
                    raise _Damaged(False)
                if not self._described:
                    raise _Damaged(False, "no interface is described before its end")
                return
            if head[:4] == _PCAPNG_MAGIC:
                self._section(head)
                continue
            kind, length = struct.unpack(self._order + "II", head)
            body = self._body(kind, length)
            if kind in _PACKET_BLOCKS:
                yield self._packet(kind, body)
            elif kind == _IDB:
                self._interfaces.append(self._interface(body))
                self._described = True

    def _section(self, head: bytes) -> None:
        """A Section Header Block, its first 8 bytes read: the byte order it sets, its version;
        the interfaces of the section before it are gone."""
        magic = self._read(4)
        if len(magic) < 4:
            raise _Damaged(False)
        order = _BYTE_ORDERS.get(magic)
        if order is None:
            raise _Damaged(False, f"a section header's byte-order magic is {magic.hex()}")
        self._order = order
        (length,) = struct.unpack(order + "I", head[4:])
        if length < 28:  # the block's lengths, type, magic, version and section length
            raise _Damaged(False, f"a section header of {length} bytes is too short")
        body = magic + self._body(_SHB, length, 4)
        major, minor = struct.unpack_from(order + "HH", body, 4)
        if major != 1:
            raise _Damaged(False, f"pcapng version {major}.{minor} is not read (1.x is)")
        self._interfaces = []

    def _body(self, kind: int, length: int, read: int = 0) -> bytes:
        """A block's body (between its length and the copy of its length at its end), ``read``
        bytes of it already read."""
        if length < 12 or length % 4:
            raise _Damaged(False, f"a block of type {kind} says it is {length} bytes long")
        rest = self._read(length - 8 - read)
        if len(rest) < length - 8 - read:
            raise _Damaged(kind in _PACKET_BLOCKS)
        (trailer,) = struct.unpack(self._order + "I", rest[-4:])
        if trailer != length:
            raise _Damaged(False, f"a block of type {kind} ends in length {trailer}, not {length}")
        return rest[:-4]

    def _packet(self, kind: int, body: bytes) -> _Packet:
        """A packet block's time and bytes, and its interface's link type (or why it is
        skipped)."""
        order, interfaces = self._order, self._interfaces
        if kind == _SPB:
            if not interfaces:
                return (None, b""), "no such interface"
            (original,) = struct.unpack_from(order + "I", body) if len(body) >= 4 else (-1,)
            snaplen = interfaces[0].snaplen
            captured = min(original, snaplen) if snaplen else original
            if not 0 <= captured <= len(body) - 4:
                return (None, b""), "malformed"
            return (None, body[4 : 4 + captured]), interfaces[0].link
        if len(body) < 20:
            return (None, b""), "malformed"
        if kind == _EPB:
            number, high, low, captured, _ = struct.unpack_from(order + "IIIII", body)
        else:  # the obsolete Packet Block: a 16-bit interface, then a drop count
            number, _, high, low, captured, _ = struct.unpack_from(order + "HHIIII", body)
        if number >= len(interfaces):
            return (None, b""), "no such interface"
        if captured > len(body) - 20:
            return (None, b""), "malformed"
        interface = interfaces[number]
        time = interface.offset + ((high << 32) | low) / interface.ticks
        return (time, body[20 : 20 + captured]), interface.link

    def _interface(self, body: bytes) -> _Interface:
        """An Interface Description Block's link type, snapshot length and time options."""
        order = self._order
        if len(body) < 8:
            raise _Damaged(False, "an interface description block is too short for its fields")
        linktype, _, snaplen = struct.unpack_from(order + "HHI", body)
        ticks, offset, at = 1e6, 0, 8
        while at + 4 <= len(body):
            code, size = struct.unpack_from(order + "HH", body, at)
            value = body[at + 4 : at + 4 + size]
            if code == _END_OF_OPTIONS:
                break
            if len(value) < size:
                raise _Damaged(False, f"interface {len(self._interfaces)}'s options run past it")
            if code == _IF_TSRESOL and size >= 1:
                # The high bit set: a negative power of 2; clear: of 10 (6 is microseconds).
                exponent = value[0] & 0x7F
                ticks = float(2**exponent if value[0] & 0x80 else 10**exponent)
            elif code == _IF_TSOFFSET and size == 8:
                (offset,) = struct.unpack(order + "q", value)
            at += 4 + (size + 3) // 4 * 4
        link = linktype if linktype in _LINK_TYPES else f"link type {linktype} not supported"
        return _Interface(link, snaplen, ticks, offset)


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
        self._packets = self._open(path)
        self.packets = 0
        self.skipped: dict[str, int] = {}
        self._endpoints: dict[tuple[bytes, int, bytes, int], tuple[str, str]] = {}
        self.damage = ""

    def _open(self, path: Path) -> Iterator[_Packet]:
        """The capture's packets, its header read: a pcapng capture's with their interfaces'
        link types, a pcap capture's with the one its header gives (which must be one read)."""
        try:
            if self._file.peek(4) == _PCAPNG_MAGIC:
                return iter(_Pcapng(self._file))
            reader = self._dpkt.pcap.Reader(self._file)
            linktype = reader.datalink()
        except Exception:  # dpkt raises ValueError, its own errors or struct.error on a bad header
            self._file.close()
            raise Fatal(f"{path} is not a pcap or pcapng capture") from None
        if linktype not in _LINK_TYPES:
            self._file.close()
            raise Fatal(
                f"{path}: link type {linktype} is not supported (Ethernet, Linux cooked "
                "(SLL, SLL2), raw IP and loopback are)"
            )
        return zip(reader, repeat(linktype))

    def __enter__(self) -> "Capture":
        return self

    def __exit__(self, *exc: object) -> None:
        self._file.close()

    def datagrams(self) -> Iterator[CapturedDatagram]:
        """Every whole UDP datagram, in capture order, up to the end or to the damage."""
        # Names looked up once, not per packet, and the datagram built as _datagram builds it:
        # benchmarks/bench_record.py (a capture to MCAP >= 0.7x the bare libraries).
        packets, file, udp_of = self._packets, self._file, self._udp
        endpoints, ports, skipped = self._endpoints, self._ports, self.skipped
        while True:
            try:
                (timestamp, packet), link = next(packets)
            except StopIteration:
                if file.cut:
                    self.damage = f"{self.path} is cut off after packet {self.packets}"
                return
            except _Damaged as damage:
                self.damage = self._broken(damage)
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
            why, ip, udp, data = udp_of(packet, link)
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
            at = None if timestamp is None else float(timestamp)  # dpkt: a Decimal for ns
            yield _datagram(CapturedDatagram, (at, shown[0], shown[1], data))

    def _broken(self, damage: _Damaged) -> str:
        """The words for where a pcapng capture broke off."""
        if damage.why:
            return f"{self.path} is damaged after packet {self.packets}: {damage.why}"
        if damage.inside:
            return f"{self.path} is cut off inside packet {self.packets + 1}"
        return f"{self.path} is cut off after packet {self.packets}"

    def _udp(self, packet: bytes, link: int | str) -> tuple[str, Any, Any, bytes]:
        """``("", ip, udp, payload)`` for a whole UDP datagram of a packet of link type ``link``
        (or why the reader skips it), else ``(why it is skipped, None, None, b"")``."""
        try:
            if link == _ETHERNET:
                ip = self._ethernet(packet).data
            elif isinstance(link, str):
                return link, None, None, b""
            else:
                ip = self._network(packet, link)
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

    def _network(self, packet: bytes, linktype: int) -> Any:
        """The network layer of a packet of a link type other than Ethernet, as dpkt reads it
        (``None`` when it is not IP)."""
        dpkt = self._dpkt
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
