"""Captures the recording tests (and bench_record.py) write: classic pcap, Ethernet, IPv4, UDP.

Imported as conftest is (``from captures import write_pcap``); it holds no tests. Written with
struct, byte by byte, so a test of the pcap readers does not lean on one of them to make its input.
"""

import struct
from collections.abc import Iterable
from pathlib import Path

_ETHERNET = bytes.fromhex("0200000000020200000000010800")
_PCAP_HEADER = struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 1)  # µs, LINKTYPE_ETHERNET
SOURCE = (192, 168, 0, 20)
DESTINATION = (192, 168, 0, 2)


def _checksum(data: bytes) -> int:
    if len(data) % 2:
        data += b"\0"
    total = int(sum(struct.unpack(f"!{len(data) // 2}H", data)))
    while total >> 16:
        total = (total & 0xFFFF) + (total >> 16)
    return ~total & 0xFFFF


def frame(payload: bytes, sport: int = 40000, dport: int = 5000) -> bytes:
    """An Ethernet frame carrying ``payload`` in one UDP datagram, checksums right."""
    source, destination = bytes(SOURCE), bytes(DESTINATION)
    length = 8 + len(payload)
    pseudo = source + destination + struct.pack("!BBH", 0, 17, length)
    udp = struct.pack("!HHHH", sport, dport, length, 0) + payload
    udp = udp[:6] + struct.pack("!H", _checksum(pseudo + udp) or 0xFFFF) + udp[8:]
    ip = struct.pack(
        "!BBHHHBBH4s4s", 0x45, 0, 20 + length, 1, 0x4000, 64, 17, 0, source, destination
    )
    ip = ip[:10] + struct.pack("!H", _checksum(ip)) + ip[12:]
    return _ETHERNET + ip + udp


def write_pcap(
    path: Path,
    datagrams: Iterable[bytes],
    start: float = 1_700_000_000.0,
    step: float = 0.01,
    dport: int = 5000,
) -> list[float]:
    """A pcap of one UDP datagram per payload, ``step`` seconds apart (microsecond times, as
    pcap keeps them); the capture time of each."""
    times = []
    with path.open("wb") as file:
        file.write(_PCAP_HEADER)
        for number, payload in enumerate(datagrams):
            micros = round(start * 1e6) + round(number * step * 1e6)
            data = frame(payload, dport=dport)
            file.write(struct.pack("<IIII", micros // 10**6, micros % 10**6, len(data), len(data)))
            file.write(data)
            times.append(micros / 1e6)
    return times
