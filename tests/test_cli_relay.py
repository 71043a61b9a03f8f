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
