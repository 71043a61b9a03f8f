"""The traps a new user of erc-codec's command line fell into, each shut: nothing is decoded that
was not given, standard input is hex lines unless --raw says otherwise, every failure is one line
with its documented exit status, a serial stream's rejected frames are reported, a capture is
filtered by port and kind, and output that goes away ends a command quietly."""

import contextlib
import json
import os
import socket
import subprocess
import sys
import threading
import time
import tracemalloc
from pathlib import Path
from typing import IO

import pytest
from cli_support import ETHERNET, records, run, udp4, write_capture

import erc_codec
from erc_codec.cli._input import LINE_LIMIT, hex_lines


@pytest.mark.parametrize("stdin", [b"", b"\n", b"  \n\t\n", b"\r\n"])
def test_empty_input_and_whitespace_are_no_datagram(stdin: bytes) -> None:
    """``echo | erc-codec decode`` printed a ph_info message: 0x0a is a valid tag."""
    done = run("decode", stdin=stdin)
    assert (done.code, done.out) == (1, "")
    assert done.err == "standard input holds no datagram: it is empty or only whitespace\n"


@pytest.mark.parametrize("hex_text", ["", ":::", " ", "::  :"])
def test_hex_that_spells_no_bytes_is_a_usage_error(hex_text: str) -> None:
    done = run("decode", hex_text)
    assert (done.code, done.out) == (2, "")
    assert done.err == "Error: Invalid value for HEX: it spells no bytes: give a datagram in hex\n"


def test_odd_hex_on_stdin_is_not_raw_bytes() -> None:
    """``echo 620b0 | erc-codec decode`` decoded the six bytes of text as a raw datagram."""
    done = run("decode", stdin=b"620b0\n")
    assert done.code == 1
    assert records(done.out) == [
        {
            "error": "line 1 is not hex: odd number of hex digits (5)",
            "reason": "not_hex",
            "length": None,
            "line": 1,
        }
    ]
    assert done.err == "1 line not hex (raw bytes on standard input need --raw)\n"


def test_a_line_longer_than_the_limit_is_an_error_naming_it() -> None:
    """A 100 MB hex line made decode crawl; a line past LINE_LIMIT is skipped, named."""
    at_limit = "0a" + "00" * (LINE_LIMIT // 2 - 1)  # the longest line still read
    over = "0a" * (LINE_LIMIT // 2 + 1)
    stdin = f"0a00\n{over}\n{at_limit}\n0a00\n{over}".encode()  # the last with no newline
    done = run("decode", stdin=stdin)
    assert done.code == 1
    got = records(done.out)
    assert [r.get("reason", r.get("kind")) for r in got] == [
        "ph_info",
        "line_too_long",
        got[2].get("reason"),  # at the limit: read, and judged as a datagram
        "ph_info",
        "line_too_long",
    ]
    assert got[2].get("reason") not in ("line_too_long", "not_hex")
    assert got[1] == {
        "error": f"line 2 is longer than {LINE_LIMIT} characters: no datagram's hex is (a "
        "datagram is at most 65535 bytes)",
        "reason": "line_too_long",
        "length": None,
        "line": 2,
    }
    assert got[4]["line"] == 5
    assert done.err.endswith(f"2 lines longer than {LINE_LIMIT} characters skipped\n")
    assert done.err.count("\n") == 1


def test_the_largest_datagram_spelled_with_separators_is_within_the_limit() -> None:
    assert len(":".join(["ff"] * 65535)) <= LINE_LIMIT


def test_a_long_line_is_not_held_in_memory() -> None:
    """100 MB of hex in 64 KiB chunks, one line: read in bounded memory, reported once."""
    chunk = b"ab" * (1 << 15)
    long_lines: list[int] = []
    tracemalloc.start()
    try:
        chunks = (chunk for _ in range(1600))
        found = list(hex_lines([*[b"0a00\n"], *chunks, b"\n0a00\n"], print, long_lines.append))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert found == [b"\x0a\x00", b"\x0a\x00"]
    assert long_lines == [2]
    assert peak < 4 * LINE_LIMIT


def test_raw_bytes_need_raw(codec: erc_codec.Codec) -> None:
    datagram = codec.encode(codec.message_class("gps_info")(satellites=9, latitude=1.5))
    done = run("decode", stdin=datagram)
    assert done.code == 1
    assert [r["reason"] for r in records(done.out)] == ["not_hex"]
    assert records(done.out)[0]["line"] == 1
    raw = run("decode", "--raw", stdin=datagram)
    assert raw.code == 0, raw.err
    assert records(raw.out)[0]["message"]["satellites"] == 9
    assert run("decode", "--raw", "0a00").code == 2  # --raw is for standard input


def test_framed_reports_rejected_frames_and_exits_1_if_nothing_decoded(
    codec: erc_codec.Codec,
) -> None:
    """A bad CRC printed nothing and exited 0."""
    good = erc_codec.runtime.frame(codec.encode(codec.message_class("gps_info")(satellites=3)))
    bad = good[:-1] + bytes([good[-1] ^ 0xFF])
    done = run("decode", "--framed", bad.hex())
    assert (done.code, done.out) == (1, "")
    assert "0 frames, 0 undecodable, 1 frame rejected (bad_crc 1)" in done.err
    assert done.err.count("\n") == 1
    both = run("decode", "--framed", (bad + good).hex())
    assert both.code == 0, both.err
    assert [r["kind"] for r in records(both.out)] == ["gps_info"]
    assert "1 frame, 0 undecodable, 1 frame rejected (bad_crc 1)" in both.err


def test_pcap_port_and_kind_filters(codec: erc_codec.Codec, tmp_path: Path) -> None:
    """mDNS and RTPS packets on other ports became error lines, or a bogus rover message."""
    gps = codec.encode(codec.message_class("gps_info")(satellites=4))
    ph = codec.encode(codec.message_class("ph_info")(ph_value=7.0))
    capture = tmp_path / "mixed.pcap"
    packets = [
        udp4(gps, 5005, 6006),
        udp4(b"\x00\x00\x84\x00", 5353, 5353),  # mDNS
        udp4(b"RTPS\x02\x03", 7400, 7401),  # ROS 2 discovery
        udp4(ph, 6006, 5005),
    ]
    write_capture(capture, "pcap", ETHERNET, packets)
    done = run("decode", "--pcap", str(capture), "--port", "6006")
    assert done.code == 0, done.err
    assert [r["kind"] for r in records(done.out)] == ["gps_info", "ph_info"]
    assert done.err == "2 datagrams, 0 undecodable, 2 packets skipped (2 other port)\n"
    repeated = run("decode", "--pcap", str(capture), "--port", "5353", "--port", "6006")
    assert [r.get("kind", r.get("reason")) for r in records(repeated.out)] == [
        "gps_info",
        "corrupt",
        "ph_info",
    ]
    kinds = run("decode", "--pcap", str(capture), "--port", "6006", "--kind", "ph_info")
    assert [r["kind"] for r in records(kinds.out)] == ["ph_info"]
    assert kinds.err == (
        "2 datagrams, 0 undecodable, 1 datagram of other kinds not shown, "
        "2 packets skipped (2 other port)\n"
    )
    unknown = run("decode", "--pcap", str(capture), "--kind", "nope")
    assert unknown.code == 2
    assert unknown.err.startswith("Error: unknown kind 'nope': PBEnvelope")
    assert run("decode", "--port", "5", "00").code == 2  # --port is for a capture


def test_kind_counts_what_it_leaves_out(codec: erc_codec.Codec) -> None:
    """--kind dropped the other datagrams and counted them nowhere."""
    gps = codec.encode(codec.message_class("gps_info")(satellites=4))
    ph = codec.encode(codec.message_class("ph_info")(ph_value=7.0))
    lines = run(
        "decode", "--kind", "ph_info", stdin=f"{gps.hex()}\n{ph.hex()}\n{gps.hex()}\n".encode()
    )
    assert lines.code == 0, lines.err
    assert [r["kind"] for r in records(lines.out)] == ["ph_info"]
    assert lines.err == "2 datagrams of other kinds not shown\n"
    framed = (erc_codec.runtime.frame(gps) + erc_codec.runtime.frame(ph)).hex()
    stream = run("decode", "--framed", "--kind", "ph_info", framed)
    assert [r["kind"] for r in records(stream.out)] == ["ph_info"]
    assert stream.err == "2 frames, 0 undecodable, 1 datagram of other kinds not shown\n"
    assert run("decode", "--kind", "gps_info", gps.hex()).err == ""  # nothing left out


def test_decode_into_a_closed_pipe_ends_quietly() -> None:
    """``erc-codec decode ... | head -1``: exit 1, nothing on stderr, no traceback."""
    decoder = subprocess.Popen(
        [sys.executable, "-m", "erc_codec", "decode"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert decoder.stdout is not None
    assert decoder.stdin is not None
    writer = threading.Thread(target=_feed, args=(decoder.stdin, b"0a00\n" * 200_000))
    writer.start()
    assert json.loads(decoder.stdout.readline())["kind"] == "ph_info"
    decoder.stdout.close()
    assert decoder.wait(timeout=60) == 1
    writer.join()
    assert decoder.stderr is not None
    assert decoder.stderr.read() == b""
    decoder.stderr.close()


def _feed(stream: IO[bytes], data: bytes) -> None:
    with contextlib.suppress(BrokenPipeError):  # it ended before reading everything: as it should
        stream.write(data)
    with contextlib.suppress(BrokenPipeError):
        stream.close()


def test_listen_into_a_closed_pipe_ends_quietly(codec: erc_codec.Codec) -> None:
    listener = subprocess.Popen(
        [sys.executable, "-m", "erc_codec", "listen", "0", "--format", "json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert listener.stdout is not None
    assert listener.stderr is not None
    address = listener.stderr.readline().decode().split()[-1]
    port = int(address.rpartition(":")[2])
    datagram = codec.encode(codec.message_class("gps_info")(satellites=1))
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sender:
        sender.sendto(datagram, ("127.0.0.1", port))
        assert json.loads(listener.stdout.readline())["kind"] == "gps_info"
        listener.stdout.close()
        deadline = time.monotonic() + 30
        while listener.poll() is None and time.monotonic() < deadline:
            sender.sendto(datagram, ("127.0.0.1", port))
            time.sleep(0.01)
    assert listener.wait(timeout=30) == 1
    assert b"Traceback" not in listener.stderr.read()
    listener.stderr.close()


def test_protobufs_pure_python_runtime_is_refused_in_one_line() -> None:
    # What a process that imported nanopb's generator hands to the processes it starts.
    environment = {**os.environ, "PROTOCOL_BUFFERS_PYTHON_IMPLEMENTATION": "python"}
    done = subprocess.run(
        [sys.executable, "-m", "erc_codec", "decode", "62026805"],
        capture_output=True,
        text=True,
        env=environment,
        check=False,
    )
    assert (done.returncode, done.stdout) == (2, "")
    assert done.stderr.count("\n") == 1
    assert "PROTOCOL_BUFFERS_PYTHON_IMPLEMENTATION=python" in done.stderr
    assert "needs its compiled one (upb)" in done.stderr
