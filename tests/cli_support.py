"""What the command-line tests share: running ``erc-codec`` as a user would (a subprocess), and
building the packets and captures its capture readers are given."""

import json
import struct
import subprocess
import sys
from pathlib import Path
from typing import Any, NamedTuple

from recording_support import need

__all__ = [
    "ETHERNET",
    "LINUX_SLL",
    "Done",
    "ipv4",
    "link",
    "one_line_error",
    "records",
    "run",
    "run_many",
    "tcp4",
    "udp4",
    "udp6",
    "write_capture",
]


class Done(NamedTuple):
    code: int
    out: str
    err: str


def run(*args: str, stdin: bytes = b"") -> Done:
    done = subprocess.run(
        [sys.executable, "-m", "erc_codec", *args], input=stdin, capture_output=True, check=False
    )
    return Done(done.returncode, done.stdout.decode(), done.stderr.decode())


def run_many(*commands: list[str]) -> list[Done]:
    """``run`` for several commands at once, in parallel (each loads the schema: 0.3 s)."""
    started = [
        subprocess.Popen(
            [sys.executable, "-m", "erc_codec", *args],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
        )
        for args in commands
    ]
    done = []
    for process in started:
        out, err = process.communicate()
        done.append(Done(process.returncode, out.decode(), err.decode()))
    return done


def records(out: str) -> list[dict[str, Any]]:
    return [json.loads(line) for line in out.splitlines()]


def one_line_error(done: Done, code: int) -> str:
    assert done.code == code, done
    assert done.out == ""
    assert done.err.count("\n") == 1, done.err
    assert "Traceback" not in done.err
    return done.err


ETHERNET, LINUX_SLL = 1, 113


def udp4(
    payload: bytes,
    sport: int = 5005,
    dport: int = 6006,
    source: bytes = bytes([192, 168, 1, 20]),
    destination: bytes = bytes([192, 168, 1, 2]),
) -> bytes:
    udp = struct.pack("!HHHH", sport, dport, 8 + len(payload), 0) + payload
    return ipv4(17, udp, source, destination)


def ipv4(
    protocol: int,
    body: bytes,
    source: bytes = bytes([192, 168, 1, 20]),
    destination: bytes = bytes([192, 168, 1, 2]),
    flags_offset: int = 0x4000,  # don't fragment
) -> bytes:
    header = struct.pack(
        "!BBHHHBBH4s4s",
        0x45,
        0,
        20 + len(body),
        1,
        flags_offset,
        64,
        protocol,
        0,
        source,
        destination,
    )
    words = struct.unpack("!10H", header)
    total = sum(words)
    total = (total & 0xFFFF) + (total >> 16)
    total = (total & 0xFFFF) + (total >> 16)
    return header[:10] + struct.pack("!H", ~total & 0xFFFF) + header[12:] + body


def udp6(
    payload: bytes,
    source: bytes = bytes.fromhex("fd000000000000000000000000000001"),
    target: bytes = bytes.fromhex("fd000000000000000000000000000002"),
) -> bytes:
    udp = struct.pack("!HHHH", 7007, 8008, 8 + len(payload), 0) + payload
    return struct.pack("!IHBB16s16s", 6 << 28, len(udp), 17, 64, source, target) + udp


def tcp4(payload: bytes) -> bytes:
    tcp = struct.pack("!HHIIBBHHH", 40000, 6006, 1, 0, 5 << 4, 0x18, 1024, 0, 0) + payload
    return ipv4(6, tcp)


def link(linktype: int, packet: bytes) -> bytes:
    kind = b"\x86\xdd" if packet[0] >> 4 == 6 else b"\x08\x00"
    if linktype == ETHERNET:
        return bytes.fromhex("020000000002") + bytes.fromhex("020000000001") + kind + packet
    # Linux cooked: packet type, ARPHRD_ETHER, address length, address (8 bytes), protocol
    return struct.pack("!HHH8s", 0, 1, 6, bytes.fromhex("0200000000010000")) + kind + packet


def write_capture(path: Path, form: str, linktype: int, packets: list[bytes]) -> None:
    dpkt = need("dpkt")
    with path.open("wb") as file:
        module = dpkt.pcap if form == "pcap" else dpkt.pcapng
        writer = module.Writer(file, linktype=linktype)
        for number, packet in enumerate(packets):
            writer.writepkt(link(linktype, packet), ts=1_700_000_000 + number / 4)
