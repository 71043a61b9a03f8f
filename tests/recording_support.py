"""What the recording tests share: captures they write, and the tools they need.

Imported as conftest is (``from recording_support import write_pcap``); it holds no tests.
Captures are classic pcap (Ethernet, IPv4, UDP), or pcapng built block by block (``section``,
``interface``, ``enhanced``, ``simple``), written with struct byte by byte, so a test of the
capture readers does not lean on one of them to make its input. ``need`` imports a library of
the test extra (or finds a program CI installs): without it a test skips and says why, except
under ERC_REQUIRE_INTEROP=1 (CI), where it fails.
"""

import importlib
import os
import shutil
import struct
from collections.abc import Iterable
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

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


def block(kind: int, body: bytes, order: str = "<") -> bytes:
    """A pcapng block: its type, its total length, the body padded to 32 bits, the length again."""
    body += bytes(-len(body) % 4)
    length = struct.pack(order + "I", 12 + len(body))
    return struct.pack(order + "I", kind) + length + body + length


def section(order: str = "<") -> bytes:
    """A Section Header Block: byte-order magic, version 1.0, section length unknown."""
    return block(0x0A0D0D0A, struct.pack(order + "IHHq", 0x1A2B3C4D, 1, 0, -1), order)


def interface(
    linktype: int, snaplen: int = 0, options: tuple[tuple[int, bytes], ...] = (), order: str = "<"
) -> bytes:
    """An Interface Description Block, with ``options`` (code, value) and their end."""
    body = struct.pack(order + "HHI", linktype, 0, snaplen)
    for code, value in [*options, (0, b"")]:
        body += struct.pack(order + "HH", code, len(value)) + value + bytes(-len(value) % 4)
    return block(1, body, order)


def enhanced(number: int, ticks: int, packet: bytes, order: str = "<") -> bytes:
    """An Enhanced Packet Block of interface ``number``, its time in the interface's units."""
    head = struct.pack(order + "IIIII", number, ticks >> 32, ticks & 0xFFFFFFFF, *[len(packet)] * 2)
    return block(6, head + packet, order)


def simple(packet: bytes, original: int | None = None, order: str = "<") -> bytes:
    """A Simple Packet Block: the packet's original length, then the bytes captured."""
    return block(3, struct.pack(order + "I", original or len(packet)) + packet, order)


def _missing(reason: str) -> None:
    if os.environ.get("ERC_REQUIRE_INTEROP") == "1":
        pytest.fail(f"ERC_REQUIRE_INTEROP=1 but {reason}")
    pytest.skip(reason)


def need(module: str) -> ModuleType:
    """Import ``module`` (of the test extra), or skip (fail under ERC_REQUIRE_INTEROP=1)."""
    try:
        return importlib.import_module(module)
    except ImportError:
        _missing(f"{module} is not installed (pip install -e '.[test]')")
        raise  # not reached: skip and fail raise


def need_program(name: str, install: str) -> str:
    """The path of program ``name``, or skip (fail under ERC_REQUIRE_INTEROP=1)."""
    found = shutil.which(name)
    if found is None:
        _missing(f"{name} is not installed ({install})")
        raise AssertionError("not reached")
    return found


def read_back(path: Path) -> list[Any]:
    """Every message, decoded from the file's own schemas, CRCs checked by both readers."""
    reader = need("mcap.reader")
    factory = need("mcap_protobuf.decoder").DecoderFactory
    with path.open("rb") as file:
        seeking = reader.make_reader(file, validate_crcs=True, decoder_factories=[factory()])
        assert type(seeking).__name__ == "SeekingReader"
        messages = list(seeking.iter_decoded_messages(log_time_order=False))
    with path.open("rb") as file:  # the data section's CRC, in DataEnd, only this one reads
        streaming = reader.NonSeekingReader(file, validate_crcs=True, decoder_factories=[factory()])
        again = list(streaming.iter_decoded_messages())
    assert [(m.channel.topic, m.message.data) for m in again] == [
        (m.channel.topic, m.message.data) for m in messages
    ]
    return messages


def metadata(path: Path) -> dict[str, dict[str, str]]:
    reader = need("mcap.reader")
    with path.open("rb") as file:
        return {m.name: dict(m.metadata) for m in reader.make_reader(file).iter_metadata()}
