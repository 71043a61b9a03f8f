"""erc-codec relay: its configuration checked key by key, and a live relay over 127.0.0.1."""

import json
import re
import signal
import socket
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

import erc_codec

CODEC = erc_codec.Codec.default()


def run_relay(config: Path) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "erc_codec", "relay", str(config)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


GOOD = """
[listen]
rover = "0"
[destinations]
base = { address = "127.0.0.1:9", form = "exact" }
[[routes]]
to = ["base"]
"""
FAILSAFE = '[[failsafes]]\nkind = "drive_motor"\nto = ["base"]\nrate = 10\ntimeout = 0.3\n'


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[listen", "not TOML"),
        (GOOD + "\n[relay]\nspeed = 1\n", "unknown key relay.speed"),
        (GOOD + "\nextra = 1\n", r"unknown key routes\[0\].extra \(known: kinds, receiver"),
        (GOOD.replace('rover = "0"', ""), r"\[listen\] names no endpoint"),
        (GOOD.replace('rover = "0"', 'rover = "x:y"'), r"listen.rover: .*port is not a number"),
        (GOOD.replace('form = "exact"', 'form = "raw"'), "destinations.base.form must be"),
        (GOOD.replace(', form = "exact"', ', via = "air"'), "destinations.base.via: no"),
        (GOOD.replace('to = ["base"]', 'to = ["nowhere"]'), "no destination 'nowhere'"),
        (GOOD + 'kinds = ["drive"]\n', "drive is not a payload kind"),
        (GOOD + 'receiver = "Mars"\n', "no member of PBEnvelope is sent"),
        (
            GOOD + '[[failsafes]]\nkind = "drive_motor"\nto = ["base"]\n',
            r"failsafes\[0\].rate is missing",
        ),
        (
            GOOD + '[[failsafes]]\nkind = "drive_motor"\nto = ["base"]\nrate = 10\n'
            "message = { speed = 1 }\n",
            r"failsafes\[0\].message: .*speed",
        ),
        (GOOD + '[relay]\nstatus = "loud"\n', "relay.status must be line, json or none"),
        (GOOD + "[relay]\ninterval = nan\n", "relay.interval must be a positive, finite"),
        (GOOD + "[relay]\ninterval = 0.001\n", r"relay.interval must be at least 0\.01 s"),
        (GOOD + FAILSAFE + "message = 5\n", r"failsafes\[0\].message must be a table"),
        (
            GOOD + FAILSAFE + FAILSAFE.replace("rate = 10", "rate = 5"),
            r"failsafes\[1\].kind: drive_motor has a failsafe already \(failsafes\[0\]\)",
        ),
        (GOOD + FAILSAFE.replace("timeout = 0.3\n", ""), r"failsafes\[0\].timeout is missing"),
        (GOOD + FAILSAFE.replace("rate = 10", "rate = 1e9"), "at most 500 a second"),
        (GOOD + FAILSAFE.replace("rate = 10", "rate = 1e-300"), "rate must be a number of Hz"),
        (GOOD + FAILSAFE.replace('["base"]', '["logger"]'), "no destination 'logger'"),
        (
            GOOD + FAILSAFE + 'sources = ["grond"]\n',
            r"failsafes\[0\].sources: no sender 'grond' \(.*: rover\)",
        ),
        (GOOD + 'sources = ["grond"]\n', r"routes\[0\].sources: no sender 'grond'"),
        (GOOD.replace('to = ["base"]', "to = []"), r"routes\[0\].to = \[\] names nothing"),
        (
            GOOD + 'kinds = ["gps_info"]\n' + FAILSAFE,
            "failsafe drive_motor: no route takes drive_motor to base: it could never arrive",
        ),
        (GOOD + '[sources]\nrover = "127.0.0.1:7"\n', "sources.rover: 'rover' names a .listen"),
        (
            GOOD.replace('rover = "0"', 'rover = "5000"').replace(":9", ":5000"),
            r"destinations.base.address: the relay listens there itself \(\[listen\] rover\)",
        ),
        (
            GOOD.replace('rover = "0"', 'rover = "0.0.0.0:5000"').replace(":9", ":5000"),
            "the relay listens there itself",
        ),
    ],
)
def test_a_bad_configuration_is_one_line_and_status_2(
    tmp_path: Path, text: str, message: str
) -> None:
    config = tmp_path / "relay.toml"
    config.write_text(text)
    done = subprocess.run(
        [sys.executable, "-m", "erc_codec", "relay", str(config)],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert done.returncode == 2, done.stderr
    assert done.stderr.count("\n") == 1, done.stderr
    assert done.stderr.startswith(f"Error: {config}: ")
    assert re.search(message, done.stderr), done.stderr


def test_a_missing_configuration_is_one_line(tmp_path: Path) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "erc_codec", "relay", str(tmp_path / "none.toml")],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert done.returncode == 2
    assert "No such file" in done.stderr
    assert done.stderr.count("\n") == 1


def test_a_live_relay_routes_by_named_source_debugs_and_counts(tmp_path: Path) -> None:
    with (
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as board,
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as jetson,
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as debug,
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as stranger,
    ):
        for sock in (board, jetson, debug, stranger):
            sock.bind(("127.0.0.1", 0))
            sock.settimeout(10)
        config = tmp_path / "relay.toml"
        config.write_text(
            f"""
[listen]
rover = "0"
[sources]
board = "127.0.0.1:{board.getsockname()[1]}"
[destinations]
jetson = {{ address = "127.0.0.1:{jetson.getsockname()[1]}", form = "strip" }}
debug = {{ address = "127.0.0.1:{debug.getsockname()[1]}", form = "exact" }}
[[routes]]
to = ["jetson"]
sources = ["board"]
[relay]
debug = "debug"
status = "json"
interval = 0.1
"""
        )
        relay = run_relay(config)
        try:
            assert relay.stderr is not None
            line = relay.stderr.readline()
            assert line.startswith("relaying: listening on rover 127.0.0.1:"), line
            port = int(line.rsplit(":", 1)[1])
            stop = CODEC.encode(CODEC.message_class("drive_motor")(), "exact")
            board.sendto(stop, ("127.0.0.1", port))
            assert jetson.recv(4096) == bytes.fromhex("4a")  # the Jetson takes it stripped
            stranger.sendto(stop, ("127.0.0.1", port))  # no route from an unnamed sender
            assert debug.recv(4096) == stop
            board.sendto(bytes.fromhex("b2 01 00"), ("127.0.0.1", port))  # a newer member
            assert debug.recv(4096) == bytes.fromhex("b2 01 00")
            assert relay.stdout is not None
            while True:  # the JSON status lines, until one has seen all three
                metrics = json.loads(relay.stdout.readline())
                if metrics["listen"]["rover"]["received"] == 3:
                    break
        finally:
            relay.send_signal(signal.SIGTERM)
            _, errors = relay.communicate(timeout=10)
    assert relay.returncode == 0, errors
    counters = json.loads(errors.rsplit("counters: ", 1)[1])
    assert counters["routes"]["jetson"] == {"forwarded": 1, "failsafe": 0}
    assert counters["dropped"] == {"unrouted": 1, "unknown_member": 1}
    assert counters["debug"] == 2
    assert counters["listen"]["rover"]["received"] == 3
    assert counters["latency_us"]["p99"] is not None


def test_the_readmes_rover_configuration_is_valid() -> None:
    from erc_codec.cli._relayconfig import read_config

    readme = (Path(__file__).parent.parent / "README.md").read_text()
    (block,) = re.findall(r"```toml\n(# relay\.toml.*?)```", readme, re.S)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "relay.toml"
        path.write_text(block)
        config = read_config(path, CODEC)
    assert list(config.listen) == ["rover", "ground"]
    assert config.destinations["base"].form == "exact"
    assert config.destinations["jetson"].form == "strip"
    assert [failsafe.kind for failsafe in config.failsafes] == ["drive_motor"]
    assert config.debug == "debug"
    assert config.sources == {("192.168.1.20", 6000): "jetson"}
    erc_codec.Router(
        CODEC,
        {name: destination.form for name, destination in config.destinations.items()},
        config.routes,
        config.failsafes,
        config.debug,
    )


def test_a_relay_started_while_the_base_station_is_down_brakes(tmp_path: Path) -> None:
    """No drive command ever arrives: the start counts as one, so the board is braked."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as board:
        board.bind(("127.0.0.1", 0))
        board.settimeout(10)
        config = tmp_path / "relay.toml"
        config.write_text(
            GOOD.replace("127.0.0.1:9", f"127.0.0.1:{board.getsockname()[1]}")
            + FAILSAFE.replace("timeout = 0.3", "timeout = 0.2")
            + '[relay]\nstatus = "none"\n'
        )
        relay = run_relay(config)
        try:
            assert board.recv(4096) == bytes.fromhex("4a 00")  # the all-zero drive command
        finally:
            relay.send_signal(signal.SIGTERM)
            _, errors = relay.communicate(timeout=10)
    assert "failsafe drive_motor engaged" in errors
    assert relay.returncode == 0, errors


def test_a_relay_forwards_metadata_named_like_encodes_parameters(tmp_path: Path) -> None:
    (tmp_path / "env.proto").write_text(
        'syntax = "proto3";\nmessage Ping { uint32 n = 1; }\n'
        "message Env { oneof payload { Ping ping = 2; } uint32 mode = 20; }\n"
    )
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as peer:
        peer.bind(("127.0.0.1", 0))
        peer.settimeout(10)
        config = tmp_path / "relay.toml"
        config.write_text(
            GOOD.replace("127.0.0.1:9", f"127.0.0.1:{peer.getsockname()[1]}")
            + '[relay]\nstatus = "none"\n'
        )
        command = ["relay", "--proto", str(tmp_path), "--root", "Env", str(config)]
        relay = subprocess.Popen(
            [sys.executable, "-m", "erc_codec", *command],
            stderr=subprocess.PIPE,
            text=True,
        )
        try:
            assert relay.stderr is not None
            port = int(relay.stderr.readline().rsplit(":", 1)[1])
            datagram = bytes.fromhex("12 02 08 01 a0 01 03")  # ping n=1, mode=3
            peer.sendto(datagram, ("127.0.0.1", port))
            assert peer.recv(4096) == datagram
        finally:
            relay.send_signal(signal.SIGTERM)
            _, errors = relay.communicate(timeout=10)
    assert relay.returncode == 0, errors
    counters = json.loads(errors.rsplit("counters: ", 1)[1])
    assert (counters["routes"]["base"]["forwarded"], counters["errors"]) == (1, {})
