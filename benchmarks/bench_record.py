"""Recording: a capture to MCAP against the bare libraries, its memory, and record on loopback.

    python benchmarks/bench_record.py [--quick]

1. Throughput. A pcap of 1,000,000 datagrams of every kind (--quick: 50,000), each payload a
   random one, in the exact form. Ours is ``erc-codec decode --pcap --mcap``'s own code (the
   command's Capture, decode, McapWriter); bare is the same libraries with nothing of ours: dpkt
   reads the pcap, ``PBEnvelope.FromString`` parses the datagram, the payload's bytes go to its
   MCAP channel (zstd chunks, CRCs on, as ours writes). Each runs in a fresh process, in rounds
   (3; --quick: 5) of bare, ours and each one's reading of the capture alone, in an order that
   turns round from one round to the next; a round's runs follow each other, so they share the
   machine's load. Target: ours >= 0.7x bare's datagrams per second, the median of the rounds'
   ratios (wall clock). Beside it, in CPU time, the ratio and where the time goes (reading the
   capture, and the rest), each pipeline's least CPU time over the rounds: a shared machine only
   ever adds to it (waiting is not in it, contention for caches is), so the least is the
   steadiest, and a difference of two of them does not drown in the noise. Ours on the fleet's
   stripped form is shown beside (bare cannot read it).
2. Memory. Ours's peak RSS converting a tenth of the datagrams and all of them: flat means the
   larger run needs no more than 10 MB over the smaller one.
3. record on loopback. ``erc-codec record`` in its own process while this one sends 20,000
   datagrams a second (stripped, every kind, one in a hundred garbage) for 5 seconds (--quick:
   1). Reported: what was sent, what record received, wrote (messages, drops) and says the kernel
   dropped, what the MCAP file holds, the system's UDP receive-buffer errors meanwhile, and the
   CPU time record and its writer used (what it needs to keep up, however busy the machine). Target:
   nothing lost unreported (sent = received + dropped by the kernel = messages + drops + dropped by
   the kernel), and it keeps up (the kernel dropped none).
Exit status 1 when a target is missed.
"""

import argparse
import json
import os
import random
import socket
import subprocess
import sys
import time
from pathlib import Path
from statistics import median
from tempfile import TemporaryDirectory
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from bench_codec import corpus
from recording_support import write_pcap

import erc_codec

_RATIO_TARGET = 0.7
_FLAT_MB = 10
_RATE = 20_000


def datagrams(codec: erc_codec.Codec, count: int, mode: erc_codec.Mode) -> list[bytes]:
    """``count`` datagrams cycling through a pool of random payloads of every kind."""
    rng = random.Random(20261201)
    pool: list[bytes] = []
    for _ in range(24):
        full, zero_ended = corpus(codec, rng)
        pool += [codec.encode(m, mode) for m in full + zero_ended]
    rng.shuffle(pool)
    return [pool[i % len(pool)] for i in range(count)]


# -- the children ------------------------------------------------------------------------------


def child(pipeline: str, capture: Path, out: Path) -> None:
    """Run one pipeline over ``capture``; print its seconds (wall clock and CPU) and peak RSS
    as JSON."""
    import resource

    from erc_codec.cli._pcap import Capture
    from erc_codec.cli._record import capture_to_mcap

    codec = erc_codec.Codec.default()
    start, cpu = time.perf_counter(), time.process_time()
    if pipeline == "ours":
        with Capture(capture) as packets:
            capture_to_mcap(packets, codec, out)
    elif pipeline == "bare":
        bare(codec, capture, out)
    elif pipeline == "read-ours":  # the capture's datagrams only, as ours reads them
        with Capture(capture) as packets:
            for _ in packets.datagrams():
                pass
    else:  # read-bare
        import dpkt  # type: ignore[import-untyped]

        with capture.open("rb") as file:
            for _, frame in dpkt.pcap.Reader(file):
                dpkt.ethernet.Ethernet(frame).data.data.data  # noqa: B018
    seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps({"seconds": seconds, "cpu": cpu, "peak_mb": peak}))


def bare(codec: erc_codec.Codec, capture: Path, out: Path) -> None:
    """The same libraries with nothing of ours between them."""
    import dpkt
    from mcap.writer import CompressionType, Writer

    envelope = codec.message_class(codec.root)
    parse = envelope.FromString
    with capture.open("rb") as file, out.open("wb") as output:
        writer = Writer(
            output,
            chunk_size=1 << 20,
            compression=CompressionType.ZSTD,
            enable_crcs=True,
            enable_data_crcs=True,
        )
        writer.start()
        channels: dict[str, int] = {}
        for timestamp, frame in dpkt.pcap.Reader(file):
            message = parse(dpkt.ethernet.Ethernet(frame).data.data.data)
            kind = message.WhichOneof("payload")
            channel = channels.get(kind)
            if channel is None:
                schema = writer.register_schema(kind, "protobuf", b"")
                channel = channels[kind] = writer.register_channel(
                    f"/erc/{kind}", "protobuf", schema
                )
            at = int(timestamp * 1e9)
            writer.add_message(channel, at, getattr(message, kind).SerializeToString(), at)
        writer.finish()  # type: ignore[no-untyped-call]


def run_child(pipeline: str, capture: Path, out: Path) -> dict[str, float]:
    out.unlink(missing_ok=True)
    done = subprocess.run(
        [sys.executable, __file__, "--child", pipeline, str(capture), str(out)],
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        raise SystemExit(f"the {pipeline} pipeline failed:\n{done.stderr}")
    result: dict[str, float] = json.loads(done.stdout.splitlines()[-1])
    return result


class Rounds:
    """The pipelines run over one capture in rounds, each in a fresh process: bare, ours and each
    one's reading of the capture alone, in an order that turns round each round. A round's runs
    follow each other, so they share the machine's load: compare within a round, and take the
    median over the rounds."""

    def __init__(self, capture: Path, folder: Path, rounds: int) -> None:
        pipelines = ("bare", "ours", "read-bare", "read-ours")
        self.runs: dict[str, list[dict[str, float]]] = {name: [] for name in pipelines}
        for number in range(rounds):
            for pipeline in pipelines if number % 2 == 0 else reversed(pipelines):
                self.runs[pipeline].append(run_child(pipeline, capture, folder / "out.mcap"))

    def of(self, name: str, what: str) -> list[float]:
        """``what`` (seconds, cpu, peak_mb) of each round's run of pipeline ``name``."""
        return [run[what] for run in self.runs[name]]

    def ratios(self, clock: str) -> list[float]:
        """Ours's throughput over bare's in each round, by ``clock`` (seconds, or cpu)."""
        pairs = zip(self.of("bare", clock), self.of("ours", clock), strict=True)
        return [bare / ours for bare, ours in pairs]

    def cpu(self, name: str) -> float:
        """The least CPU seconds of pipeline ``name`` over the rounds."""
        return min(self.of(name, "cpu"))


# -- record on loopback ------------------------------------------------------------------------


def rcvbuf_errors() -> int | None:
    """The system's UDP RcvbufErrors (datagrams dropped for a full receive buffer)."""
    try:
        lines = [line.split() for line in Path("/proc/net/snmp").read_text().splitlines()]
    except OSError:
        return None
    names, values = [line for line in lines if line[0] == "Udp:"][:2]
    return int(values[names.index("RcvbufErrors")])


def record_at_rate(codec: erc_codec.Codec, folder: Path, seconds: float) -> dict[str, Any]:
    count = int(_RATE * seconds)
    sent_data = datagrams(codec, count, "strip")
    for i in range(0, count, 100):
        sent_data[i] = bytes.fromhex("b20100")  # one in a hundred: a newer schema's member
    import resource

    out = folder / "live.mcap"
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    limits = ["--count", str(count), "--seconds", str(seconds + 20)]
    recorder = subprocess.Popen(
        [sys.executable, "-m", "erc_codec", "record", "127.0.0.1:0", str(out), *limits],
        stderr=subprocess.PIPE,
        text=True,
    )
    assert recorder.stderr is not None
    first = recorder.stderr.readline()
    port = int(first.split()[2].rsplit(":", 1)[1])
    errors_before = rcvbuf_errors()
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        target = ("127.0.0.1", port)
        start = time.perf_counter()
        burst = _RATE // 1000  # every millisecond, a millisecond's worth
        for i in range(0, count, burst):
            due = start + i / _RATE
            while (now := time.perf_counter()) < due:
                if due - now > 0.0005:
                    time.sleep(due - now - 0.0003)
            for data in sent_data[i : i + burst]:
                sock.sendto(data, target)
        sending = time.perf_counter() - start
    _, err = recorder.communicate(timeout=seconds + 60)
    errors_after = rcvbuf_errors()
    after = resource.getrusage(resource.RUSAGE_CHILDREN)  # record and its writer, both waited for
    cpu = after.ru_utime + after.ru_stime - children.ru_utime - children.ru_stime
    line = err.strip().splitlines()[-1]
    summary: dict[str, Any] = json.loads(line.removeprefix("recorded: "))
    from mcap.reader import make_reader

    with out.open("rb") as file:
        found = make_reader(file, validate_crcs=True).get_summary()
    assert found is not None
    assert found.statistics is not None
    return {
        "sent": count,
        "send_seconds": sending,
        "received": summary["received"],
        "messages": sum(summary["messages"].values()),
        "drops": sum(summary["drops"].values()),
        "dropped_by_kernel": summary["dropped_by_kernel"],
        "in_file": found.statistics.message_count,
        "cpu_seconds": cpu,
        "rcvbuf_errors": None
        if errors_before is None or errors_after is None
        else errors_after - errors_before,
    }


# -- the report --------------------------------------------------------------------------------


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller runs (a smoke run)")
    parser.add_argument(
        "--child", nargs=3, metavar=("PIPELINE", "PCAP", "OUT"), help=argparse.SUPPRESS
    )
    arguments = parser.parse_args()
    if arguments.child:
        pipeline, capture, out = arguments.child
        child(pipeline, Path(capture), Path(out))
        return 0
    count = 50_000 if arguments.quick else 1_000_000
    codec = erc_codec.Codec.default()
    ok = True
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    with TemporaryDirectory() as temporary:
        folder = Path(temporary)
        exact, stripped, small = (
            folder / "exact.pcap",
            folder / "stripped.pcap",
            folder / "small.pcap",
        )
        write_pcap(exact, datagrams(codec, count, "exact"), step=0.0001)
        write_pcap(stripped, datagrams(codec, count, "strip"), step=0.0001)
        write_pcap(small, datagrams(codec, count // 10, "exact"), step=0.0001)
        print(f"capture to MCAP, {count:,} datagrams of {len(codec.kinds())} kinds:")
        runs = Rounds(exact, folder, 5 if arguments.quick else 3)
        fleet = run_child("ours", stripped, folder / "fleet.mcap")
        ratio = median(runs.ratios("seconds"))
        rate = {name: count / median(runs.of(name, "seconds")) for name in ("bare", "ours")}
        print(f"  bare (dpkt, FromString, mcap)    {rate['bare']:>10,.0f} datagrams/s")
        print(f"  ours (decode --pcap --mcap)      {rate['ours']:>10,.0f} datagrams/s")
        print(f"  ours, the fleet's stripped form  {count / fleet['seconds']:>10,.0f} datagrams/s")
        met = ratio >= _RATIO_TARGET
        ok &= met
        shown = " ".join(f"{r:.2f}" for r in runs.ratios("seconds"))
        print(
            f"  ratio {ratio:.2f}x (target >= {_RATIO_TARGET}x): {'yes' if met else 'NO'}; "
            f"its rounds {shown}; in CPU time {runs.cpu('bare') / runs.cpu('ours'):.2f}x"
        )
        us = {name: runs.cpu(name) / count * 1e6 for name in runs.runs}
        print(
            f"  CPU µs a datagram: ours {us['ours']:.1f}, bare {us['bare']:.1f}; of which reading "
            f"the capture: ours (cli/_pcap.py's Capture) {us['read-ours']:.1f}, bare (dpkt's "
            f"loop) {us['read-bare']:.1f}; the rest, ours {us['ours'] - us['read-ours']:.1f}, "
            f"bare {us['bare'] - us['read-bare']:.1f}"
        )
        smaller = run_child("ours", small, folder / "small.mcap")["peak_mb"]
        larger = max(runs.of("ours", "peak_mb"))
        flat = larger <= smaller + _FLAT_MB
        ok &= flat
        print(
            f"memory, peak RSS: {smaller:.0f} MB at {count // 10:,} datagrams, {larger:.0f} MB at "
            f"{count:,} (bare: {max(runs.of('bare', 'peak_mb')):.0f} MB); "
            f"flat (within {_FLAT_MB} MB): {'yes' if flat else 'NO'}"
        )
        seconds = 1.0 if arguments.quick else 5.0
        live = record_at_rate(codec, folder, seconds)
        unreported = live["sent"] - live["received"] - (live["dropped_by_kernel"] or 0)
        written = live["messages"] + live["drops"]
        print(
            f"record at {_RATE:,} datagrams/s for {seconds:.0f} s (sent in "
            f"{live['send_seconds']:.2f} s): sent {live['sent']:,}, received {live['received']:,}, "
            f"wrote {live['messages']:,} messages + {live['drops']:,} drops (file: "
            f"{live['in_file']:,}), dropped by the kernel {live['dropped_by_kernel']}, system "
            f"UDP receive-buffer errors meanwhile {live['rcvbuf_errors']}"
        )
        print(
            f"  record's CPU (receiving and writing, start-up included): "
            f"{live['cpu_seconds'] / max(live['received'], 1) * 1e6:.0f} µs a datagram received, "
            f"{live['cpu_seconds'] / seconds:.2f} CPUs over the run; load average now "
            f"{os.getloadavg()[0]:.1f}"
        )
        kept_up = live["dropped_by_kernel"] == 0
        honest = unreported == 0 and written == live["received"] == live["in_file"]
        ok &= kept_up and honest
        print(
            f"  lost unreported: {unreported} ({'none' if honest else 'SOME'}); "
            f"kept up: {'yes' if kept_up else 'NO'}"
        )
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
