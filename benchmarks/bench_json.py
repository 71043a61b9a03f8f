"""Codec's JSON mapping as a ratio to google.protobuf.json_format: same documents, one run.

    python benchmarks/bench_json.py [--quick]

Every row converts one random payload of every kind (bench_codec's corpus: every field set,
floats with 7 or 8 significant digits, as sensors send them), ours and json_format's measured
alternately, the best of several repeats counting:
- ``to_dict`` against ``MessageToDict`` with the two flags ``erc-codec decode`` used to pass it
  (the same dict, keys aside: ours are in .proto order);
- ``to_json`` against ``json.dumps`` of that dict (one line, as the command line prints it);
- ``from_dict`` against ``ParseDict`` of the same dict (ours range-checks every value first).
Target: to_dict ≤ 0.5x MessageToDict, for ``erc-codec listen`` keeping up with 20,000
datagrams a second in JSON mode (50 µs a datagram for everything; MessageToDict alone takes more).
The other rows are printed to be watched, with no target. Exit status 1 when the target is missed.
"""

import argparse
import json
import random
import sys
import timeit
from collections.abc import Callable
from typing import Any

from bench_codec import corpus
from google.protobuf import json_format
from google.protobuf.message import Message

import erc_codec

_TARGETS = {"to_dict": 0.5}


def theirs_dict(payload: Message) -> dict[str, Any]:
    return json_format.MessageToDict(
        payload, always_print_fields_with_no_presence=True, preserving_proto_field_name=True
    )


def ratio(
    ours: Callable[[], object], theirs: Callable[[], object], number: int
) -> tuple[float, float, float]:
    """(ours / theirs, ours s, theirs s): best-of times, measured alternately."""
    mine, bare = [], []
    for _ in range(15):
        bare.append(min(timeit.repeat(theirs, number=number, repeat=1)))
        mine.append(min(timeit.repeat(ours, number=number, repeat=1)))
    return min(mine) / min(bare), min(mine), min(bare)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer iterations (a smoke run)")
    number = 5 if parser.parse_args().quick else 50
    codec = erc_codec.Codec.default()
    envelope = codec.message_class(codec.root)
    oneof = envelope.DESCRIPTOR.oneofs[0].name
    full, _ = corpus(codec, random.Random(20261122))
    payloads = [getattr(m, m.WhichOneof(oneof)) for m in full]
    documents = [(type(p), theirs_dict(p)) for p in payloads]
    to_dict, to_json, from_dict = codec.to_dict, codec.to_json, codec.from_dict
    assert all(to_dict(p) == theirs_dict(p) for p in payloads), "to_dict differs from json_format"
    assert all(from_dict(cls, d) == p for (cls, d), p in zip(documents, payloads, strict=True))

    rows = {
        "to_dict": (
            lambda: [to_dict(p) for p in payloads],
            lambda: [theirs_dict(p) for p in payloads],
        ),
        "to_json": (
            lambda: [to_json(p) for p in payloads],
            lambda: [json.dumps(theirs_dict(p)) for p in payloads],
        ),
        "from_dict": (
            lambda: [from_dict(cls, d) for cls, d in documents],
            lambda: [json_format.ParseDict(d, cls()) for cls, d in documents],
        ),
    }
    print(f"payloads per pass: {len(payloads)} (one of every kind)")
    print(f"{'measure':<11}{'ours µs':>9}{'json_format µs':>16}{'ratio':>8}{'target':>8}  ok")
    missed = False
    per = len(payloads) * number
    for name, (ours, theirs) in rows.items():
        factor, mine, bare = ratio(ours, theirs, number)
        target = _TARGETS.get(name)
        ok = target is None or factor <= target
        missed |= not ok
        shown = "" if target is None else f"{target:.2f}x"
        verdict = "" if target is None else "yes" if ok else "NO"
        print(
            f"{name:<11}{mine / per * 1e6:>9.2f}{bare / per * 1e6:>16.2f}{factor:>7.2f}x"
            f"{shown:>8}  {verdict}"
        )
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main())
