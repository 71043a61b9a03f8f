"""``erc-codec listen --format json`` under a steady UDP stream: is every datagram shown or counted?

    python benchmarks/bench_listen.py [--rates 5000,10000,20000] [--seconds 3] [--mix] [--quick]

For each rate, a listener (the command, as a user runs it, its output to a file) and a sender
process (datagrams paced in 1 ms bursts on 127.0.0.1) run for the given seconds; once the
listener's output has stopped growing (it has read what was queued) it is stopped with SIGINT
and its ``counters:`` line read. Printed per rate: datagrams
sent, received by listen, shown (JSON lines written), dropped by listen (its own counters),
dropped by the kernel as listen reports it (``kernel_dropped``; "-" from a listen that does not
report it), and the system-wide ``Udp: RcvbufErrors`` delta of ``/proc/net/snmp`` (every socket's
receive-buffer drops on this machine during the run: a cross-check, and an upper bound, since
other processes may drop too). Nothing is lost silently when sent = received + kernel dropped +
unread (still queued when listen stopped).
Target (security issue, "every loss counted"): at 20,000 datagrams/s nothing lost at all.

Whether listen keeps up depends on the CPU it gets, which on a shared machine is whatever the
others leave: so the CPU time listen spent per datagram received (``/proc/PID/stat``, Linux) is
printed too, with the rate that would fill one CPU (``1 / that``): the figure to compare between
two versions, as it hardly depends on the load.

The datagrams are the README's ``send`` example (a drive_motor, 7 bytes); with
``--mix``, one random payload of every kind in turn (``bench_codec.corpus``), whose conversion
to JSON costs far more. The machine is shared and noisy: repeat a run before believing it.
Exit status 1 when a rate's datagrams are not all accounted for (sent != received + kernel
dropped + unread), or, at the target rate, when any was lost.
"""

import argparse
import json
import os
import random
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from tempfile import TemporaryDirectory
from typing import NamedTuple

from bench_codec import corpus

import erc_codec

_TARGET_RATE = 20_000
_BURST = 0.001  # seconds between two bursts of the sender


class Result(NamedTuple):
    sent: int
    received: int  # by listen
    shown: int  # JSON lines written
    dropped: int  # listen's own counters
    kernel: int | None  # kernel_dropped, as listen reports it (None: not reported)
    unread: int | None  # still queued when listen stopped (None: not reported)
    system: int | None  # the system's RcvbufErrors delta
    buffer: int | None  # the receive buffer granted, as listen reports it
    cpu: float | None  # listen's CPU seconds while the datagrams came and were read


def cpu_seconds(pid: int) -> float | None:
    """The user and system CPU time of process ``pid`` (Linux's ``/proc``), None elsewhere."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def datagrams(mix: bool) -> list[bytes]:
    codec = erc_codec.Codec.default()
    if mix:
        full, _ = corpus(codec, random.Random(20261122))
        return [codec.encode(envelope) for envelope in full]
    motor = codec.message_class("DrivingBoardMotorMessage")
    return [codec.encode(motor(distance_to_go=1.5))]


def send(port: int, rate: int, seconds: float, mix: bool) -> None:
    """The sender process: ``rate`` datagrams a second for ``seconds``, in 1 ms bursts."""
    data = datagrams(mix)
    total = round(rate * seconds)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.connect(("127.0.0.1", port))
        start = time.perf_counter()
        sent = 0
        while sent < total:
            due = min(total, round((time.perf_counter() - start) * rate) + 1)
            while sent < due:
                try:
                    sock.send(data[sent % len(data)])
                except ConnectionRefusedError:  # an ICMP error of an earlier datagram
                    continue
                sent += 1
            time.sleep(_BURST)
    print(sent)


def rcvbuf_errors() -> int | None:
    """The system's ``Udp: RcvbufErrors`` (``/proc/net/snmp``), None where there is none."""
    try:
        lines = Path("/proc/net/snmp").read_text().splitlines()
    except OSError:
        return None
    names, values = (line.split()[1:] for line in lines if line.startswith("Udp:"))
    return int(dict(zip(names, values, strict=True))["RcvbufErrors"])


def settled(output: Path, quiet: float = 0.5, longest: float = 20.0) -> None:
    """Wait until ``output`` has not grown for ``quiet`` seconds (``longest`` at most)."""
    deadline = time.monotonic() + longest
    size, since = -1, time.monotonic()
    while time.monotonic() < deadline:
        now = output.stat().st_size
        if now != size:
            size, since = now, time.monotonic()
        elif time.monotonic() - since >= quiet:
            return
        time.sleep(0.05)


def run(rate: int, seconds: float, mix: bool, folder: Path) -> Result:
    shown = folder / "shown.jsonl"
    with shown.open("wb") as out:
        listener = subprocess.Popen(
            [sys.executable, "-m", "erc_codec", "listen", "127.0.0.1:0", "--format", "json"],
            stdout=out,
            stderr=subprocess.PIPE,
            text=True,
        )
        assert listener.stderr is not None
        first = listener.stderr.readline()
        assert first.startswith("listening on 127.0.0.1:"), first
        port = int(first.rsplit(":", 1)[1])
        before = rcvbuf_errors()
        started = cpu_seconds(listener.pid)
        me = [sys.executable, __file__, "--send", str(port), str(rate), str(seconds)]
        sender = subprocess.run(
            [*me, *(["--mix"] if mix else [])], capture_output=True, text=True, check=True
        )
        settled(shown)  # what is queued is read and shown
        ended = cpu_seconds(listener.pid)
        listener.send_signal(signal.SIGINT)
        _, err = listener.communicate(timeout=60)
        after = rcvbuf_errors()
    counters = json.loads(err.strip().splitlines()[-1].removeprefix("counters: "))
    with shown.open("rb") as lines:
        written = sum(1 for _ in lines)
    return Result(
        int(sender.stdout),
        counters["received"],
        written,
        counters["dropped"],
        counters.get("kernel_dropped"),
        counters.get("unread"),
        None if before is None or after is None else after - before,
        counters.get("receive_buffer"),
        None if started is None or ended is None else ended - started,
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rates", default="5000,10000,20000", help="datagrams per second")
    parser.add_argument("--seconds", type=float, default=3.0, help="per rate")
    parser.add_argument("--mix", action="store_true", help="every payload kind, not one")
    parser.add_argument("--quick", action="store_true", help="one second at 5,000/s (a smoke run)")
    parser.add_argument("--send", nargs=3, metavar=("PORT", "RATE", "SECONDS"), help="internal")
    args = parser.parse_args()
    if args.send:
        send(int(args.send[0]), int(args.send[1]), float(args.send[2]), args.mix)
        return 0
    rates = [5000] if args.quick else [int(rate) for rate in args.rates.split(",")]
    seconds = 1.0 if args.quick else args.seconds
    print(f"datagrams: {'one of every kind' if args.mix else 'drive_motor, 7 bytes'}")
    print(
        "rate/s    sent  received     shown  dropped  kernel dropped  unread  system    buffer"
        "  CPU µs/datagram  (1 CPU: /s)"
    )
    ok = True
    with TemporaryDirectory() as folder:
        for rate in rates:
            r = run(rate, seconds, args.mix, Path(folder))
            kernel, unread, system, buffer = ("-" if n is None else n for n in r[4:8])
            each = r.cpu / r.received if r.cpu is not None and r.received else None
            cost = "-" if each is None else f"{each * 1e6:.1f}"
            capacity = "-" if not each else f"{1 / each:,.0f}"
            print(
                f"{rate:>6} {r.sent:>7} {r.received:>9} {r.shown:>9} {r.dropped:>8}"
                f" {kernel:>15} {unread:>7} {system:>7} {buffer:>9} {cost:>16} {capacity:>12}"
            )
            counted = r.kernel is not None and r.received + r.kernel + (r.unread or 0) == r.sent
            ok = ok and counted and not (rate >= _TARGET_RATE and r.shown != r.sent)
    target = f"none lost at {_TARGET_RATE}/s" if _TARGET_RATE in rates else "(target rate not run)"
    print(f"every datagram accounted for, {target}: {'yes' if ok else 'NO'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
