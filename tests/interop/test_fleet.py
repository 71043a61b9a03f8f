"""The fleet in a box: a nanopb board and a prost base station, with the relay between them.

The board (tests/fleet/board.c, built against Debian's nanopb) sends its diagnostics stripped, as
the fleet's boards do, and decodes with plain ``pb_decode`` on the exact length; the base station
(tests/fleet/basestation, Rust with Debian's prost 0.11, built offline) decodes ``&buf[..len]``
and sends drive commands advertising a 300 ms timeout. Neither can read what the other's side
sends as is; the relay (``erc-codec relay``, a subprocess, on 127.0.0.1) hands each one the exact
form, and brakes the board (a zero drive command) when the base station's commands stop.
Without gcc, nanopb or cargo and prost the tests skip, unless ERC_REQUIRE_INTEROP=1 (CI).
"""

import json
import os
import queue
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from conftest import PROTO
from fleet_support import cargo_build, cargo_missing, gcc_build, nanopb_missing

import erc_codec

pytestmark = pytest.mark.interop

CODEC = erc_codec.Codec.default()
DIAGNOSTICS = 40  # the board sends this many, every PERIOD_MS
PERIOD_MS = 20
TIMEOUT = 0.3  # the relay's failsafe timeout for drive_motor, as the base station advertises
DRIVE_PERIOD = 0.05  # the base station's command period (src/main.rs)
BRAKE_RATE = 20  # failsafe datagrams a second


def _require(missing: str, what: str) -> None:
    if missing:
        reason = f"the fleet-in-a-box tests need {missing} ({what})"
        if os.environ.get("ERC_REQUIRE_INTEROP") == "1":
            pytest.fail(f"ERC_REQUIRE_INTEROP=1 but {reason}")
        pytest.skip(reason)


@pytest.fixture(scope="session")
def board_program(tmp_path_factory: pytest.TempPathFactory) -> Path:
    missing, generator = nanopb_missing()
    _require(missing, "apt-get install gcc nanopb libnanopb-dev")
    assert generator is not None
    return gcc_build(PROTO, generator, tmp_path_factory.mktemp("board"))


@pytest.fixture(scope="session")
def basestation_program(tmp_path_factory: pytest.TempPathFactory) -> Path:
    _require(cargo_missing(), "apt-get install cargo librust-prost-dev")
    return cargo_build(CODEC, tmp_path_factory.mktemp("basestation"))


class Peer:
    """A running program whose stdout lines are collected, each with the time it was read."""

    def __init__(self, command: list[str]) -> None:
        self.process = subprocess.Popen(
            command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1
        )
        self.lines: queue.Queue[tuple[float, str]] = queue.Queue()
        self.seen: list[tuple[float, str]] = []
        threading.Thread(target=self._read, daemon=True).start()
        self.port = int(self.expect("PORT ").split()[1])

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            self.lines.put((time.monotonic(), line.rstrip("\n")))

    def say(self, line: str) -> None:
        assert self.process.stdin is not None
        self.process.stdin.write(line + "\n")
        self.process.stdin.flush()

    def expect(self, prefix: str, timeout: float = 10.0) -> str:
        deadline = time.monotonic() + timeout
        while True:
            at, line = self.lines.get(timeout=max(deadline - time.monotonic(), 0.001))
            self.seen.append((at, line))
            if line.startswith(prefix):
                return line

    def drain(self, seconds: float) -> None:
        """Collect what arrives for ``seconds``."""
        deadline = time.monotonic() + seconds
        while (left := deadline - time.monotonic()) > 0:
            try:
                self.seen.append(self.lines.get(timeout=left))
            except queue.Empty:
                return

    def close(self) -> None:
        if self.process.poll() is None:
            self.say("QUIT")
        self.drain(0.2)
        self.process.wait(timeout=10)
        assert self.process.stdout is not None
        assert self.process.stdin is not None
        self.process.stdout.close()
        self.process.stdin.close()


CONFIG = """
[listen]
rover = "127.0.0.1:0"      # the boards send here
ground = "127.0.0.1:0"     # the base station sends here

[destinations]
board = {{ address = "127.0.0.1:{board}", form = "exact", via = "rover" }}
base = {{ address = "127.0.0.1:{base}", form = "exact", via = "ground" }}

[[routes]]
to = ["base"]
sources = ["rover"]

[[routes]]
to = ["board"]
kinds = ["drive_motor"]
sources = ["ground"]

[[failsafes]]
kind = "drive_motor"
message = {{}}               # distance 0, radius 0: "stay where you are"
to = ["board"]
rate = {rate}
timeout = {timeout}

[relay]
status = "json"
interval = 0.2
"""


@pytest.fixture
def fleet(
    board_program: Path, basestation_program: Path, tmp_path: Path
) -> Iterator[tuple[Peer, Peer, subprocess.Popen[str]]]:
    board = Peer([str(board_program), str(DIAGNOSTICS), str(PERIOD_MS)])
    base = Peer([str(basestation_program)])
    config = tmp_path / "relay.toml"
    config.write_text(
        CONFIG.format(board=board.port, base=base.port, rate=BRAKE_RATE, timeout=TIMEOUT)
    )
    relay = subprocess.Popen(
        [sys.executable, "-m", "erc_codec", "relay", str(config)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        yield board, base, relay
    finally:
        for peer in (board, base):
            peer.close()
        if relay.poll() is None:
            relay.kill()
        relay.communicate(timeout=10)


def relay_ports(relay: subprocess.Popen[str]) -> dict[str, int]:
    assert relay.stderr is not None
    line = relay.stderr.readline()
    assert line.startswith("relaying: listening on "), line
    return {
        name: int(address.rsplit(":", 1)[1])
        for name, address in (
            part.split(" ") for part in line.removeprefix("relaying: listening on ").split(", ")
        )
    }


def test_the_fleet_needs_the_relay_to_understand_itself(
    board_program: Path, basestation_program: Path
) -> None:
    """Sent as is, the board's stripped diagnostics are errors to prost (the control)."""
    base = Peer([str(basestation_program)])
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            for data in (bytes.fromhex("42"), CODEC.encode(CODEC.message_class("drive_diag")())):
                sock.sendto(data, ("127.0.0.1", base.port))
        first, second = base.expect("ERR"), base.expect("ERR")
        assert first == second
        assert any(error in first for error in ("invalid varint", "buffer underflow")), first
        base.say("RELAY 9")  # and it decodes the exact form
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            sock.sendto(
                CODEC.encode(CODEC.message_class("drive_diag")(), "exact"), ("127.0.0.1", base.port)
            )
            sock.sendto(
                CODEC.encode(CODEC.message_class("drive_diag")(), "pad"), ("127.0.0.1", base.port)
            )
        assert base.expect("OK").startswith("OK DriveDiag")
        assert "invalid tag value: 0" in base.expect("ERR")
    finally:
        base.close()


def test_every_datagram_arrives_decodable_and_the_failsafe_brakes(
    fleet: tuple[Peer, Peer, "subprocess.Popen[str]"],
) -> None:
    board, base, relay = fleet
    ports = relay_ports(relay)
    base.say(f"RELAY {ports['ground']}")
    base.say("DRIVE on")
    board.say(f"RELAY {ports['rover']}")

    # 1. Every diagnostic, stripped by the board, reaches prost decodable; commands reach the
    # board, advertising their timeout.
    sent = [board.expect("SENT ").split()[2] for _ in range(DIAGNOSTICS)]
    assert "42" in sent  # an all-zero payload, stripped to its tag
    assert any(data.startswith("5205") and len(data) < 14 for data in sent)  # a zero-ending float
    received = [base.expect("OK ") for _ in range(DIAGNOSTICS)]
    assert all(" DriveDiag(" in line or " DriveProgress(" in line for line in received)
    assert not [line for _, line in base.seen if line.startswith("ERR")]
    assert board.expect("CMD 9 ") == "CMD 9 1.5 0 300"

    # 2. The base station stops driving: the board is braked within timeout + one period.
    base.say("DRIVE off")
    stopped = time.monotonic()
    board.drain(TIMEOUT + 0.6)
    commands = [(at, line) for at, line in board.seen if line.startswith("CMD 9 ")]
    last_drive = max(at for at, line in commands if line == "CMD 9 1.5 0 300")
    # The relay's start counts as a drive command: braked, too, if the first came later than the
    # timeout (a slow start of the base station); those brakes precede this silence.
    early = [at for at, line in commands if line == "CMD 9 0 0 0" and at < stopped]
    brakes = [at for at, line in commands if line == "CMD 9 0 0 0" and at >= stopped]
    assert brakes, commands[-5:]
    assert last_drive <= stopped + DRIVE_PERIOD + 0.05
    assert TIMEOUT - 0.01 <= brakes[0] - last_drive <= TIMEOUT + 1 / BRAKE_RATE + 0.05
    assert len(brakes) >= 0.4 * BRAKE_RATE  # repeated at its rate while silent (0.6 s)
    assert not [line for _, line in board.seen if line.startswith("ERR")]

    # 3. Driving resumes: the brake stops.
    base.say("DRIVE on")
    resumed = time.monotonic()
    board.drain(0.5)
    after = [(at, line) for at, line in board.seen if at > resumed and line.startswith("CMD 9 ")]
    first_drive = min(at for at, line in after if line == "CMD 9 1.5 0 300")
    assert not [at for at, line in after if line == "CMD 9 0 0 0" and at > first_drive + 0.02]

    # 4. The counters, on SIGTERM: every diagnostic forwarded, nothing dropped.
    relay.send_signal(signal.SIGTERM)
    _, errors = relay.communicate(timeout=10)
    assert relay.returncode == 0, errors
    assert "failsafe drive_motor engaged" in errors
    assert "failsafe drive_motor released" in errors
    counters = json.loads(errors.rsplit("counters: ", 1)[1])
    assert counters["routes"]["base"]["forwarded"] == DIAGNOSTICS
    assert counters["dropped"] == {}
    times = {"drive_motor": 2 if early else 1}
    assert counters["failsafe"] == {"engaged": times, "released": times}
    assert counters["routes"]["board"]["failsafe"] == len(
        [1 for _, line in board.seen if line == "CMD 9 0 0 0"]
    )
    assert counters["listen"]["rover"]["kernel_dropped"] == 0
