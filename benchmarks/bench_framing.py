"""Deframing throughput as a ratio to computing the CRC alone over the same payloads, one run.

    python benchmarks/bench_framing.py [--quick]

A stream of 60-byte payloads, framed, is fed to a Deframer in 4 KiB chunks; the peer computes
binascii.crc_hqx over the same payloads (the least any deframer must do). Target (transports
issue): ratio ≥ 0.5, i.e. framing costs at most as much again as the checksum. Frames per second
are reported too. Best of alternating rounds. Exit status 1 when the target is missed.
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
    payloads = [rng.randbytes(60) for _ in range(_FRAMES)]
    stream = b"".join(erc_codec.frame(payload) for payload in payloads)
    crc = binascii.crc_hqx

    def checksum() -> None:
        for payload in payloads:
            crc(payload, 0xFFFF)

    def deframe() -> None:
        deframer = erc_codec.Deframer(max_length=255)
        total = 0
        for start in range(0, len(stream), 4096):
            total += len(deframer.feed(stream[start : start + 4096]))
        assert total == _FRAMES

    crc_times, deframe_times = [], []
    for _ in range(rounds):
        crc_times.append(min(timeit.repeat(checksum, number=5, repeat=1)) / 5)
        deframe_times.append(min(timeit.repeat(deframe, number=5, repeat=1)) / 5)
    ours, theirs = min(deframe_times), min(crc_times)
    ratio = theirs / ours
    print(f"frames per pass: {_FRAMES} of 60 bytes")
    print(f"crc_hqx alone   {_FRAMES / theirs:>12,.0f} frames/s")
    print(f"Deframer.feed   {_FRAMES / ours:>12,.0f} frames/s")
    ok = ratio >= _TARGET
    print(f"ratio {ratio:.2f} (target ≥ {_TARGET:.2f}): {'yes' if ok else 'NO'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
