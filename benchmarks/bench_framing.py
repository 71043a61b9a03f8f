"""Deframing throughput as a ratio to computing the CRC alone over the same payloads, one run;
then the worst case: seconds per MB of adversarial streams.

    python benchmarks/bench_framing.py [--quick]

A stream of 60-byte payloads, framed, is fed to a Deframer in 4 KiB chunks; the peer computes
binascii.crc_hqx over the same payloads (the least any deframer must do). Target (transports
issue): ratio ≥ 0.5, i.e. framing costs at most as much again as the checksum. Frames per second
are reported too. Best of alternating rounds. Exit status 1 when the target is missed.

Frames of one length back to back are what the Deframer checks a batch at a time, so a second
stream, of payloads from 20 to 100 bytes, shows the frame-by-frame speed (for information).

The worst case (for information: the Deframer promises time linear in the bytes fed, whatever
max_length, and this shows the constant): the bad-input campaign's streams, fed in 4 KiB chunks
at max_length 65535 and 255, in CPU seconds per MB and as a ratio to plain garbage (random bytes
without a "P") at the same max_length. CPU time, best of rounds: the machine is shared.
"""

import argparse
import binascii
import random
import sys
import time
import timeit

import erc_codec

_TARGET = 0.5
_FRAMES = 2000
_MB = 1 << 20


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer rounds (a smoke run)")
    quick = parser.parse_args().quick
    rounds = 3 if quick else 15
    rng = random.Random(20261122)
    uniform = [rng.randbytes(60) for _ in range(_FRAMES)]
    mixed = [rng.randbytes(rng.randint(20, 100)) for _ in range(_FRAMES)]
    ratios = [measure(payloads, rounds) for payloads in (uniform, mixed)]
    print(f"frames per pass: {_FRAMES}, fed in 4 KiB chunks")
    print("payloads        crc_hqx alone  Deframer.feed  ratio")
    for name, (theirs, ours) in zip(("60 bytes", "20-100 bytes"), ratios, strict=True):
        rates = f"{_FRAMES / theirs:>10,.0f}/s {_FRAMES / ours:>12,.0f}/s"
        print(f"{name:<14} {rates} {theirs / ours:>6.2f}")
    ok = ratios[0][0] / ratios[0][1] >= _TARGET
    print(f"ratio on 60 bytes (target ≥ {_TARGET:.2f}): {'yes' if ok else 'NO'}")
    print()
    worst_case(_MB // 4 if quick else _MB, 1 if quick else 3)
    return 0 if ok else 1


def measure(payloads: list[bytes], rounds: int) -> tuple[float, float]:
    """Seconds per pass: the CRC alone, and deframing the framed stream."""
    stream = b"".join(erc_codec.runtime.frame(payload) for payload in payloads)
    chunks = [stream[start : start + 4096] for start in range(0, len(stream), 4096)]
    crc = binascii.crc_hqx

    def checksum() -> None:
        for payload in payloads:
            crc(payload, 0xFFFF)

    def deframe() -> None:
        deframer = erc_codec.runtime.Deframer(max_length=255)
        total = 0
        for chunk in chunks:
            total += len(deframer.feed(chunk))
        assert total == len(payloads)

    crc_times, deframe_times = [], []
    for _ in range(rounds):
        crc_times.append(min(timeit.repeat(checksum, number=5, repeat=1)) / 5)
        deframe_times.append(min(timeit.repeat(deframe, number=5, repeat=1)) / 5)
    return min(crc_times), min(deframe_times)


def adversarial(size: int) -> dict[str, bytes]:
    """Plain garbage and the bad-input campaign's streams, about ``size`` bytes each."""
    rng = random.Random(20261201)
    frames = (erc_codec.runtime.frame(rng.randbytes(60)) for _ in range(size // 70))
    return {
        "garbage": rng.randbytes(size).replace(b"P", b"Q"),
        "PR ff ff, repeated": b"PR\xff\xff" * (size // 4),
        "PR, repeated": b"PR" * (size // 2),
        "PR f0 00 + frame": b"".join(b"PR\xf0\x00" + framed for framed in frames),
        "noise, PR every 8": b"".join(rng.randbytes(6) + b"PR" for _ in range(size // 8)),
    }


def worst_case(size: int, rounds: int) -> None:
    """Print seconds per MB of each adversarial stream, and its ratio to plain garbage."""
    streams = adversarial(size)
    costs: dict[int, dict[str, float]] = {65535: {}, 255: {}}
    for _ in range(rounds):  # alternating, best of each
        for max_length, cost in costs.items():
            for name, stream in streams.items():
                seconds = per_mb(stream, max_length)
                cost[name] = min(cost.get(name, seconds), seconds)
    print(f"worst case: {size // 1024} KiB a stream, fed in 4 KiB chunks, best of {rounds}")
    print("stream                max 65535: s/MB  x garbage   max 255: s/MB  x garbage")
    for name in streams:
        cells = [
            f"{costs[m][name]:>10.3f} {costs[m][name] / costs[m]['garbage']:>10,.0f}" for m in costs
        ]
        print(f"{name:<20} {cells[0]:>21} {cells[1]:>25}")
    worst = {m: max(costs[m].values()) for m in costs}
    print(f"worst: {worst[65535]:.2f} s/MB at max 65535, {worst[255]:.2f} s/MB at max 255")


def per_mb(stream: bytes, max_length: int) -> float:
    """Seconds per MB to deframe ``stream`` in 4 KiB chunks."""
    chunks = [stream[start : start + 4096] for start in range(0, len(stream), 4096)]

    def deframe() -> None:
        deframer = erc_codec.runtime.Deframer(max_length=max_length)
        for chunk in chunks:
            deframer.feed(chunk)

    return (
        min(timeit.repeat(deframe, timer=time.process_time, number=1, repeat=1)) * _MB / len(stream)
    )


if __name__ == "__main__":
    sys.exit(main())
