"""``erc-codec encode`` and ``erc-codec decode``, run as a user would (a subprocess)."""

import array
import fcntl
import ipaddress
import json
import struct
import subprocess
import sys
import termios
import time
from pathlib import Path
from typing import Any

import pytest
from cli_support import (
    ETHERNET,
    LINUX_SLL,
    Done,
    ipv4,
    link,
    one_line_error,
    records,
    run,
    run_many,
    tcp4,
    udp4,
    udp6,
    write_capture,
)
from conftest import REPO
from google.protobuf import json_format
from recording_support import enhanced, interface, need, section, simple

import erc_codec

PRESENCE = REPO / "tests" / "schema_trees" / "presence"

# (kind, payload JSON): plain scalars, enums and int64 (in proto and camelCase spelling), a
# submessage, and an all-default payload, whose stripped form is its tag alone.
PAYLOADS: list[tuple[str, dict[str, Any]]] = [
    (
        "gps_info",
        {"latitude": 52.2389, "longitude": 6.8566, "satellites": 9, "fixQuality": "DGPS_FIX"},
    ),
    (
        "arm_diag",
        {
            "state": "ARM_BOARD_STATE_OPERATING",
            "base_motor": {"motorId": 3, "rpm": -12.5, "state": "MOTOR_STATE_OPERATING"},
        },
    ),
    ("arm_feedback", {}),
]


def payload(codec: erc_codec.Codec, kind: str, document: dict[str, Any]) -> Any:
    """The payload message that ``document`` spells, built in-process for comparison."""
    envelope = codec.message_class(codec.root)()
    return json_format.ParseDict(document, getattr(envelope, kind))


@pytest.mark.parametrize("mode", ["strip", "exact", "pad"])
def test_encode_then_decode_round_trips(codec: erc_codec.Codec, mode: str) -> None:
    lines = []
    encoded = run_many(*(["encode", k, json.dumps(d), "--mode", mode] for k, d in PAYLOADS))
    for (kind, document), done in zip(PAYLOADS, encoded, strict=True):
        assert done.code == 0, done.err
        expected = codec.encode(payload(codec, kind, document), mode)  # type: ignore[arg-type]
        assert done.out == expected.hex() + "\n"
        lines.append(done.out)
    done = run("decode", stdin="".join(lines).encode())
    assert done.code == 0, done.err
    decoded = records(done.out)
    assert [(r["kind"], r["length"]) for r in decoded] == [
        (kind, len(bytes.fromhex(line))) for (kind, _), line in zip(PAYLOADS, lines, strict=True)
    ]
    for (kind, document), record in zip(PAYLOADS, decoded, strict=True):
        sent = payload(codec, kind, document)
        assert json_format.ParseDict(record["message"], type(sent)()) == sent


def test_decode_shows_every_field_in_proto_order_with_enum_names() -> None:
    done = run("encode", "gps_info", '{"satellites": 9, "latitude": 52.5}')
    record = records(run("decode", done.out.strip()).out)[0]
    message = record["message"]
    assert list(message)[:3] == ["latitude", "longitude", "altitude"]
    assert message["latitude"] == 52.5
    assert message["satellites"] == 9
    assert message["speed"] == 0.0
    assert message["fix_quality"] == "NO_FIX"
    assert message["utc_timestamp"] == "0"


def test_frame_and_framed_round_trip(codec: erc_codec.Codec) -> None:
    frames = []
    encoded = run_many(*(["encode", k, json.dumps(d), "--frame"] for k, d in PAYLOADS))
    for (kind, document), done in zip(PAYLOADS, encoded, strict=True):
        assert done.code == 0, done.err
        datagram = codec.encode(payload(codec, kind, document))
        assert bytes.fromhex(done.out) == erc_codec.runtime.frame(datagram)
        frames.append(bytes.fromhex(done.out))
    stream = b"noise" + frames[0] + frames[1] + b"\x00\x13" + frames[2] + b"PR\x05"
    for done in (
        run("decode", "--framed", "--raw", stdin=stream),  # raw bytes on stdin
        run("decode", "--framed", "-", stdin=stream.hex(" ", 4).encode()),  # hex text on stdin
        *run_many(["decode", "--framed", stream.hex(":")]),  # one hex argument, no stdin
    ):
        assert done.code == 0, done.err
        assert [r["kind"] for r in records(done.out)] == [kind for kind, _ in PAYLOADS]
        assert done.err == (
            "3 frames, 0 undecodable, 7 bytes discarded (garbage 7), "
            "3 bytes left in an unfinished frame\n"
        )


def test_a_framed_payload_that_does_not_decode_is_reported() -> None:
    stream = erc_codec.runtime.frame(bytes.fromhex("b20100")) + erc_codec.runtime.frame(b"\x22")
    done = run("decode", "--framed", "--raw", stdin=stream)
    assert done.code == 1
    first, second = records(done.out)
    assert first["reason"] == "unknown_member"
    assert second["kind"] == "arm_feedback"
    assert done.err == "2 frames, 1 undecodable\n"


def test_hex_with_spaces_or_colons_quoted_or_not() -> None:
    datagram = run("encode", "gps_info", '{"satellites": 9, "hdop": 1.5}').out.strip()
    spaced = bytes.fromhex(datagram).hex(" ")
    expected = run("decode", datagram)
    assert expected.code == 0, expected.err
    assert records(expected.out)[0]["kind"] == "gps_info"
    forms = ([spaced], spaced.split(), [bytes.fromhex(datagram).hex(":")])
    assert run_many(*(["decode", *args] for args in forms)) == [expected] * 3


def test_stdin_hex_lines_go_on_after_a_bad_line() -> None:
    good = run("encode", "gps_info", '{"satellites": 9}').out.strip()
    text = f"{good}\n\n  b2 01 00\nthis is no hex\n0a 1\n22:00\r\n{good}"
    done = run("decode", stdin=text.encode())
    assert done.code == 1
    assert done.err == "2 lines not hex (raw bytes on standard input need --raw)\n"
    lines = records(done.out)
    assert [r.get("kind") or r["reason"] for r in lines] == [
        "gps_info",
        "unknown_member",
        "not_hex",
        "not_hex",
        "arm_feedback",
        "gps_info",
    ]
    assert lines[1]["length"] == 3
    assert (lines[2]["line"], lines[3]["line"]) == (4, 5)
    assert lines[2]["length"] is None
    assert "'t' at column 1 is not a hex digit" in lines[2]["error"]
    assert "odd number of hex digits (3)" in lines[3]["error"]


def test_raw_bytes_on_stdin_are_one_datagram(codec: erc_codec.Codec) -> None:
    gps = codec.message_class("SensorBoardGPSInfo")
    datagram = codec.encode(gps(latitude=-33.5, satellites=12, hdop=0.75), "pad")
    done = run("decode", "-", "--raw", stdin=datagram)
    assert done.code == 0, done.err
    (record,) = records(done.out)
    assert record["kind"] == "gps_info"
    assert record["length"] == 262
    assert record["message"]["latitude"] == -33.5
    assert record["message"]["hdop"] == 0.75


@pytest.mark.parametrize(
    ("data", "reason"),
    [("b20100", "unknown_member"), ("00 00", "no_payload"), ("62 05 08", "corrupt")],
)
def test_an_undecodable_datagram_is_one_json_line_and_exit_1(data: str, reason: str) -> None:
    done = run("decode", data)
    assert done.code == 1
    assert done.err == ""
    (record,) = records(done.out)
    assert record["reason"] == reason
    assert record["length"] == len(bytes.fromhex(data))
    assert set(record) == {"error", "reason", "length"}


@pytest.mark.parametrize(
    ("args", "code", "text"),
    [
        (
            ["gps_info", '{"fix_quality": 9}'],
            1,
            "SensorBoardGPSInfo.fix_quality: 9 is not a declared value: GPSFixQuality takes one "
            "of NO_FIX, GPS_FIX, DGPS_FIX, PPS_FIX, RTK_FIX, RTK_FLOAT",
        ),
        (
            ["gps_info", '{"fix_quality": "FIX_OF_THE_DAY"}'],
            1,
            'SensorBoardGPSInfo.fix_quality: "FIX_OF_THE_DAY" is not one of its names',
        ),
        (
            ["gps_info", '{"altitude_m": 3}'],
            1,
            'SensorBoardGPSInfo: no field named "altitude_m": SensorBoardGPSInfo has latitude, '
            "longitude, altitude, speed,",
        ),
        (
            ["gps_info", '{"satellites": 4294967296}'],
            1,
            "SensorBoardGPSInfo.satellites: 4294967296 is out of range for int32",
        ),
        # Values json_format wraps or takes for another before the undeclared-value check.
        (
            ["gps_info", '{"fix_quality": 1099511627776}'],
            1,
            "SensorBoardGPSInfo.fix_quality: 1099511627776 is not a declared value",
        ),
        (
            ["gps_info", '{"fix_quality": 4294967298}'],
            1,
            "SensorBoardGPSInfo.fix_quality: 4294967298 is not a declared value",
        ),
        (
            ["gps_info", '{"fix_quality": 1.5}'],
            1,
            "SensorBoardGPSInfo.fix_quality: 1.5 is not an integer: GPSFixQuality takes one of",
        ),
        (
            ["gps_info", '{"fix_quality": true}'],
            1,
            "SensorBoardGPSInfo.fix_quality: true is not a name or an integer",
        ),
        (  # an OverflowError traceback, once
            ["gps_info", '{"error_code": Infinity}'],
            1,
            "SensorBoardGPSInfo.error_code: Infinity is not an integer: GPSErrorCode takes one",
        ),
        (
            ["sensor_diag", '{"gps_sensor_1": {"utc_timestamp": 1e30}}'],
            1,
            "SensorBoardDiagnostics.gps_sensor_1.utc_timestamp: 1e+30 is out of range for int64",
        ),
        (["gps_info", "{satellites: 9}"], 1, "JSON is not valid"),
        (["gps_info", "[9]"], 1, "JSON must be an object"),
        (["gps_fix", "{}"], 2, "unknown kind 'gps_fix': PBEnvelope has ph_info, "),
    ],
)
def test_encode_errors_are_one_line(args: list[str], code: int, text: str) -> None:
    assert text in one_line_error(run("encode", *args), code)


def test_encode_reads_json_from_stdin() -> None:
    done = run("encode", "arm_feedback", "-", "--mode", "exact", stdin=b"{}")
    assert (done.code, done.out) == (0, "2200\n")


def test_a_decoded_line_encodes_back_to_its_datagram(codec: erc_codec.Codec) -> None:
    """What decode prints is what encode reads: the whole line, or its message alone."""
    gps = codec.message_class("SensorBoardGPSInfo")
    sent = gps(latitude=-33.5, altitude=1e-40, satellites=12, utc_timestamp=-(2**63))
    datagram = codec.encode(sent).hex()
    line = run("decode", datagram).out
    message = json.dumps(records(line)[0]["message"])
    whole, alone, wrong = run_many(
        ["encode", "gps_info", line],
        ["encode", "gps_info", message],
        ["encode", "ph_info", line],
    )
    assert whole.out == alone.out == datagram + "\n", (whole, alone)
    assert "decoded gps_info datagram, not ph_info" in one_line_error(wrong, 1)
    piped = run("encode", "gps_info", "-", stdin=line.encode())
    assert piped.out == datagram + "\n", piped


def test_decode_prints_a_truncated_datagram_as_an_error() -> None:
    """620b...4048 is 620b...404802 (fix_quality DGPS_FIX) cut by a byte: not a stripped form."""
    done = run("decode", stdin=b"620b09d8817346941e4a4048\n620b09d8817346941e4a404802\n")
    assert done.code == 1
    cut, whole = records(done.out)
    assert cut["reason"] == "truncated"
    assert "SensorBoardGPSInfo.fix_quality = NO_FIX" in cut["error"]
    assert whole["message"]["fix_quality"] == "DGPS_FIX"


def test_another_schema_with_proto_and_root(codec: erc_codec.Codec) -> None:
    tree = ["--proto", str(PRESENCE), "--root", "Env"]
    done = run("encode", "counter", '{"id": 7, "count": 0}', *tree)
    assert (done.code, done.out) == (0, "0a04080710\n")  # the explicit zero count, stripped
    decoded = run("decode", done.out.strip(), *tree)
    assert decoded.code == 0, decoded.err
    (record,) = records(decoded.out)
    assert record["kind"] == "counter"
    assert record["message"] == {"id": 7, "count": 0, "stamp": 0, "offset": "0"}
    gps = codec.message_class("SensorBoardGPSInfo")
    rover = codec.encode(gps(satellites=1)).hex()
    assert records(run("decode", rover, *tree).out)[0]["reason"] == "unknown_member"
    assert "unknown kind 'gps_info': Env has counter, choice" in one_line_error(
        run("encode", "gps_info", "{}", *tree), 2
    )


def test_a_tree_that_does_not_load_is_one_line_and_exit_2(tmp_path: Path) -> None:
    for args in (["decode", "22"], ["encode", "gps_info", "{}"]):
        error = one_line_error(run(*args, "--proto", str(tmp_path)), 2)
        assert "no .proto file defines message PBEnvelope" in error


@pytest.mark.parametrize(
    "args",
    [
        ["decode", "0x22"],
        ["decode", "-", "22"],
        ["decode", "--pcap", "capture.pcap", "22"],
        ["decode", "--pcap", "capture.pcap", "--framed"],
        ["encode", "gps_info", "{}", "--mode", "zip"],
        ["encode", "gps_info"],
    ],
)
def test_usage_errors_exit_2_in_one_line(args: list[str]) -> None:
    done = run(*args)
    assert done.code == 2
    assert done.out == ""
    assert done.err.startswith("Error: ")
    assert done.err.count("\n") == 1


# -- captures -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("form", "linktype"), [("pcap", ETHERNET), ("pcapng", ETHERNET), ("pcap", LINUX_SLL)]
)
def test_pcap_decodes_every_udp_payload(
    codec: erc_codec.Codec, tmp_path: Path, form: str, linktype: int
) -> None:
    gps = codec.message_class("SensorBoardGPSInfo")
    feedback = codec.message_class("ArmBoardMovementFeedback")
    fix, stop = codec.encode(gps(satellites=5)), codec.encode(feedback())
    capture = tmp_path / f"rover.{form}"
    packets = [udp4(fix), tcp4(fix), udp6(stop), udp4(bytes.fromhex("b20100"))]
    write_capture(capture, form, linktype, packets)
    done = run("decode", "--pcap", str(capture))
    assert done.code == 1
    assert done.err == "3 datagrams, 1 undecodable, 1 packet skipped (1 not UDP)\n"
    first, second, third = records(done.out)
    assert first["kind"] == "gps_info"
    assert first["message"]["satellites"] == 5
    assert (first["time"], first["src"], first["dst"]) == (
        1_700_000_000.0,
        "192.168.1.20:5005",
        "192.168.1.2:6006",
    )
    assert (second["kind"], second["length"]) == ("arm_feedback", len(stop))
    assert (second["time"], second["src"], second["dst"]) == (
        1_700_000_000.5,
        "[fd00::1]:7007",
        "[fd00::2]:8008",
    )
    assert (third["reason"], third["length"], third["time"]) == (
        "unknown_member",
        3,
        1_700_000_000.75,
    )


def test_a_capture_hands_on_whole_udp_datagrams_and_skips_the_rest_by_reason(
    codec: erc_codec.Codec, tmp_path: Path
) -> None:
    """Every reason a packet is skipped, beside the datagrams handed on: a datagram's bytes end
    where its UDP length says, fragments are skipped whichever flag or offset says so (the
    reader tests dpkt's header field for both at once)."""
    from erc_codec.cli._pcap import Capture

    fix = codec.encode(codec.message_class("SensorBoardGPSInfo")(satellites=5))
    udp = struct.pack("!HHHH", 5005, 6006, 8 + len(fix), 0) + fix
    fragment6 = struct.pack("!BBHI", 17, 0, 1, 7)  # next header UDP, offset 0, more fragments
    header6 = struct.pack(
        "!IHBB16s16s", 6 << 28, 8 + len(udp), 44, 64, bytes(15) + b"\1", bytes(16)
    )
    packets = [
        udp4(fix),
        ipv4(17, udp, flags_offset=0x2000),  # the first fragment: more fragments follow
        ipv4(17, udp, flags_offset=0x0003),  # a later one, at offset 24
        ipv4(17, udp, flags_offset=0x6000),  # don't fragment and more fragments: still one
        header6 + fragment6 + udp,
        ipv4(17, struct.pack("!HHHH", 5005, 6006, 4, 0) + fix),  # a UDP length under 8
        udp4(fix)[:-2],  # the capture kept less than the datagram
        ipv4(17, udp + b"trailer"),  # bytes after the datagram, inside the IP packet
        tcp4(fix),
        udp4(fix, sport=1),
    ]
    capture = tmp_path / "reasons.pcap"
    write_capture(capture, "pcap", ETHERNET, packets)
    with capture.open("ab") as file:  # a frame too short for its Ethernet header
        file.write(struct.pack("<IIII", 1_700_000_100, 0, 6, 6) + bytes(6))
    with Capture(capture) as read:
        got = [(d.time, d.source, d.destination, d.data) for d in read.datagrams()]
        assert read.skipped == {
            "fragmented": 4,
            "malformed": 2,
            "cut short by the capture": 1,
            "not UDP": 1,
        }
        assert (read.packets, read.damage) == (11, "")
    assert got == [
        (1_700_000_000.0, "192.168.1.20:5005", "192.168.1.2:6006", fix),
        (1_700_000_001.75, "192.168.1.20:5005", "192.168.1.2:6006", fix),
        (1_700_000_002.25, "192.168.1.20:1", "192.168.1.2:6006", fix),
    ]
    assert all(type(d) is bytes for *_, d in got)


def test_pcap_senders_are_shown_however_many_there_are(
    codec: erc_codec.Codec, tmp_path: Path
) -> None:
    # More senders than the reader keeps shown, IPv4 and IPv6: a thousand, again and again,
    # then a flood of new ones. Every address as ipaddress shows it.
    fix = codec.encode(codec.message_class("SensorBoardGPSInfo")(satellites=5))
    packets, expected = [], []
    for number in range(10_000):  # 8,000 senders in all
        repeat = number % 1000 if number < 3000 else number  # known ones, then a flood
        if number % 2:
            source = bytes.fromhex("fd00") + repeat.to_bytes(14, "big")
            packets.append(udp6(fix, source=source))
            expected.append((f"[{ipaddress.ip_address(source)}]:7007", "[fd00::2]:8008"))
        else:
            source = bytes([10, repeat >> 16 & 0xFF, repeat >> 8 & 0xFF, repeat & 0xFF])
            packets.append(udp4(fix, sport=1 + repeat, source=source))
            expected.append((f"{ipaddress.ip_address(source)}:{1 + repeat}", "192.168.1.2:6006"))
    capture = tmp_path / "many.pcap"
    write_capture(capture, "pcap", ETHERNET, packets)
    done = run("decode", "--pcap", str(capture))
    assert done.code == 0, done.err
    assert [(line["src"], line["dst"]) for line in records(done.out)] == expected


def test_pcap_problems_exit_2_in_one_line(codec: erc_codec.Codec, tmp_path: Path) -> None:
    need("dpkt")
    missing = tmp_path / "missing.pcap"
    assert "cannot read" in one_line_error(run("decode", "--pcap", str(missing)), 2)
    text = tmp_path / "notes.pcap"
    text.write_text("not a capture\n")
    error = one_line_error(run("decode", "--pcap", str(text)), 2)
    assert "is not a pcap or pcapng capture" in error
    assert "cannot read" in one_line_error(run("decode", "--pcap", str(tmp_path)), 2)
    cut = tmp_path / "cut.pcap"
    fix = codec.encode(codec.message_class("SensorBoardGPSInfo")())
    write_capture(cut, "pcap", ETHERNET, [udp4(fix), udp4(fix)])
    whole = cut.read_bytes()
    record = (len(whole) - 24) // 2  # after the 24-byte file header, two records of one size
    cut.write_bytes(whole[: len(whole) - record + 8])  # the second record's header cut off
    done = run("decode", "--pcap", str(cut))
    assert done.code == 2
    assert [r["kind"] for r in records(done.out)] == ["gps_info"]
    summary, damage = done.err.splitlines()
    assert summary == "1 datagram, 0 undecodable, 0 packets skipped"
    assert "is damaged after packet 1" in damage
    # Cut inside the last packet's data: dpkt passes the stump on as a packet; it is damage.
    cut.write_bytes(whole[:-3])
    done = run("decode", "--pcap", str(cut))
    assert done.code == 2
    assert [r["kind"] for r in records(done.out)] == ["gps_info"]
    assert done.err.splitlines()[1] == f"Error: {cut} is cut off inside packet 2"
    cut.write_bytes(whole[: len(whole) - record + 16])  # nothing after the record's header
    done = run("decode", "--pcap", str(cut))
    assert (done.code, done.err.splitlines()[1]) == (2, f"Error: {cut} is cut off inside packet 2")
    # A pcapng capture cut inside a last block that holds no packet (statistics, say).
    write_capture(cut, "pcapng", ETHERNET, [udp4(fix)])
    cut.write_bytes(cut.read_bytes() + struct.pack("<II", 5, 32) + bytes(6))
    done = run("decode", "--pcap", str(cut))
    assert (done.code, done.err.splitlines()[1]) == (2, f"Error: {cut} is cut off after packet 1")


def boundaries(form: str, whole: bytes) -> tuple[int, list[int]]:
    """Where a capture's header ends, and where each record (pcap) or block (pcapng) ends."""
    if form == "pcap":
        offset, ends = 24, []
        while offset < len(whole):
            offset += 16 + struct.unpack_from("<I", whole, offset + 8)[0]  # header, caplen
            ends.append(offset)
        return 24, ends
    offset, ends = 0, []
    while offset < len(whole):
        offset += struct.unpack_from("<I", whole, offset + 4)[0]  # block type, total length
        ends.append(offset)
    return ends[1], ends[2:]  # the section header and interface description blocks first


@pytest.mark.parametrize("form", ["pcap", "pcapng"])
def test_a_capture_cut_anywhere_but_between_packets_is_damage(
    codec: erc_codec.Codec, tmp_path: Path, form: str
) -> None:
    """Every byte offset: between records or blocks, a shorter capture (all its packets, no
    damage); inside one, damage after the packets before it; inside the header, no capture."""
    from erc_codec.cli._pcap import Capture
    from erc_codec.cli._shared import Fatal

    fix = codec.encode(codec.message_class("SensorBoardGPSInfo")(satellites=5))
    whole_path = tmp_path / f"whole.{form}"
    write_capture(whole_path, form, ETHERNET, [udp4(fix)] * 3)
    whole = whole_path.read_bytes()
    header, ends = boundaries(form, whole)
    assert len(ends) == 3
    cut = tmp_path / f"cut.{form}"
    wrong = []
    for length in range(len(whole) + 1):
        cut.write_bytes(whole[:length])
        before = sum(end <= length for end in ends)  # the packets wholly before the cut
        try:
            with Capture(cut) as capture:
                got = len(list(capture.datagrams())), bool(capture.damage)
        except Fatal:
            got = 0, True
        expected = before, not (length == header or length in ends)
        if got != expected:
            wrong.append((length, got, expected))
    assert wrong == []  # (cut at, (datagrams, damage), expected)


@pytest.mark.parametrize("form", ["pcap", "pcapng"])
def test_decode_of_a_cut_capture_exits_2_after_the_packets_before_the_cut(
    codec: erc_codec.Codec, tmp_path: Path, form: str
) -> None:
    fix = codec.encode(codec.message_class("SensorBoardGPSInfo")(satellites=5))
    capture = tmp_path / f"rover.{form}"
    write_capture(capture, form, ETHERNET, [udp4(fix)] * 2)
    whole = capture.read_bytes()
    _, (first, second) = boundaries(form, whole)
    commands = []
    for length in (first, first + 1, first + 7, second - 1):  # the next header's first bytes
        cut = tmp_path / f"cut{length}.{form}"
        cut.write_bytes(whole[:length])
        commands.append(["decode", "--pcap", str(cut)])
    at_boundary, *inside = run_many(*commands)
    assert (at_boundary.code, at_boundary.err) == (
        0,
        "1 datagram, 0 undecodable, 0 packets skipped\n",
    )
    for done in inside:
        assert done.code == 2, done
        assert [r["kind"] for r in records(done.out)] == ["gps_info"]
        summary, damage = done.err.splitlines()
        assert summary == "1 datagram, 0 undecodable, 0 packets skipped"
        assert damage.startswith("Error: ")
        assert " is cut off " in damage or " is damaged " in damage


def test_pcapng_simple_packet_blocks_are_read_as_interface_0s_without_a_time(
    codec: erc_codec.Codec, tmp_path: Path
) -> None:
    """A Simple Packet Block has no interface of its own and no time: it is interface 0's, cut
    to that interface's snapshot length, in each section (of either byte order)."""
    need("dpkt")
    fix = codec.encode(codec.message_class("SensorBoardGPSInfo")(satellites=5))
    frame = link(ETHERNET, udp4(fix))
    capture = tmp_path / "simple.pcapng"
    capture.write_bytes(
        section()
        + interface(ETHERNET)
        + simple(frame)
        + section(">")  # a second section, big-endian: its own interfaces
        + interface(ETHERNET, snaplen=len(frame) - 2, order=">")
        + simple(frame[:-2], original=len(frame), order=">")  # cut by the snapshot length
        + simple(frame[:-2] + b"\xee\xee", original=len(frame), order=">")  # bytes past it
    )
    done = run("decode", "--pcap", str(capture))
    assert (done.code, done.err) == (
        0,
        "1 datagram, 0 undecodable, 2 packets skipped (2 cut short by the capture)\n",
    )
    (shown,) = records(done.out)
    assert (shown["kind"], shown["message"]["satellites"]) == ("gps_info", 5)
    assert (shown["time"], shown["src"], shown["dst"]) == (
        None,
        "192.168.1.20:5005",
        "192.168.1.2:6006",
    )


def test_each_pcapng_packet_is_read_with_its_own_interface(
    codec: erc_codec.Codec, tmp_path: Path
) -> None:
    """Interfaces of different link types and time resolutions in one capture: each packet is
    read with its own interface's, and one naming no interface of its section is skipped."""
    need("dpkt")
    fix = codec.encode(codec.message_class("SensorBoardGPSInfo")(satellites=5))
    binary_ticks = bytes([0x80 | 10])  # if_tsresol: 1/1024 s
    hundred_seconds = struct.pack("<q", 100)  # if_tsoffset
    capture = tmp_path / "interfaces.pcapng"
    capture.write_bytes(
        section()
        + interface(ETHERNET)  # microseconds, the default
        + interface(LINUX_SLL, options=((9, b"\x09"),))  # nanoseconds
        + interface(101, options=((9, binary_ticks), (14, hundred_seconds)))  # raw IP
        + interface(147)  # a link type not read
        + enhanced(0, 1_700_000_000_000_000, link(ETHERNET, udp4(fix, sport=1)))
        + enhanced(1, 1_700_000_000_500_000_000, link(LINUX_SLL, udp4(fix, sport=2)))
        + enhanced(2, 1_700_000_001 * 1024 + 512, udp4(fix, sport=3))
        + enhanced(3, 0, link(ETHERNET, udp4(fix, sport=4)))
        + enhanced(4, 1_700_000_002_000_000, link(ETHERNET, udp4(fix, sport=5)))
        + section()  # interfaces are a section's own: the next names one no more
        + enhanced(0, 1_700_000_003_000_000, link(ETHERNET, udp4(fix, sport=6)))
        + interface(ETHERNET, options=((9, b"\x03"),))  # milliseconds
        + enhanced(0, 1_700_000_004_000, link(ETHERNET, udp4(fix, sport=7)))
    )
    done = run("decode", "--pcap", str(capture))
    assert (done.code, done.err) == (
        0,
        "4 datagrams, 0 undecodable, 3 packets skipped "
        "(1 link type 147 not supported, 2 no such interface)\n",
    )
    assert [(r["time"], r["src"], r["kind"]) for r in records(done.out)] == [
        (1_700_000_000.0, "192.168.1.20:1", "gps_info"),
        (1_700_000_000.5, "192.168.1.20:2", "gps_info"),
        (1_700_000_101.5, "192.168.1.20:3", "gps_info"),
        (1_700_000_004.0, "192.168.1.20:7", "gps_info"),
    ]


def test_pcap_without_dpkt_says_what_to_install(tmp_path: Path) -> None:
    # The same entry point, with dpkt made unimportable (whether or not it is installed).
    code = "import sys; sys.modules['dpkt'] = None; from erc_codec.cli import main; main()"
    done = subprocess.run(
        [sys.executable, "-c", code, "decode", "--pcap", str(tmp_path / "x.pcap")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 2
    assert done.stderr == "Error: --pcap needs the dpkt package: pip install 'erc-codec[pcap]'\n"


@pytest.mark.parametrize("byte", [b"\n", b"2", b"B", b"b", b":"])
def test_a_one_byte_raw_datagram_on_stdin_is_raw(byte: bytes) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "erc_codec", "decode", "--raw"], input=byte, capture_output=True
    )
    assert done.returncode == 0, done.stdout
    (line,) = done.stdout.decode().splitlines()
    assert json.loads(line)["length"] == 1


def run_slowly(*pieces: bytes, options: tuple[str, ...] = ()) -> Done:
    """``decode`` with standard input arriving in pieces, each once the command has read the
    one before (and had time to judge it), as from a slow writer."""
    decoder = subprocess.Popen(
        [sys.executable, "-m", "erc_codec", "decode", *options],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert decoder.stdin is not None
    for piece in pieces:
        decoder.stdin.write(piece)
        decoder.stdin.flush()
        deadline = time.monotonic() + 30
        waiting = array.array("i", [1])
        while waiting[0] and time.monotonic() < deadline:  # bytes still in the pipe
            fcntl.ioctl(decoder.stdin.fileno(), termios.FIONREAD, waiting)
            time.sleep(0.01)
        time.sleep(0.3)
    out, err = decoder.communicate(timeout=30)
    return Done(decoder.returncode, out.decode(), err.decode())


def test_hex_text_arriving_slowly_on_stdin_is_hex() -> None:
    # The first line's first digit alone would look like a one-byte raw datagram.
    done = run_slowly(b"2", b"200\n", b"0a00\n")
    assert done.code == 0, done
    assert [(r["kind"], r["length"]) for r in records(done.out)] == [
        ("arm_feedback", 2),
        ("ph_info", 2),
    ]
    done = run_slowly(b"\n  ", b"  22", b"00\n")  # blank lines first: judged on the first line
    assert [r["length"] for r in records(done.out)] == [2]


def test_raw_bytes_arriving_slowly_on_stdin_are_one_datagram() -> None:
    done = run_slowly(b"\xb2\x01", b"\x00", options=("--raw",))  # member 22, empty: 3 bytes
    assert done.code == 1
    assert [(r["reason"], r["length"]) for r in records(done.out)] == [("unknown_member", 3)]


def test_a_key_given_twice_is_refused() -> None:
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "erc_codec",
            "encode",
            "gps_info",
            '{"satellites":1,"satellites":2}',
        ],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 1
    assert "key 'satellites' appears twice" in done.stderr


def test_a_decoded_lines_metadata_is_shown_and_encoded_back() -> None:
    sent = "62024003f001ac02"  # gps_info (satellites 3) with the envelope's timeout 300
    line = run("decode", sent)
    assert line.code == 0
    assert json.loads(line.out)["metadata"] == {"timeout": 300}
    assert run("encode", "gps_info", "-", stdin=line.out.encode()) == Done(0, sent + "\n", "")


def test_a_decoded_line_listing_unknown_fields_is_sent_with_a_warning() -> None:
    line = run("decode", "6200a00101")  # field 20 beside gps_info: listed, no bytes of it
    done = run("encode", "gps_info", "-", stdin=line.out.encode())
    assert (done.code, done.out) == (0, "62\n")
    assert done.err == (
        "warning: the decoded line lists 1 field(s) this schema does not know; JSON holds no "
        "bytes of them, so they are not sent\n"
    )
