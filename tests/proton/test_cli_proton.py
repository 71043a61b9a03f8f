"""erc-codec proton decode and listen: Proton bundles by name, as JSON lines, from the shell."""

import json
import signal
import socket
import struct
import subprocess
import sys
from pathlib import Path

import pytest
from cli_support import ETHERNET, one_line_error, records, run, udp4, write_capture
from google.protobuf import json_format, wrappers_pb2
from hypothesis import given, settings
from hypothesis import strategies as st
from proton_values import HERE, TYPES_1_0, TYPES_2_0
from test_proton_codec import LARGE, bundle2, field, signal2

import erc_codec
from erc_codec.cli._proton import json_value
from erc_codec.proton import BundleCodec, parse_config

V2 = BundleCodec(TYPES_2_0)
V1 = BundleCodec(TYPES_1_0, "1.0")
CONFIG = ["--config", str(HERE / "types.yaml")]
CONFIG_1_0 = ["--config", str(HERE / "types_1_0.yaml"), "--protocol", "1.0"]
BEAT = V2.encode("heartbeat", {"beat": 3})
COMMAND = V2.encode("command", {"set_speed": -1.5, "set_name": "ares", "set_mask": b"\x01"})


def test_decode_prints_bundles_by_name() -> None:
    done = run("proton", "decode", *CONFIG, BEAT.hex())
    assert done.code == 0, done.err
    assert records(done.out) == [
        {"bundle": "heartbeat", "id": 0, "length": len(BEAT), "signals": {"beat": 3}}
    ]
    (command,) = records(run("proton", "decode", *CONFIG, COMMAND.hex()).out)
    assert command["signals"] == {"set_speed": -1.5, "set_name": "ares", "set_mask": "AQ=="}


def test_values_as_protobufs_json_mapping_writes_them() -> None:
    assert json_value("uint64", 2**64 - 1) == "18446744073709551615"
    assert json_value("int64", -5) == "-5"
    assert json_value("int32", -5) == -5
    assert [json_value("double", v) for v in (float("nan"), float("inf"), -float("inf"))] == [
        "NaN",
        "Infinity",
        "-Infinity",
    ]
    assert json_value("bytes", b"\xff\x00") == "/wA="
    assert json_value("list_uint64", [1, 2]) == ["1", "2"]
    assert json_value("list_bytes", [b"\x01"]) == ["AQ=="]
    tenth = V2.decode(V2.encode("floats", {"a_float": 0.1})).signals["a_float"]
    assert tenth == 0.10000000149011612  # the C float's value, as a Python float
    assert json.dumps(json_value("float", tenth)) == "0.1"  # as protobuf prints it
    assert json_value("list_float", [tenth]) == [0.1]
    assert json.dumps(json_value("double", tenth)) == "0.10000000149011612"  # a double's own


@given(value=st.floats(width=32))
@settings(max_examples=300, deadline=None)
def test_a_float_prints_as_protobufs_json_mapping_prints_it(value: float) -> None:
    """The fewest digits that read back as the same 32-bit float: protobuf's own JSON printer
    (json_format, a FloatValue) is the reference."""
    theirs = json_format.MessageToDict(wrappers_pb2.FloatValue(value=value))
    ours = json_value("float", value)
    if isinstance(theirs, str):  # NaN and the infinities
        assert ours == theirs
    else:
        assert json.dumps(ours) == json.dumps(theirs)
        assert struct.pack("<f", json.loads(json.dumps(ours))) == struct.pack("<f", value)


def test_protocol_1_0_with_its_lists() -> None:
    defaults = {n: TYPES_1_0.signal(n).default for n in TYPES_1_0.bundle("lists").signals}
    message = V1.encode("lists", {**defaults, "int64s": [-1, 2**62], "bools": [True] * 5})
    (record,) = records(run("proton", "decode", *CONFIG_1_0, message.hex()).out)
    assert record["bundle"] == "lists"
    assert record["signals"]["int64s"] == ["-1", str(2**62)]
    assert record["signals"]["bools"] == [True] * 5
    assert record["signals"]["texts"] == ["", "", ""]


def test_stdin_lines_go_on_after_one_that_does_not_decode() -> None:
    stdin = f"{BEAT.hex()}\n0a03089909\nnot hex\n{COMMAND.hex()}\n".encode()
    done = run("proton", "decode", *CONFIG, stdin=stdin)
    assert done.code == 1
    kinds = [r.get("bundle", r.get("reason")) for r in records(done.out)]
    assert kinds == ["heartbeat", "unknown_bundle", "not_hex", "command"]
    assert records(done.out)[1]["error"].startswith("bundle id 0x499 is not in ")


def test_framed_serial_stream_and_raw_stdin() -> None:
    stream = (
        b"\x00noise" + erc_codec.runtime.frame(BEAT) + erc_codec.runtime.frame(COMMAND) + b"PR\x05"
    )
    done = run("proton", "decode", *CONFIG, "--framed", "--raw", stdin=stream)
    assert done.code == 0, done.err
    assert [r["bundle"] for r in records(done.out)] == ["heartbeat", "command"]
    assert done.err == (
        "2 frames, 0 undecodable, 6 bytes discarded (garbage 6), "
        "3 bytes left in an unfinished frame\n"
    )
    raw = run("proton", "decode", *CONFIG, "--raw", stdin=COMMAND)
    assert [r["bundle"] for r in records(raw.out)] == ["command"]


def test_a_frame_the_stream_cuts_off_is_reported_as_erc_codec_decode_reports_it() -> None:
    """The Deframer's flush() counts it; the exit status is erc-codec decode --framed's: the
    summary shows it, every complete message decoded is 0 (both helps say so)."""
    stream = erc_codec.runtime.frame(BEAT) + erc_codec.runtime.frame(COMMAND)[:-3]
    done = run("proton", "decode", *CONFIG, "--framed", "--raw", stdin=stream)
    assert [r["bundle"] for r in records(done.out)] == ["heartbeat"]
    assert done.err == (
        f"1 frame, 0 undecodable, {len(erc_codec.runtime.frame(COMMAND)) - 3} bytes left in an "
        "unfinished frame\n"
    )
    main = run("decode", "--framed", "--raw", stdin=stream)
    assert (done.code, main.code) == (0, 0)
    helped = " ".join(run("proton", "decode", "--help").out.split())
    assert "a cut-off last frame show in the summary only, as for erc-codec decode --framed" in (
        helped
    )


def test_a_udp_header_is_read_and_shown() -> None:
    done = run("proton", "decode", *CONFIG, (bytes([1, 1, 0, 0]) + BEAT).hex())
    assert records(done.out)[0] == {
        "node_id": 1,
        "bundle": "heartbeat",
        "id": 0,
        "length": len(BEAT) + 4,
        "signals": {"beat": 3},
    }


def test_pcap_decodes_every_udp_payload(tmp_path: Path) -> None:
    capture = tmp_path / "board.pcap"
    write_capture(capture, "pcap", ETHERNET, [udp4(BEAT), udp4(b"\x12\x00"), udp4(COMMAND)])
    done = run("proton", "decode", *CONFIG, "--pcap", str(capture))
    assert done.code == 1
    found = records(done.out)
    assert [r.get("bundle", r.get("reason")) for r in found] == [
        "heartbeat",
        "unsupported_operation",
        "command",
    ]
    assert found[0]["src"] == "192.168.1.20:5005"
    assert done.err == "3 datagrams, 1 undecodable, 0 packets skipped\n"


@pytest.mark.parametrize(
    ("args", "code", "text"),
    [
        (["--config", "missing.yaml", "00"], 2, "missing.yaml: cannot read it"),
        (
            ["--config", str(HERE / "types_1_0.yaml"), "00"],
            2,
            "types_1_0.yaml:29: signals[10].type: list_double (signal 'doubles') is a Proton 1.0 "
            "type",
        ),
        ([*CONFIG, "zz"], 2, "Invalid value for HEX: 'z' at column 1 is not a hex digit"),
        ([*CONFIG, "--pcap", "x.pcap", "00"], 2, "--pcap reads the capture only"),
        ([*CONFIG, "--protocol", "3.0", "00"], 2, "Invalid value for '--protocol'"),
        (["00"], 2, "Missing option '--config'"),
    ],
)
def test_failures_are_one_line_with_their_status(args: list[str], code: int, text: str) -> None:
    assert text in one_line_error(run("proton", "decode", *args), code)


def test_without_pyyaml_it_says_which_extra_to_install() -> None:
    code = "import sys; sys.modules['yaml'] = None; from erc_codec.cli import main; main()"
    done = subprocess.run(
        [sys.executable, "-c", code, "proton", "decode", *CONFIG, "00"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 2
    assert done.stderr == (
        "Error: reading a Proton configuration needs pyyaml: pip install 'erc-codec[proton]'\n"
    )


def test_a_bad_configuration_names_its_line(tmp_path: Path) -> None:
    broken = tmp_path / "broken.yaml"
    broken.write_text((HERE / "types.yaml").read_text().replace("type: double}", "type: real}", 1))
    error = one_line_error(run("proton", "decode", "--config", str(broken), "00"), 2)
    assert f"{broken}:21: signals[0].type: 'real' is not a Proton signal type" in error


@pytest.mark.parametrize(
    ("change", "text"),
    [
        ("id: 0x10, type: double}", "id: !foo 0x10, type: double}"),
        ("id: 0x10, type: double}", "id: !!python/int 16, type: double}"),
        ("type: double}", "type: double, value: 2001-02-30}"),
    ],
)
def test_a_configuration_yaml_cannot_build_is_one_line_and_status_2(
    tmp_path: Path, change: str, text: str
) -> None:
    """Not a traceback and status 1: the reviewer's ConstructorError and ValueError."""
    broken = tmp_path / "broken.yaml"
    broken.write_text((HERE / "types.yaml").read_text().replace(change, text, 1))
    error = one_line_error(run("proton", "decode", "--config", str(broken), "00"), 2)
    assert f"{broken}:21: signals[0]." in error
    assert "cannot be read" in error


def test_a_configuration_with_merge_keys_loads(tmp_path: Path) -> None:
    """yaml.safe_load (Proton's generator) reads merge keys: so does erc-codec."""
    merged = tmp_path / "merge.yaml"
    merged.write_text(
        """\
nodes:
  - {name: pc, id: 0, endpoints: [{id: 0, type: udp4, ip: 127.0.0.1, port: 11416}]}
  - {name: mcu, id: 1, endpoints: [{id: 0, type: udp4, ip: 127.0.0.1, port: 11417}]}
connections:
  - first: {node: pc, id: 0}
    second: {node: mcu, id: 0}
signals:
  - {name: a, id: 1, type: uint32}
bundles:
  - &x {name: b, id: 2, producers: [pc], consumers: [mcu], signals: [1]}
  - {<<: *x, name: c, id: 3}
"""
    )
    message = "0a09 0803 1205 2807 980101"
    done = run("proton", "decode", "--config", str(merged), message)
    assert done.code == 0, done.err
    assert records(done.out)[0]["bundle"] == "c"


def test_the_scratch_buffer_a_board_is_built_with(tmp_path: Path) -> None:
    large = tmp_path / "large.yaml"
    large.write_text(LARGE)
    error = one_line_error(run("proton", "decode", "--config", str(large), "00"), 2)
    assert "signals[0].capacity: capacity 600 (signal 'text')" in error
    codec = BundleCodec(parse_config(LARGE), scratch_buffer_size=1024)
    message = codec.encode("long", {"text": "x" * 599, "blob": bytes(513)})
    done = run(
        "proton", "decode", "--config", str(large), "--scratch-buffer-size", "1024", message.hex()
    )
    assert done.code == 0, done.err
    assert records(done.out)[0]["signals"]["text"] == "x" * 599


def test_fields_proton_does_not_define_are_shown() -> None:
    message = bundle2(0x106, signal2(field(7, 0, b"\x01") + field(20, 0, b"\x01"), 0x16))
    done = run("proton", "decode", *CONFIG, message.hex())
    assert done.code == 0, done.err
    (record,) = records(done.out)
    assert record["signals"] == {"a_bool": True}
    assert record["unknown_fields"] == [{"message": "Signal", "number": 20, "offset": 9}]


def test_listen_prints_what_arrives() -> None:
    listener = subprocess.Popen(
        [
            *(sys.executable, "-m", "erc_codec", "proton", "listen", *CONFIG, "127.0.0.1:0"),
            *("--count", "3", "--seconds", "30"),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert listener.stderr is not None
    first = listener.stderr.readline()
    assert first.startswith("listening on 127.0.0.1:"), first
    port = int(first.rsplit(":", 1)[1])
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as board:
        for datagram in (BEAT, b"\x0a\x00", bytes([1, 1, 0, 0]) + COMMAND):
            board.sendto(datagram, ("127.0.0.1", port))
    out, err = listener.communicate(timeout=30)
    assert listener.returncode == 0, err
    lines = records(out)
    assert [line.get("bundle", line.get("reason")) for line in lines] == [
        "heartbeat",
        "corrupt",
        "command",
    ]
    assert lines[0]["from"].startswith("127.0.0.1:")
    assert lines[2]["node_id"] == 1
    counters = json.loads(err.strip().splitlines()[-1].removeprefix("counters: "))
    assert counters == {
        "received": 3,
        "bundles": {"heartbeat": 1, "command": 1},
        "undecodable": {"corrupt": 1},
    }


@pytest.mark.parametrize("number", [signal.SIGTERM, signal.SIGINT])
def test_listen_stopped_by_a_signal_prints_its_counters(number: signal.Signals) -> None:
    """SIGTERM killed it (exit 143) with the counters unprinted, as erc-codec listen once did."""
    listener = subprocess.Popen(
        [sys.executable, "-m", "erc_codec", "proton", "listen", *CONFIG, "127.0.0.1:0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert listener.stderr is not None
    assert listener.stdout is not None
    first = listener.stderr.readline()
    assert first.startswith("listening on 127.0.0.1:"), first
    port = int(first.rsplit(":", 1)[1])
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as board:
        board.sendto(BEAT, ("127.0.0.1", port))
    assert json.loads(listener.stdout.readline())["bundle"] == "heartbeat"  # it is listening
    listener.send_signal(number)
    out, err = listener.communicate(timeout=30)
    assert listener.returncode == 0, err
    assert out == ""
    assert err.count("\n") == 1, err  # the counters alone: no traceback, no "Aborted!"
    counters = json.loads(err.removeprefix("counters: "))
    assert counters == {"received": 1, "bundles": {"heartbeat": 1}, "undecodable": {}}


@pytest.mark.parametrize(
    ("option", "value", "problem"),
    [
        ("--seconds", "nan", "'nan' is not a finite number."),  # was exit 0, at once
        ("--seconds", "inf", "'inf' is not a finite number."),  # was for ever
        ("--seconds", "0", "0.0 is not in the range x>0."),
        ("--count", "0", "0 is not in the range x>=1."),
    ],
)
def test_listen_refuses_a_time_or_count_that_is_not_finite_and_positive(
    option: str, value: str, problem: str
) -> None:
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "erc_codec",
            "proton",
            "listen",
            *CONFIG,
            "127.0.0.1:0",
            option,
            value,
        ],
        capture_output=True,
        text=True,
        timeout=30,  # inf listened for ever
    )
    assert (done.returncode, done.stdout) == (2, "")
    assert done.stderr == f"Error: Invalid value for '{option}': {problem}\n"


def test_listen_into_a_closed_pipe_ends_quietly_with_status_1() -> None:
    """| head -1: the reader goes away. One quiet exit with status 1, as the command group ends
    any command whose reader left, not a traceback per datagram and a listener running on."""
    listener = subprocess.Popen(
        [
            *(sys.executable, "-m", "erc_codec", "proton", "listen", *CONFIG, "127.0.0.1:0"),
            *("--seconds", "30"),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert listener.stderr is not None
    assert listener.stdout is not None
    first = listener.stderr.readline()
    port = int(first.rsplit(":", 1)[1])
    listener.stdout.close()  # the reader is gone before anything is written
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as board:
        for _ in range(5):
            board.sendto(BEAT, ("127.0.0.1", port))
    with listener.stderr:
        err = listener.stderr.read()
    assert listener.wait(timeout=30) == 1
    assert err == ""
