"""Dispatcher.feed throughput as a ratio to bare codec.decode on the same datagrams, one run.

    python benchmarks/bench_runtime.py [--quick]

Both decode the same mix of datagrams (one random payload of every kind, exact and stripped);
feed also looks up the handler, calls it (a no-op here, so the ratio is the dispatcher's own
cost) and counts. Exact and really stripped datagrams are also shown apart, beside the whole
mix, which the target is about. Target (runtime companions issue): feed ≤ 1.2x decode. The
contenders are measured alternately, datagram by datagram, in many tiny samples; the best of
each counts. Exit status 1 when the target is missed.
"""

import argparse
import functools
import random
import sys
import timeit

from bench_codec import corpus

import erc_codec

_TARGET = 1.2


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer iterations (a smoke run)")
    rounds = 10 if parser.parse_args().quick else 200
    codec = erc_codec.Codec.default()
    full, zero_ended = corpus(codec, random.Random(20261122))
    exact = [m.SerializeToString() for m in full + zero_ended]
    stripped = [data.rstrip(b"\0") for data in exact]
    dispatcher = erc_codec.runtime.Dispatcher(codec)
    for kind in codec.kinds().values():
        dispatcher.register(kind, lambda message: None)
    decode, feed = codec.decode, dispatcher.feed
    # Per datagram, many tiny alternating samples; the minimum of each contender is what the
    # call costs when nothing else on this (virtual, shared) machine gets in the way.
    times: dict[bytes, tuple[float, float]] = {}
    for data in exact + stripped:
        one_decode = functools.partial(decode, data)
        one_feed = functools.partial(feed, data)
        theirs = min(min(timeit.repeat(one_decode, number=20, repeat=1)) for _ in range(rounds))
        ours = min(min(timeit.repeat(one_feed, number=20, repeat=1)) for _ in range(rounds))
        times[data] = theirs, ours
    print(f"datagrams per pass: {len(exact + stripped)} (each payload exact, and stripped)")
    print("datagrams             codec.decode  Dispatcher.feed  ratio")
    shrunk = [data for data, whole in zip(stripped, exact, strict=True) if data != whole]
    for name, group in (("exact", exact), ("really stripped", shrunk), ("all", exact + stripped)):
        theirs = sum(times[data][0] for data in group) / (20 * len(group))
        ours = sum(times[data][1] for data in group) / (20 * len(group))
        print(f"{name:<16} {theirs * 1e6:10.3f} µs {ours * 1e6:13.3f} µs {ours / theirs:6.2f}x")
    ratio = ours / theirs
    ok = ratio <= _TARGET
    print(f"ratio {ratio:.2f}x (target ≤ {_TARGET:.2f}x): {'yes' if ok else 'NO'}")
    assert dispatcher.stats().handled, "the handlers never ran"
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
