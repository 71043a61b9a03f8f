"""Proton serial framing: the test vectors, and recovery from any chunking, noise and damage.

The Deframer checks runs of equal-length frames a batch at a time (a speed trick for the target of
benchmarks/bench_framing.py); ``reference_stats`` is the plain version it is held to: the same
rules read frame by frame over the whole stream at once.
"""

import binascii
import itertools
from array import array
from collections import Counter

import pytest
from hypothesis import given
from hypothesis import strategies as st

import erc_codec
from erc_codec import Deframer, DeframerStats, frame
from erc_codec._framing import crc16

MAX = 64


def test_proton_vectors() -> None:
    assert crc16(b"") == 0xFFFF
    assert crc16(b"\xab") == 0xE571
    assert crc16(b"123456789") == 0x29B1
    assert frame(b"123456789") == bytes.fromhex("5052 0900 313233343536373839 b129")
    assert frame(b"") == bytes.fromhex("5052 0000 ffff")


def test_a_payload_longer_than_a_frame_can_say_is_refused() -> None:
    with pytest.raises(erc_codec.EncodeError, match="65536 bytes is too long"):
        frame(bytes(65536))


def test_a_codecs_deframer_takes_up_to_its_envelope_size(codec: erc_codec.Codec) -> None:
    deframer = Deframer.for_codec(codec)
    too_long = frame(bytes(256))
    assert deframer.feed(too_long + frame(bytes(255))) == [bytes(255)]
    assert deframer.stats().rejected == {"too_long": 1}


def test_a_deframer_without_its_maximum_is_deprecated_and_takes_the_packaged_envelopes() -> None:
    with pytest.warns(DeprecationWarning, match=r"Deframer\(\) without max_length"):
        deframer = Deframer()
    assert deframer.feed(frame(bytes(256)) + frame(bytes(255))) == [bytes(255)]


def test_garbage_bad_crcs_and_impossible_lengths_are_counted() -> None:
    deframer = Deframer(max_length=MAX)
    damaged = bytearray(frame(b"lost"))
    damaged[5] ^= 0x01
    stream = b"noise" + bytes(damaged) + b"PR\xff\x00" + frame(b"kept") + b"P"
    assert deframer.feed(stream) == [b"kept"]
    stats = deframer.stats()
    assert stats.frames == 1
    assert stats.rejected == {"bad_crc": 1, "too_long": 1}
    # The rejected candidates lose one byte each; the rest is rescanned, then discarded as garbage.
    assert stats.discarded_bytes == {"garbage": 5 + 9 + 3, "bad_crc": 1, "too_long": 1}
    assert deframer.buffered() == 1  # the last "P" may start a frame
    assert deframer.feed(b"R" + frame(b"x")[2:]) == [b"x"]


def test_a_real_frame_inside_a_false_one_is_found() -> None:
    deframer = Deframer(max_length=MAX)
    real = frame(b"inside")
    stream = b"PR\x20\x00" + real + bytes(0x20 - len(real) + 2)  # claims to hold the real one
    assert deframer.feed(stream) == [b"inside"]


def reference(stream: bytes, max_length: int) -> list[bytes]:
    """The framing rules applied to the whole stream at once, the slow obvious way."""
    return reference_stats(stream, max_length)[0]


def reference_stats(stream: bytes, max_length: int) -> tuple[list[bytes], DeframerStats, int]:
    """The plain version the Deframer's batches are held to: the payloads, the counters and the
    bytes left buffered, reading ``stream`` frame by frame, one candidate at a time."""
    found, i = [], 0
    discarded: Counter[str] = Counter()
    rejected: Counter[str] = Counter()
    while i + 2 <= len(stream):
        if stream[i : i + 2] != b"PR":
            discarded["garbage"] += 1
            i += 1
            continue
        if i + 4 > len(stream):
            break
        length = int.from_bytes(stream[i + 2 : i + 4], "little")
        if length > max_length:
            rejected["too_long"] += 1
            discarded["too_long"] += 1
            i += 1
            continue
        end = i + 6 + length
        if end > len(stream):
            break  # a frame still arriving
        payload = stream[i + 4 : end - 2]
        if crc16(payload) == int.from_bytes(stream[end - 2 : end], "little"):
            found.append(payload)
            i = end
        else:
            rejected["bad_crc"] += 1
            discarded["bad_crc"] += 1
            i += 1
    if i == len(stream) - 1 and stream[i:] != b"P":
        discarded["garbage"] += 1
        i += 1
    return found, DeframerStats(len(found), dict(discarded), dict(rejected)), len(stream) - i


def chunked(stream: bytes, cuts: list[int]) -> list[bytes]:
    deframer = Deframer(max_length=MAX)
    out: list[bytes] = []
    edges = sorted({0, len(stream), *(c % (len(stream) + 1) for c in cuts)})
    for start, stop in itertools.pairwise(edges):
        out += deframer.feed(stream[start:stop])
        assert deframer.buffered() <= MAX + 5  # bounded, whatever arrives
    return out


NO_P = st.binary(max_size=12).map(lambda b: b.replace(b"P", b"Q"))
PAYLOADS = st.lists(st.binary(max_size=MAX), max_size=8)
CUTS = st.lists(st.integers(0, 10_000), max_size=12)


@given(PAYLOADS, st.lists(NO_P, min_size=9, max_size=9), CUTS)
def test_every_frame_survives_any_chunking_and_noise(
    payloads: list[bytes], noise: list[bytes], cuts: list[int]
) -> None:
    stream = b"".join(n + frame(p) for n, p in zip(noise, payloads, strict=False)) + noise[-1]
    assert chunked(stream, cuts) == payloads


@given(PAYLOADS, st.lists(NO_P, min_size=9, max_size=9))
def test_every_split_point_gives_the_same_frames(payloads: list[bytes], noise: list[bytes]) -> None:
    stream = b"".join(n + frame(p) for n, p in zip(noise, payloads, strict=False))
    for cut in range(len(stream) + 1):
        assert chunked(stream, [cut]) == payloads


@st.composite
def damaged(draw: st.DrawFn) -> tuple[list[bytes], list[bool], bytes]:
    """Frames of P-free payloads, some hit by a burst of at most 16 flipped bits in their payload
    or CRC; no flip makes a "P". Then every intact frame must come out, and no damaged one:
    CRC-16 detects every such burst, and with no stray "P" nothing else can start a frame."""
    payloads = draw(st.lists(NO_P.filter(bool), min_size=1, max_size=8))
    hit, stream = [], b""
    for payload in payloads:
        framed = bytearray(frame(payload))
        broken = draw(st.booleans())
        if broken:
            at = draw(st.integers(4, len(framed) - 2))  # payload or CRC, not magic or length
            mask = draw(st.integers(1, 0xFFFF)).to_bytes(2, "big")
            for offset, bits in enumerate(mask):
                if at + offset < len(framed):
                    framed[at + offset] ^= bits
            broken = bytes(framed) != frame(payload)
        if b"P" in framed[2:]:
            broken, framed = False, bytearray(frame(payload))  # keep the stream P-free
        hit.append(broken)
        stream += draw(NO_P) + bytes(framed)
    return payloads, hit, stream


@given(damaged(), CUTS)
def test_intact_frames_come_out_and_damaged_ones_never(
    case: tuple[list[bytes], list[bool], bytes], cuts: list[int]
) -> None:
    payloads, hit, stream = case
    assert chunked(stream, cuts) == [
        p for p, broken in zip(payloads, hit, strict=True) if not broken
    ]


@given(st.lists(st.binary(max_size=MAX), max_size=6), st.binary(max_size=40), st.data())
def test_any_damage_gives_what_the_rules_give(
    payloads: list[bytes], noise: bytes, data: st.DataObject
) -> None:
    """Dropped bytes and noise full of "PR": no guarantee about a damaged frame beyond CRC-16's
    odds, so no luck either: the stream deframer must agree exactly with the reference."""
    stream = bytearray(noise.join(frame(p) for p in payloads) + noise)
    for _ in range(data.draw(st.integers(0, 4))):
        if stream:
            action = data.draw(st.sampled_from(["drop", "flip", "magic"]))
            at = data.draw(st.integers(0, len(stream) - 1))
            if action == "drop":
                del stream[at]
            elif action == "flip":
                stream[at] ^= 1 << data.draw(st.integers(0, 7))
            else:
                stream[at:at] = b"PR"
    cuts = data.draw(CUTS)
    assert chunked(bytes(stream), cuts) == reference(bytes(stream), MAX)


@st.composite
def runs(draw: st.DrawFn) -> bytes:
    """Runs of frames of one length back to back (the deframer checks those a batch at a time),
    the runs of a few lengths, some frames damaged in header, payload or CRC."""
    stream = bytearray()
    for _ in range(draw(st.integers(1, 4))):
        size = draw(st.sampled_from([0, 1, 7, MAX, MAX + 1]))
        for _ in range(draw(st.integers(1, 40))):
            stream += frame(draw(st.binary(min_size=size, max_size=size)))
    for _ in range(draw(st.integers(0, 3))):
        at = draw(st.integers(0, len(stream) - 1))
        stream[at] ^= 1 << draw(st.integers(0, 7))
    return bytes(stream)


@given(runs(), CUTS)
def test_runs_of_equal_frames_give_what_the_rules_give(stream: bytes, cuts: list[int]) -> None:
    payloads, stats, left = reference_stats(stream, MAX)
    deframer = Deframer(max_length=MAX)
    edges = sorted({0, len(stream), *(c % (len(stream) + 1) for c in cuts)})
    out = [p for a, b in itertools.pairwise(edges) for p in deframer.feed(stream[a:b])]
    assert out == payloads
    assert deframer.stats() == stats
    assert deframer.buffered() == left


def test_a_long_run_with_a_bad_frame_late_in_it() -> None:
    payloads = [n.to_bytes(2, "big") * 5 for n in range(300)]
    stream = bytearray(b"".join(frame(p) for p in payloads))
    stream[250 * 16 + 9] ^= 0xFF  # frame 250's payload
    deframer = Deframer(max_length=MAX)
    assert deframer.feed(bytes(stream)) == payloads[:250] + payloads[251:]
    assert deframer.stats().rejected == {"bad_crc": 1}
    assert deframer.stats().discarded_bytes == {"bad_crc": 1, "garbage": 15}


def test_a_typed_buffer_counts_in_bytes() -> None:
    deframer = Deframer(max_length=MAX)
    framed = frame(b"abc")
    assert deframer.feed(framed[:5]) == []
    assert deframer.feed(memoryview(array("H", framed[5:]))) == [b"abc"]  # 4 bytes, 2 items
    assert deframer.buffered() == 0


def test_a_broken_run_wastes_no_more_crcs_than_the_run_delivered(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    crcs: list[int] = []
    crc_hqx = binascii.crc_hqx

    def counted(data: bytes, value: int) -> int:
        crcs.append(len(data))
        return crc_hqx(data, value)

    monkeypatch.setattr(binascii, "crc_hqx", counted)
    deframer = Deframer(max_length=MAX)
    for _ in range(6):  # one frame a chunk: batches of one, which must not grow the next batch
        deframer.feed(frame(bytes(MAX)))
    broken = bytearray(frame(bytes(MAX)))
    broken[-1] ^= 1
    del crcs[:]
    assert (
        len(deframer.feed(frame(bytes(MAX)) * 2 + bytes(broken) + frame(bytes(MAX)) * 300)) == 302
    )
    assert len(crcs) <= 303 + 1 + 15  # every frame, the bad one again on its own, the waste
    bad = bytearray(frame(bytes(10)))
    bad[-1] ^= 1
    # A long run (batches grow to 256), one frame of another length, two good ones, a bad one.
    stream = frame(bytes(MAX)) * 600 + frame(bytes(10)) * 3 + bytes(bad) + frame(bytes(10)) * 300
    del crcs[:]
    assert len(deframer.feed(stream)) == 903
    # The second run starts at a batch of 16, so the damage wastes at most 15 CRCs.
    assert len(crcs) <= 904 + 1 + 15
