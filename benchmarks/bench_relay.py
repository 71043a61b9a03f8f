"""``erc-codec relay`` against a bare asyncio forwarder on the same loopback, side by side.

    python benchmarks/bench_relay.py [--repeat 3] [--quick]

Both forwarders run as subprocesses on 127.0.0.1: the relay as a user runs it (one route, every
datagram to one ``exact`` destination), and the bare forwarder (``asyncio`` datagram protocol:
each datagram received is sent on unchanged). The datagrams are board diagnostics as the boards
send them, stripped (``bench_codec.corpus``: one random payload of every kind, and ones whose
encoding ended in zeros), so the relay decodes, restores and re-sends each one.

Measured, each ``--repeat`` times, the contenders interleaved:
- throughput: a sender keeps 64 datagrams in flight through the forwarder and counts what comes
  out (no drops at that depth): datagrams a second. Target: relay >= 0.7x bare.
- added latency at 1,000 datagrams/s: each datagram's one-way time (send to receipt, both in this
  process) through the relay, against the same stream through the bare forwarder (one process
  hop too: the machine's scheduling delays are in both): p99 relay minus p99 bare. Target:
  < 1 ms. Also shown: the stream sent straight to the receiver, and the relay's own figure
  (read to send, its ``latency_us`` p99).
- losses under a flood (datagrams sent as fast as one process can, for ``--flood`` seconds):
  sent = received + what the relay counted (dropped, and its socket's kernel drops) + what the
  receiver's socket lost, from ``/proc/net/snmp`` ``Udp: RcvbufErrors`` (system-wide: an upper
  bound on a shared machine). Target: nothing lost that is not counted.
Exit status 1 when a target is missed (the median throughput ratio, the median added p99).
"""

import argparse
import asyncio
import contextlib
import json
import os
import random
import select
import signal
import socket
import statistics
import subprocess
import sys
import time
from pathlib import Path
from tempfile import TemporaryDirectory
from typing import Any

from bench_codec import corpus  # beside this script

import erc_codec

_IN_FLIGHT = 64
_RATIO_TARGET = 0.7
_LATENCY_TARGET_MS = 1.0


def datagrams(codec: erc_codec.Codec) -> list[bytes]:
    full, zero_ended = corpus(codec, random.Random(20261202))
    return [m.SerializeToString().rstrip(b"\0") for m in full + zero_ended]


def stamped(codec: erc_codec.Codec, seq: int) -> bytes:
    """A stripped rover_localization stamped with its sequence number, ending in zeros."""
    message = codec.message_class("rover_localization")(timestamp_ms=seq, x=1e-40)
    return codec.encode(message, "strip")


# -- the contenders ----------------------------------------------------------------------------


def bare_forwarder(target_port: int) -> None:
    """Run in a subprocess: receive on a free port, send each datagram on unchanged."""

    class Forward(asyncio.DatagramProtocol):
        def connection_made(self, transport: Any) -> None:
            self.transport = transport

        def datagram_received(self, data: bytes, addr: Any) -> None:
            self.transport.sendto(data, ("127.0.0.1", target_port))

    async def main() -> None:
        loop = asyncio.get_running_loop()
        transport, _ = await loop.create_datagram_endpoint(Forward, local_addr=("127.0.0.1", 0))
        print(f"relaying: listening on bare 127.0.0.1:{transport.get_extra_info('sockname')[1]}")
        sys.stdout.flush()
        stop: asyncio.Future[None] = loop.create_future()
        loop.add_signal_handler(signal.SIGTERM, stop.cancel)
        with contextlib.suppress(asyncio.CancelledError):
            await stop

    asyncio.run(main())


class Forwarder:
    """A running contender: its listening port; ``stop()`` returns its counters (relay)."""

    def __init__(self, kind: str, target_port: int, folder: Path) -> None:
        self.kind = kind
        if kind == "relay":
            config = folder / "relay.toml"
            config.write_text(
                '[listen]\nin = "127.0.0.1:0"\n\n[destinations]\n'
                f'sink = {{ address = "127.0.0.1:{target_port}", form = "exact" }}\n\n'
                '[[routes]]\nto = ["sink"]\n\n[relay]\nstatus = "none"\n'
            )
            command = [sys.executable, "-m", "erc_codec", "relay", str(config)]
            self.process = subprocess.Popen(
                command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
            )
            line = self.process.stderr.readline()  # type: ignore[union-attr]
        else:
            command = [sys.executable, __file__, "--bare-forwarder", str(target_port)]
            self.process = subprocess.Popen(
                command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
            )
            line = self.process.stdout.readline()  # type: ignore[union-attr]
        assert line.startswith("relaying: listening on "), line
        self.port = int(line.rsplit(":", 1)[1])

    def stop(self) -> dict[str, Any]:
        self.process.send_signal(signal.SIGTERM)
        _, errors = self.process.communicate(timeout=30)
        if self.kind != "relay":
            return {}
        counters: dict[str, Any] = json.loads(errors.rsplit("counters: ", 1)[1])
        return counters


# -- measurements ------------------------------------------------------------------------------


def receiver() -> socket.socket:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
    sock.bind(("127.0.0.1", 0))
    return sock


def throughput(port: int, sink: socket.socket, stream: list[bytes], count: int) -> float:
    """Datagrams a second through the forwarder on ``port``, ``_IN_FLIGHT`` at a time."""
    out = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.settimeout(2.0)
    target = ("127.0.0.1", port)
    sent = received = 0
    start = time.perf_counter()
    while sent < min(_IN_FLIGHT, count):
        out.sendto(stream[sent % len(stream)], target)
        sent += 1
    try:
        while received < count:
            sink.recv(4096)
            received += 1
            if sent < count:
                out.sendto(stream[sent % len(stream)], target)
                sent += 1
    except TimeoutError:
        pass  # lost: counted below as a shortfall
    elapsed = time.perf_counter() - start
    out.close()
    return received / elapsed


def latencies(
    codec: erc_codec.Codec, port: int, sink: socket.socket, count: int, rate: float, first: int
) -> list[float]:
    """One-way times in ms of ``count`` stamped datagrams (numbered from ``first``) sent at
    ``rate`` to ``port``. Between sends the sender waits in ``select`` (not spinning: on a
    shared machine a spinning sender takes the CPU the forwarder needs)."""
    out = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.setblocking(False)
    target = ("127.0.0.1", port)
    sent_at: dict[int, float] = {}
    arrived: dict[int, float] = {}
    start = time.perf_counter()
    for seq in range(first, first + count):
        due = start + (seq - first) / rate
        while (wait := due - time.perf_counter()) > 0:
            if select.select([sink], [], [], wait)[0]:
                _collect(codec, sink, arrived)
        out.sendto(stamped(codec, seq), target)
        sent_at[seq] = time.perf_counter()
    deadline = time.perf_counter() + 0.5
    while len(arrived) < count and (wait := deadline - time.perf_counter()) > 0:
        if select.select([sink], [], [], wait)[0]:
            _collect(codec, sink, arrived)
    out.close()
    sink.setblocking(True)
    return [(arrived[seq] - at) * 1e3 for seq, at in sent_at.items() if seq in arrived]


def _collect(codec: erc_codec.Codec, sink: socket.socket, arrived: dict[int, float]) -> None:
    while True:
        try:
            data = sink.recv(4096)
        except BlockingIOError:
            return
        at = time.perf_counter()
        message: Any = codec.decode(data).message
        arrived[message.timestamp_ms] = at


def snmp_rcvbuf_errors() -> int | None:
    try:
        lines = Path("/proc/net/snmp").read_text().splitlines()
    except OSError:
        return None
    udp = [line.split() for line in lines if line.startswith("Udp:")]
    return int(udp[1][udp[0].index("RcvbufErrors")])


def flood(port: int, sink: socket.socket, stream: list[bytes], seconds: float) -> tuple[int, int]:
    """Send as fast as possible for ``seconds``; (sent, received)."""
    out = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.setblocking(False)
    target = ("127.0.0.1", port)
    sent = received = 0
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        for data in stream:
            out.sendto(data, target)
            sent += 1
        while True:
            try:
                sink.recv(4096)
            except BlockingIOError:
                break
            received += 1
    settle = time.perf_counter() + 1.0
    while time.perf_counter() < settle:
        try:
            sink.recv(4096)
            received += 1
        except BlockingIOError:
            time.sleep(0.01)
    out.close()
    sink.setblocking(True)
    return sent, received


def percentile(values: list[float], share: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(share * len(ordered)))]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--flood", type=float, default=1.0)
    parser.add_argument("--bare-forwarder", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.bare_forwarder is not None:
        bare_forwarder(args.bare_forwarder)
        return 0
    codec = erc_codec.Codec.default()
    stream = datagrams(codec)
    count = 2_000 if args.quick else 20_000
    paced = 500 if args.quick else 3_000
    repeat = 1 if args.quick else args.repeat
    ratios, p99s, own = [], [], []
    with TemporaryDirectory() as folder:
        for run in range(repeat):
            sink = receiver()
            sink_port = sink.getsockname()[1]
            rates = {}
            for kind in ("bare", "relay"):  # interleaved: noise hits both alike
                contender = Forwarder(kind, sink_port, Path(folder))
                rates[kind] = throughput(contender.port, sink, stream, count)
                contender.stop()
            ratios.append(rates["relay"] / rates["bare"])
            direct = latencies(codec, sink_port, sink, paced, 1000.0, 0)
            one_way = {}
            first = paced
            for kind in ("bare", "relay"):
                contender = Forwarder(kind, sink_port, Path(folder))
                latencies(codec, contender.port, sink, 200, 2000.0, first)  # warm-up
                one_way[kind] = latencies(codec, contender.port, sink, paced, 1000.0, first + 200)
                first += paced + 200
                counters = contender.stop()
            through, bare = one_way["relay"], one_way["bare"]
            p99s.append(percentile(through, 0.99) - percentile(bare, 0.99))
            own.append(counters["latency_us"]["p99"])
            shown = {
                name: f"{percentile(times, 0.5):.3f}/{percentile(times, 0.99):.3f}"
                for name, times in (("relay", through), ("bare", bare), ("direct", direct))
            }
            print(
                f"run {run + 1}: throughput relay {rates['relay']:,.0f}/s, bare "
                f"{rates['bare']:,.0f}/s, ratio {ratios[-1]:.2f}x; at 1,000/s one-way p50/p99 "
                f"ms: relay {shown['relay']}, bare forwarder {shown['bare']}, direct "
                f"{shown['direct']}: added p99 {p99s[-1]:.3f} ms (the relay's own read-to-send "
                f"p99 {own[-1]} µs; arrived {len(through)}, {len(bare)}, {len(direct)} of "
                f"{paced})"
            )
            sink.close()
        sink = receiver()
        relay = Forwarder("relay", sink.getsockname()[1], Path(folder))
        before = snmp_rcvbuf_errors()
        sent, received = flood(relay.port, sink, stream, 0.3 if args.quick else args.flood)
        after = snmp_rcvbuf_errors()
        counters = relay.stop()
        sink.close()
    listen = counters["listen"]["in"]
    counted = sum(counters["dropped"].values()) + (listen["kernel_dropped"] or 0) + listen["unread"]
    kernel = None if before is None or after is None else after - before
    lost = sent - received
    accounted = lost <= counted + (kernel or 0)
    print(
        f"flood: sent {sent}, received {received}, lost {lost}; relay counted {counted} "
        f"(dropped {counters['dropped']}, kernel {listen['kernel_dropped']}, unread "
        f"{listen['unread']}), /proc/net/snmp RcvbufErrors +{kernel}: "
        f"{'all counted' if accounted else 'NOT ALL COUNTED'}"
    )
    middle, p99 = statistics.median(ratios), statistics.median(p99s)
    ok_ratio, ok_latency = middle >= _RATIO_TARGET, p99 < _LATENCY_TARGET_MS
    print(
        f"throughput ratio median {middle:.2f}x of {[round(r, 2) for r in ratios]} (target >= "
        f"{_RATIO_TARGET}x): {'yes' if ok_ratio else 'NO'}; added latency p99 median "
        f"{p99:.3f} ms (target < {_LATENCY_TARGET_MS} ms): {'yes' if ok_latency else 'NO'}"
    )
    return 0 if ok_ratio and ok_latency and accounted else 1


if __name__ == "__main__":
    os.environ.setdefault("PYTHONHASHSEED", "0")
    sys.exit(main())
