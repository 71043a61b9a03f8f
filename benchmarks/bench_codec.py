"""Encode/decode throughput of erc_codec as a ratio to bare protobuf: same bytes, one run.

    python benchmarks/bench_codec.py [--quick]

Bare decode is ``PBEnvelope.FromString`` + ``WhichOneof`` + ``getattr``; bare encode is
``SerializeToString`` of a ready envelope. Targets (from the codec foundation issue): decode ≤ 1.25x
bare on exact datagrams, ≤ 2x on stripped datagrams that ended in zeros (bare parses their exact
form, since it cannot parse the stripped one), encode (wrap + validate + serialize) ≤ 2x bare.
Each measurement interleaves the contenders and keeps the best of several repeats, so machine noise
hits both alike. Exit status 1 when a target is missed.
"""

import argparse
import random
import sys
import timeit
from collections.abc import Callable
from typing import Any

from google.protobuf.descriptor import FieldDescriptor
from google.protobuf.message import Message

import erc_codec
from erc_schema import descriptor_of, enum_of

_T = FieldDescriptor
_TARGETS = {"decode exact": 1.25, "decode stripped": 2.0, "encode": 2.0}


def fill(message: Message, rng: random.Random) -> Message:
    """Give every field of ``message`` (recursively) a random value of its type."""
    descriptor = descriptor_of(type(message))
    for field in descriptor.fields:
        if field.type == _T.TYPE_MESSAGE:
            fill(getattr(message, field.name), rng)
        else:
            setattr(message, field.name, _value(field, rng))
    return message


def _value(field: FieldDescriptor, rng: random.Random) -> Any:
    if field.type == _T.TYPE_ENUM:
        return rng.choice(enum_of(field).values).number
    if field.type == _T.TYPE_BOOL:
        return rng.random() < 0.5
    if field.type in (_T.TYPE_FLOAT, _T.TYPE_DOUBLE):
        return rng.uniform(-1000, 1000)
    if field.type in (_T.TYPE_INT64, _T.TYPE_SINT64, _T.TYPE_SFIXED64):
        return rng.randint(-(2**40), 2**40)
    if field.type in (_T.TYPE_INT32, _T.TYPE_SINT32, _T.TYPE_SFIXED32):
        return rng.randint(-(2**20), 2**20)
    return rng.randint(0, 2**20)


def corpus(codec: erc_codec.Codec, rng: random.Random) -> tuple[list[Message], list[Message]]:
    """One random envelope per payload type, and envelopes whose exact encoding ends in 0x00."""
    envelope = codec.message_class(codec.root)
    full, zero_ended = [], []
    for kind in codec.kinds().values():
        message = envelope()
        fill(getattr(message, kind), rng)
        full.append(message)
        empty = envelope()
        getattr(empty, kind).SetInParent()  # all-default payload: tag, then length 00
        zero_ended.append(empty)
        tiny = envelope()
        fill(getattr(tiny, kind), rng)
        last = max(getattr(tiny, kind).DESCRIPTOR.fields, key=lambda f: f.number)
        if last.type in (_T.TYPE_FLOAT, _T.TYPE_DOUBLE):
            setattr(getattr(tiny, kind), last.name, 1e-40)  # subnormal: high bytes zero
            zero_ended.append(tiny)
    assert all(m.SerializeToString().endswith(b"\0") for m in zero_ended)
    return full, zero_ended


def best(function: Callable[[], object], number: int, repeat: int) -> float:
    return min(timeit.repeat(function, number=number, repeat=repeat)) / number


def ratio(
    ours: Callable[[], object], bare: Callable[[], object], number: int
) -> tuple[float, float, float]:
    """Best-of times of both, measured alternately; return (ours s, bare s, ratio)."""
    ours_times, bare_times = [], []
    for _ in range(15):
        bare_times.append(best(bare, number, 1))
        ours_times.append(best(ours, number, 1))
    mine, theirs = min(ours_times), min(bare_times)
    return mine, theirs, mine / theirs


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer iterations (a smoke run)")
    args = parser.parse_args()
    number = 20 if args.quick else 300

    codec = erc_codec.Codec.default()
    envelope = codec.message_class(codec.root)
    oneof = envelope.DESCRIPTOR.oneofs[0].name
    full, zero_ended = corpus(codec, random.Random(20261122))
    exact = [m.SerializeToString() for m in full]
    stripped = [m.SerializeToString().rstrip(b"\0") for m in zero_ended]
    stripped_exact = [m.SerializeToString() for m in zero_ended]
    payloads = [getattr(m, m.WhichOneof(oneof)) for m in full]
    parse, decode, encode = envelope.FromString, codec.decode, codec.encode

    def bare_decode(datagrams: list[bytes]) -> Callable[[], None]:
        def run() -> None:
            for data in datagrams:
                message = parse(data)
                getattr(message, message.WhichOneof(oneof))

        return run

    def our_decode(datagrams: list[bytes]) -> Callable[[], None]:
        def run() -> None:
            for data in datagrams:
                decode(data)

        return run

    def bare_encode() -> None:
        for message in full:
            message.SerializeToString()

    def our_encode() -> None:
        for payload in payloads:
            encode(payload)

    rows = {
        "decode exact": ratio(our_decode(exact), bare_decode(exact), number),
        "decode stripped": ratio(our_decode(stripped), bare_decode(stripped_exact), number),
        "encode": ratio(our_encode, bare_encode, number),
    }
    sizes = (len(exact), len(stripped), len(payloads))
    print(
        f"protobuf runtime: {_runtime()}; datagrams per pass: exact {sizes[0]}, "
        f"stripped {sizes[1]}, encode {sizes[2]}"
    )
    print(f"{'measure':<17}{'ours µs':>9}{'bare µs':>9}{'ratio':>8}{'target':>8}  ok")
    missed = False
    for name, (mine, theirs, factor) in rows.items():
        count = sizes[list(rows).index(name)]
        ok = factor <= _TARGETS[name]
        missed |= not ok
        print(
            f"{name:<17}{mine / count * 1e6:>9.3f}{theirs / count * 1e6:>9.3f}"
            f"{factor:>7.2f}x{_TARGETS[name]:>7.2f}x  {'yes' if ok else 'NO'}"
        )
    return 1 if missed else 0


def _runtime() -> str:
    import google.protobuf
    from google.protobuf.internal import api_implementation

    return f"protobuf {google.protobuf.__version__} ({api_implementation.Type()})"


if __name__ == "__main__":
    sys.exit(main())
