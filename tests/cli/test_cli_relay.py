"""erc-codec relay: its configuration checked key by key, and a live relay over 127.0.0.1."""

import ipaddress
import json
import os
import re
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
import tracemalloc
from pathlib import Path

import pytest
from conftest import REPO

import erc_codec
from erc_codec.cli._local import canonical, is_local, receives

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
        (GOOD + 'kinds = ["drive"]\n', r"routes\[0\].kinds: 'drive' is not a payload kind"),
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
        (GOOD + "[relay]\ninterval = 0.001\n", r"relay.interval must be from 0\.01 to 3600 s"),
        (GOOD + "[relay]\ninterval = 1e308\n", r"relay.interval must be from 0\.01 to 3600 s"),
        (GOOD + '[relay]\ndebug = ["base"]\n', "relay.debug must be a string"),
        (GOOD + "[relay]\ndebug = { a = 1 }\n", "relay.debug must be a string"),
        (GOOD + '[relay]\ndebug = "logger"\n', r"relay.debug: no destination 'logger'"),
        (GOOD.replace(', form = "exact"', ', via = ["rover"]'), "destinations.base.via must be"),
        ("a = " + "[" * 5000 + "]" * 5000 + "\n", "not TOML: nested too deeply"),
        (GOOD + FAILSAFE.replace("0.3", "1e-300"), r"failsafes\[0\].timeout must be from 0\.001"),
        (
            GOOD + FAILSAFE.replace("0.3", "1e308"),
            r"failsafes\[0\].timeout must be from 0\.001 to 3600",
        ),
        (
            GOOD + FAILSAFE.replace("0.3", "nan"),
            r"failsafes\[0\].timeout must be a positive, finite",
        ),
        (GOOD + FAILSAFE.replace("0.3", '"soon"'), r"failsafes\[0\].timeout must be a positive"),
        (
            GOOD + FAILSAFE.replace('to = ["base"]', 'to = ["base", "base"]'),
            r"failsafes\[0\].to names 'base' twice",
        ),
        (GOOD.replace('to = ["base"]', 'to = ["base", "base"]'), r"routes\[0\].to names 'base'"),
        (GOOD.replace("127.0.0.1:9", "127.0.0.1:0"), "destinations.base.address: port 0 is no"),
        (GOOD.replace("127.0.0.1:9", "0.0.0.0:9"), "0.0.0.0 means every local address"),
        (
            GOOD + '[sources]\na = "127.0.0.1:7"\nb = "127.0.0.1:7"\n',
            r"sources.b: '127.0.0.1:7' is sources.a already",
        ),
        (
            GOOD + '[sources]\na = "127.0.0.1:7"\nb = "[::ffff:127.0.0.1]:7"\n',
            r"sources.b: '\[::ffff:127.0.0.1\]:7' is sources.a already",
        ),
        (
            GOOD.replace('rover = "0"', 'rover = "[::]:5000"').replace(
                "127.0.0.1:9", "[::ffff:127.0.0.1]:5000"
            ),
            r"destinations.base.address: the relay listens there itself \(\[listen\] rover\)",
        ),
        (
            GOOD.replace('rover = "0"', 'rover = "9"').replace(
                "127.0.0.1:9", "[::ffff:127.0.0.1]:9"
            ),
            r"destinations.base.address: the relay listens there itself",
        ),
        (
            GOOD + '[sources]\nground = "127.0.0.1:0"\n',
            "sources.ground: port 0 is no sender",
        ),
        (
            GOOD + '[sources]\nground = "0.0.0.0:7"\n',
            "sources.ground: 0.0.0.0 means every local address, no sender",
        ),
        (
            GOOD.replace('rover = "0"', 'rover = "5000"') + '[sources]\nme = "127.0.0.1:5000"\n',
            r"sources.me: the relay listens there itself \(\[listen\] rover\)",
        ),
        (
            GOOD.replace('rover = "0"', 'rover = "5000"\nground = "127.0.0.1:5000"'),
            "listen.ground: '127.0.0.1:5000' is where listen.rover listens",
        ),
        (
            GOOD.replace('rover = "0"', 'rover = "0.0.0.0:5000"\nground = "127.0.0.1:5000"'),
            "listen.ground: '127.0.0.1:5000' is where listen.rover listens",
        ),
        (GOOD + FAILSAFE.replace("rate = 10", "rate = 0"), r"from 0\.01 to 500"),
        (
            GOOD.replace('to = ["base"]', "to = []"),
            r"routes\[0\].to = \[\] names nothing: name at least",
        ),
        (
            GOOD.replace("127.0.0.1:9", "[::1]:9"),
            "destinations.base.address: an IPv6 address, and via = 'rover' is an IPv4 socket",
        ),
        (
            GOOD.replace('rover = "0"', 'rover = "[::1]:0"'),
            "destinations.base.address: an IPv4 address, and via = 'rover' is an IPv6 socket",
        ),
        (
            GOOD.replace('to = ["base"]', 'to = ["board"]'),
            r"routes\[0\].to: no destination 'board' \(destinations: base\)",
        ),
        (
            GOOD + FAILSAFE.replace('to = ["base"]', 'to = ["board"]'),
            r"failsafes\[0\].to: no destination 'board'",
        ),
        (GOOD + FAILSAFE + "message = 5\n", r"failsafes\[0\].message must be a table"),
        (
            GOOD + FAILSAFE + FAILSAFE.replace("rate = 10", "rate = 5"),
            r"failsafes\[1\].kind: drive_motor has a failsafe already \(failsafes\[0\]\)",
        ),
        (GOOD + FAILSAFE.replace("timeout = 0.3\n", ""), r"failsafes\[0\].timeout is missing"),
        (
            GOOD + FAILSAFE.replace("rate = 10", "rate = 1e9"),
            r"rate must be a number of Hz from 0\.01 to 500 \(the relay polls every 2 ms\)",
        ),
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

    readme = (REPO / "README.md").read_text()
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
    assert config.sources == {  # as an IPv4 socket and a dual-stack one report it
        ("192.168.1.20", 6000): "jetson",
        ("::ffff:192.168.1.20", 6000): "jetson",
    }
    erc_codec.runtime.Router(
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


def test_a_configuration_over_a_mebibyte_is_refused_unread(tmp_path: Path) -> None:
    config = tmp_path / "relay.toml"
    config.write_text(GOOD + "#" * (1 << 20) + "\n")
    done = subprocess.run(
        [sys.executable, "-m", "erc_codec", "relay", str(config)],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert done.returncode == 2
    assert done.stderr == f"Error: {config}: larger than 1 MiB: not a relay configuration\n"


def interface_address() -> str:
    """One of this host's IPv4 addresses that is not 127.0.0.1 (an interface's, if it has one)."""
    import fcntl
    import struct

    for _, name in socket.if_nameindex():
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            try:
                answer = fcntl.ioctl(probe, 0x8915, struct.pack("256s", name.encode()[:15]))
            except OSError:  # no IPv4 address on it
                continue
        address = socket.inet_ntoa(answer[20:24])
        if not address.startswith("127."):
            return address
    return "127.0.0.2"  # loopback only: still this host's, under another spelling


def test_a_wildcard_listener_refuses_a_destination_at_an_interface_address(
    tmp_path: Path,
) -> None:
    config = tmp_path / "relay.toml"
    address = interface_address()
    config.write_text(
        GOOD.replace('rover = "0"', 'rover = "0.0.0.0:5000"').replace(
            "127.0.0.1:9", f"{address}:5000"
        )
    )
    done = subprocess.run(
        [sys.executable, "-m", "erc_codec", "relay", str(config)],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert done.returncode == 2, done.stderr
    assert "destinations.base.address: the relay listens there itself" in done.stderr


# -- the failsafe whatever its output does -----------------------------------------------------

DRIVE = CODEC.message_class("drive_motor")
BRAKE = bytes.fromhex("4a 00")  # the all-zero drive command, exact
RATE, TIMEOUT = 20, 0.3


def braking_config(tmp_path: Path, board: socket.socket, relay: str) -> Path:
    """A relay that forwards drive commands to ``board`` and brakes it after TIMEOUT s."""
    config = tmp_path / "relay.toml"
    config.write_text(
        f"""
[listen]
rover = "0"
[destinations]
board = {{ address = "127.0.0.1:{board.getsockname()[1]}", form = "exact" }}
[[routes]]
to = ["board"]
kinds = ["drive_motor"]
[[failsafes]]
kind = "drive_motor"
to = ["board"]
rate = {RATE}
timeout = {TIMEOUT}
[relay]
{relay}
"""
    )
    return config


def drive_and_go_quiet(port: int, board: socket.socket, commands: int) -> float:
    """Send ``commands`` drive commands at 20 Hz, each received by the board before the next;
    then be silent: the seconds from the last command to the first brake datagram."""
    go = CODEC.encode(DRIVE(distance_to_go=1.5), "exact")
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as base:
        for _ in range(commands):
            base.sendto(go, ("127.0.0.1", port))
            while (got := board.recv(4096)) == BRAKE:  # brakes from before the first command
                pass
            assert got == go
            time.sleep(1 / 20)
        quiet = time.monotonic()
        assert board.recv(4096) == BRAKE
        return time.monotonic() - quiet


def brakes_for(board: socket.socket, seconds: float) -> int:
    """Brake datagrams the board receives in the next ``seconds``."""
    count, end = 0, time.monotonic() + seconds
    while (left := end - time.monotonic()) > 0:
        board.settimeout(left)
        try:
            assert board.recv(4096) == BRAKE
        except TimeoutError:
            break
        count += 1
    board.settimeout(10)
    return count


def test_a_stopped_stdout_reader_holds_up_neither_routing_nor_the_brake(tmp_path: Path) -> None:
    """Status lines every 10 ms to a stdout nobody reads for 5 s: the pipe fills within a second
    or two, then the relay's queue, and the lines after that are dropped and counted."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as board:
        board.bind(("127.0.0.1", 0))
        board.settimeout(10)
        relay = run_relay(braking_config(tmp_path, board, 'status = "json"\ninterval = 0.01'))
        try:
            assert relay.stderr is not None
            assert relay.stdout is not None
            port = int(relay.stderr.readline().rsplit(":", 1)[1])
            errors: list[str] = []
            drain = threading.Thread(target=lambda: errors.extend(relay.stderr or ()))
            drain.start()
            time.sleep(2.0)  # the pipe is full by now
            gap = drive_and_go_quiet(port, board, commands=20)
            assert gap < TIMEOUT + 1 / RATE + 0.25, gap
            assert brakes_for(board, 1.0) >= RATE // 2
            time.sleep(1.0)  # 5 s with nobody reading
            dropped = 0
            while not dropped:  # read again: the lines that found no room were counted
                dropped = json.loads(relay.stdout.readline())["output"]["stdout"]["dropped"]
        finally:
            relay.send_signal(signal.SIGTERM)
            assert relay.stdout is not None
            relay.stdout.read()  # stderr is the drain's
            relay.wait(10)
            drain.join(10)
            relay.stdout.close()
            assert relay.stderr is not None
            relay.stderr.close()
        sent = brakes_for(board, 0.2)  # what was still on its way to the board
    counters = json.loads("".join(errors).rsplit("counters: ", 1)[1])
    assert counters["routes"]["board"]["forwarded"] == 20
    assert counters["listen"]["rover"]["received"] == 20
    assert counters["dropped"] == {}
    assert counters["errors"] == {}
    assert counters["failsafe"]["engaged"]["drive_motor"] >= 2  # at the start, and after
    assert counters["routes"]["board"]["failsafe"] >= RATE // 2 + sent


def test_a_closed_stderr_leaves_the_brake_braking(tmp_path: Path) -> None:
    """`erc-codec relay cfg.toml 2>&1 | head -1`: the first line read, the reader gone."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as board:
        board.bind(("127.0.0.1", 0))
        board.settimeout(10)
        relay = run_relay(braking_config(tmp_path, board, 'status = "json"\ninterval = 0.1'))
        try:
            assert relay.stderr is not None
            assert relay.stdout is not None
            port = int(relay.stderr.readline().rsplit(":", 1)[1])
            relay.stderr.close()
            for _ in range(2):  # engaged, released, engaged again: each line a broken pipe
                gap = drive_and_go_quiet(port, board, commands=10)
                assert gap < TIMEOUT + 1 / RATE + 0.25, gap
                assert brakes_for(board, 0.5) >= RATE // 4
            for _ in range(100):  # the status lines, 10 a second, until one has seen it all
                metrics = json.loads(relay.stdout.readline())
                if metrics["failsafe"]["released"].get("drive_motor", 0) >= 2:
                    break
        finally:
            relay.send_signal(signal.SIGTERM)
            relay.communicate(timeout=10)
    assert relay.returncode == 0
    assert metrics["output"]["stderr"]["closed"] == "Broken pipe"
    assert metrics["output"]["stderr"]["dropped"] >= 1
    assert metrics["routes"]["board"]["forwarded"] == 20
    assert metrics["errors"] == {}


def test_a_datagram_from_the_relays_own_address_is_dropped_and_counted(tmp_path: Path) -> None:
    """However a destination leads back to the relay, what comes from its own socket goes
    nowhere: here a datagram whose source is the relay's own address and port."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as board:
        board.bind(("127.0.0.1", 0))
        board.settimeout(10)
        config = braking_config(tmp_path, board, 'status = "none"')
        config.write_text(config.read_text().replace('kinds = ["drive_motor"]\n', ""))
        relay = run_relay(config)
        try:
            assert relay.stderr is not None
            port = int(relay.stderr.readline().rsplit(":", 1)[1])
            go = CODEC.encode(DRIVE(distance_to_go=1.5), "exact")
            header = struct.pack("!HHHH", port, port, 8 + len(go), 0)  # no UDP checksum
            with socket.socket(socket.AF_INET, socket.SOCK_RAW, socket.IPPROTO_UDP) as raw:
                raw.sendto(header + go, ("127.0.0.1", 0))  # from 127.0.0.1:port, the relay's
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as base:
                base.sendto(go, ("127.0.0.1", port))
            while (got := board.recv(4096)) == BRAKE:
                pass
            assert got == go  # the second, from the base station
        finally:
            relay.send_signal(signal.SIGTERM)
            _, errors = relay.communicate(timeout=10)
    counters = json.loads(errors.rsplit("counters: ", 1)[1])
    assert counters["listen"]["rover"]["received"] == 2
    assert counters["dropped"] == {"looped": 1}
    assert counters["routes"]["board"]["forwarded"] == 1


def test_a_route_around_the_failsafes_sources_is_warned_at_the_start(tmp_path: Path) -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as board:
        board.bind(("127.0.0.1", 0))
        config = braking_config(tmp_path, board, 'status = "none"')
        config.write_text(
            config.read_text()
            .replace("timeout = 0.3\n", 'timeout = 0.3\nsources = ["ground"]\n')
            .replace('rover = "0"\n', 'rover = "0"\nground = "0"\n')
        )
        relay = run_relay(config)
        try:
            assert relay.stderr is not None
            warning = relay.stderr.readline()
            assert relay.stderr.readline().startswith("relaying: listening on")
        finally:
            relay.send_signal(signal.SIGTERM)
            relay.communicate(timeout=10)
    assert warning == (
        f"{config}: warning: routes[0] delivers drive_motor to board from senders "
        "failsafes[0].sources does not name: while the brake is engaged, their commands reach "
        "it between the brake datagrams\n"
    )


def test_failsafe_events_are_counted_not_kept(tmp_path: Path) -> None:
    """A sender advertising 1 ms makes the brake engage and release between every command: a
    relay that kept its events grew with them."""
    from erc_codec.cli._lines import LineStream
    from erc_codec.cli._relay import _Relay
    from erc_codec.cli._relayconfig import read_config

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as board:
        board.bind(("127.0.0.1", 0))
        config = read_config(braking_config(tmp_path, board, 'status = "none"'), CODEC)
    with open(os.devnull, "w") as sink:
        stream = LineStream(sink.fileno(), "null")
        session = _Relay(CODEC, config, stream, stream)
        go = CODEC.encode(DRIVE(distance_to_go=1.0), "exact", timeout=1)
        tracemalloc.start()
        try:
            for cycle in range(20_000):
                now = cycle * 0.01
                session.router.route(go, "rover", now)
                session.router.poll(now + 0.005)  # 5 ms of silence: engaged
                if cycle == 1_000:
                    before = tracemalloc.get_traced_memory()[0]
            grown = tracemalloc.get_traced_memory()[0] - before
        finally:
            tracemalloc.stop()
            stream.close(1.0)
    stats = session.router.stats()
    assert stats.engaged["drive_motor"] == stats.released["drive_motor"] + 1 == 20_000
    assert grown < 50_000, grown


def test_a_dual_stack_listener_brakes_an_ipv4_board(tmp_path: Path) -> None:
    """Listening on [::], the relay sends to an IPv4 destination as its IPv4-mapped address."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as board:
        board.bind(("127.0.0.1", 0))
        board.settimeout(10)
        config = braking_config(tmp_path, board, 'status = "none"')
        config.write_text(config.read_text().replace('rover = "0"', 'rover = "[::]:0"'))
        relay = run_relay(config)
        try:
            assert relay.stderr is not None
            port = int(relay.stderr.readline().rsplit(":", 1)[1])
            gap = drive_and_go_quiet(port, board, commands=3)
            assert gap < TIMEOUT + 1 / RATE + 0.25, gap
            assert brakes_for(board, 0.5) >= RATE // 4
        finally:
            relay.send_signal(signal.SIGTERM)
            _, errors = relay.communicate(timeout=10)
    counters = json.loads(errors.rsplit("counters: ", 1)[1])
    assert counters["routes"]["board"]["forwarded"] == 3
    assert (counters["errors"], counters["listen"]["rover"]["send_errors"]) == ({}, 0)


def test_lines_still_queued_at_the_end_are_counted(tmp_path: Path) -> None:
    """A stdout pipe of one page that nobody reads until the relay has stopped: the counters
    say every status line it wrote, and every other one as dropped, the queued ones too."""
    import fcntl

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as board:
        board.bind(("127.0.0.1", 0))
        config = braking_config(tmp_path, board, 'status = "json"\ninterval = 0.01')
        relay = run_relay(config)
        assert relay.stdout is not None
        assert relay.stderr is not None
        fcntl.fcntl(relay.stdout, 1031, 4096)  # F_SETPIPE_SZ: a page, some six status lines
        relay.stderr.readline()
        time.sleep(1.0)  # some hundred status lines, a few of which fit
        relay.send_signal(signal.SIGTERM)
        errors = relay.stderr.read()
        relay.wait(10)
        lines = relay.stdout.read().splitlines()
        relay.stdout.close()
        relay.stderr.close()
    output = json.loads(errors.rsplit("counters: ", 1)[1])["output"]["stdout"]
    assert output["written"] == len(lines) > 0
    assert output["dropped"] > 0
    assert output["closed"] is None


def own_link_local() -> str | None:
    """One of this host's link-local IPv6 addresses with its interface (``fe80::1%eth0``)."""
    try:
        table = Path("/proc/net/if_inet6").read_text().splitlines()
    except OSError:
        return None
    for row in table:
        digits, _, _, scope, _, name = row.split()
        if scope == "20":  # link scope
            return f"{ipaddress.IPv6Address(int(digits, 16))}%{name}"
    return None


def test_a_link_local_address_of_this_host_is_its_own_whether_scoped_by_name_or_index() -> None:
    assert canonical("fe80::1%lo") == canonical("fe80::1%1") == "fe80::1%1"
    assert canonical("::ffff:127.0.0.1") == "127.0.0.1"
    assert all(map(is_local, ("127.0.0.1", "::ffff:127.0.0.1", "::")))
    assert not is_local("192.0.2.1")  # a documentation address, nobody's
    link_local = own_link_local()
    if link_local is not None:  # bound with its scope's index: bind refuses it as text
        assert is_local(link_local)
        assert receives(("::", 5000, 0, 0), (link_local, 5000, 0, 0))
        host, _, scope = link_local.partition("%")  # as getaddrinfo gives it: the scope apart
        assert receives(("::", 5000, 0, 0), (host, 5000, 0, socket.if_nametoindex(scope)))
        assert not receives(("::", 5000, 0, 0), (host, 5000, 0, 0))  # no scope: not bindable
