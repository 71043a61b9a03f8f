"""Deframing throughput as a ratio to computing the CRC alone over the same payloads, one run.

    python benchmarks/bench_framing.py [--quick]

A stream of 60-byte payloads, framed, is fed to a Deframer in 4 KiB chunks; the peer computes
binascii.crc_hqx over the same payloads (the least any deframer must do). Target (transports
issue): ratio ≥ 0.5, i.e. framing costs at most as much again as the checksum. Frames per second
are reported too. Best of alternating rounds. Exit status 1 when the target is missed.

Frames of one length back to back are what the Deframer checks a batch at a time, so a second
stream, of payloads from 20 to 100 bytes, shows the frame-by-frame speed (for information).
"""

import argparse
import binascii
import random
import sys
import timeit

import erc_codec

_TARGET = 0.5
_FRAMES = 2000


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer rounds (a smoke run)")
    rounds = 3 if parser.parse_args().quick else 15
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
    return 0 if ok else 1


def measure(payloads: list[bytes], rounds: int) -> tuple[float, float]:
    """Seconds per pass: the CRC alone, and deframing the framed stream."""
    stream = b"".join(erc_codec.frame(payload) for payload in payloads)
    chunks = [stream[start : start + 4096] for start in range(0, len(stream), 4096)]
    crc = binascii.crc_hqx

    def checksum() -> None:
        for payload in payloads:
            crc(payload, 0xFFFF)

    def deframe() -> None:
        deframer = erc_codec.Deframer(max_length=255)
        total = 0
        for chunk in chunks:
            total += len(deframer.feed(chunk))
        assert total == len(payloads)

    crc_times, deframe_times = [], []
    for _ in range(rounds):
        crc_times.append(min(timeit.repeat(checksum, number=5, repeat=1)) / 5)
        deframe_times.append(min(timeit.repeat(deframe, number=5, repeat=1)) / 5)
    return min(crc_times), min(deframe_times)


if __name__ == "__main__":
    sys.exit(main())
