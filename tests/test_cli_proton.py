"""erc-codec proton decode and listen: Proton bundles by name, as JSON lines, from the shell."""

import json
import socket
import subprocess
import sys
from pathlib import Path

import pytest
from proton_values import HERE, TYPES_1_0, TYPES_2_0
from test_cli_codec import ETHERNET, one_line_error, records, run, udp4, write_capture

import erc_codec
from erc_codec.cli._proton import json_value
from erc_codec.proton import BundleCodec

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
    stream = b"\x00noise" + erc_codec.frame(BEAT) + erc_codec.frame(COMMAND) + b"PR\x05"
    done = run("proton", "decode", *CONFIG, "--framed", stdin=stream)
    assert done.code == 0, done.err
    assert [r["bundle"] for r in records(done.out)] == ["heartbeat", "command"]
    assert done.err == (
        "2 frames, 0 undecodable, 6 bytes discarded (garbage 6), "
        "3 bytes left in an unfinished frame\n"
    )
    raw = run("proton", "decode", *CONFIG, stdin=COMMAND)
    assert [r["bundle"] for r in records(raw.out)] == ["command"]


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
            "types_1_0.yaml:29: signal 'doubles': list_double is a Proton 1.0 type",
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
    code = "import sys; sys.modules['yaml'] = None; from erc_codec.cli._main import main; main()"
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
    assert f"{broken}:20: signals[0].type: 'real' is not a Proton signal type" in error


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
