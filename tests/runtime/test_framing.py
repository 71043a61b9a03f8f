"""Proton serial framing: the test vectors; the Deframer held to a byte-at-a-time reading of the
rule, whatever the chunking, noise and damage; flush; validation; the cost of bad input.

The Deframer checks runs of equal-length frames a batch at a time and overlapping candidates with
prefix CRCs (speed tricks for benchmarks/bench_framing.py); ``reference_stats`` is the plain
version both are held to: the rule read literally, one byte at a time.
"""

import binascii
import itertools
import json
import random
import subprocess
import sys
from array import array
from collections import Counter
from collections.abc import Callable

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import erc_codec
from erc_codec.runtime import Deframer, DeframerStats, frame
from erc_codec.runtime._framing import crc16

MAX = 64
STOP = bytes.fromhex("5052 0300 820100 97aa")  # the rover's STOP command, framed
FORGED = bytes.fromhex("5052 0200 ffff 0000")  # CRC-16/CCITT-FALSE of ff ff is 0


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
    too_long = frame(bytes(263))  # PBEnvelope_size is 262
    assert deframer.feed(too_long + frame(bytes(262))) == [bytes(262)]
    assert deframer.stats().rejected == {"too_long": 1}


def test_a_deframer_without_its_maximum_is_deprecated_and_takes_the_packaged_envelopes() -> None:
    with pytest.warns(DeprecationWarning, match=r"Deframer\(\) without max_length"):
        deframer = Deframer()
    assert deframer.feed(frame(bytes(263)) + frame(bytes(262))) == [bytes(262)]


@pytest.mark.parametrize(
    ("bad", "problem"),
    [
        (2.5, "must be a whole number of at least 0, not 2.5"),  # was taken: 2.5 < 3
        (True, "must be a whole number of at least 0, not True"),  # was taken as 1
        ("9", "must be a whole number of at least 0, not '9'"),
        (-1, "must be a whole number of at least 0, not -1"),
        (0x10000, "must be within 0..65535, not 65536"),
    ],
)
def test_a_maximum_that_is_no_length_is_refused(bad: object, problem: str) -> None:
    with pytest.raises(ValueError, match=rf"^max_length {problem}$"):
        Deframer(max_length=bad)  # type: ignore[arg-type]
    assert Deframer(max_length=0xFFFF).feed(frame(b"x")) == [b"x"]


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


Accept = Callable[[bytes], bool] | None


def reference(stream: bytes, max_length: int, accept: Accept = None) -> list[bytes]:
    """The framing rule applied to the whole stream, the slow obvious way."""
    return reference_stats(stream, max_length, accept)[0]


def reference_stats(
    stream: bytes, max_length: int, accept: Accept = None
) -> tuple[list[bytes], DeframerStats, int]:
    """The payloads, the counters and the bytes left held, by the rule read literally: the bytes
    arrive one at a time, and after each one every candidate it completes is decided, the
    earliest start first; decided bytes at the front of the window leave it."""
    found: list[bytes] = []
    fate: dict[int, str] = {}  # start of a candidate → why it was rejected
    discarded: Counter[str] = Counter()
    rejected: Counter[str] = Counter()
    pos = 0  # the bytes before pos are decided: in a frame, or discarded

    def leaves(first: int, reason: str) -> None:
        discarded[reason] += 1
        if reason != "garbage":
            rejected[reason] += 1

    for n in range(1, len(stream) + 1):  # stream[:n] has arrived
        for start in range(pos, n - 3):  # every candidate whose length has arrived
            if stream[start : start + 2] != b"PR" or start in fate:
                continue
            verdict = judged(stream, start, n, max_length, accept)
            if verdict == "frame":  # delivered: every candidate before it drops
                for first in range(pos, start):
                    magic = stream[first : first + 2] == b"PR"
                    leaves(first, fate.get(first, "overtaken" if magic else "garbage"))
                found.append(stream[start + 4 : n - 2])
                pos = n
                fate.clear()
                break
            if verdict:
                fate[start] = verdict
        while pos < n:
            if pos in fate:
                leaves(pos, fate.pop(pos))
            elif stream[pos : min(pos + 2, n)] in (b"PR", b"P"):
                break  # a candidate not yet decided (or perhaps the start of one)
            else:
                leaves(pos, "garbage")
            pos += 1
    return found, DeframerStats(len(found), dict(discarded), dict(rejected)), len(stream) - pos


def judged(stream: bytes, start: int, n: int, max_length: int, accept: Accept) -> str:
    """What the first ``n`` bytes say of the candidate at ``start``: "frame", why it fails, or
    nothing yet."""
    length = int.from_bytes(stream[start + 2 : start + 4], "little")
    if length > max_length:
        return "too_long"
    if start + 6 + length != n:
        return ""  # not complete (a candidate that was is decided already)
    payload = stream[start + 4 : n - 2]
    if crc16(payload) != int.from_bytes(stream[n - 2 : n], "little"):
        return "bad_crc"
    if accept is not None and not accept(payload):
        return "undecodable"
    return "frame"


def test_the_reference_reads_clean_streams_as_frames() -> None:
    payloads = [b"", b"PR\x00\x00", b"x" * MAX, b"PR"]
    stream = b"".join(frame(p) for p in payloads)
    assert reference_stats(stream, MAX) == (payloads, DeframerStats(4, {}, {}), 0)
    assert reference_stats(stream + b"PR\x05", MAX)[2] == 3
    assert reference_stats(b"ab" + stream[:-1], MAX)[1:] == (
        DeframerStats(3, {"garbage": 2}, {}),
        len(frame(b"PR")) - 1,
    )


def chunked(stream: bytes, cuts: list[int]) -> list[bytes]:
    return deframed(stream, cuts)[0]


def deframed(
    stream: bytes, cuts: list[int], max_length: int = MAX, accept: Accept = None
) -> tuple[list[bytes], DeframerStats, int]:
    """The payloads, the counters and the bytes held, after feeding ``stream`` cut at ``cuts``."""
    deframer = Deframer(max_length=max_length, accept=accept)
    out: list[bytes] = []
    edges = sorted({0, len(stream), *(c % (len(stream) + 1) for c in cuts)})
    for start, stop in itertools.pairwise(edges):
        out += deframer.feed(stream[start:stop])
        assert deframer.buffered() <= max_length + 5  # bounded, whatever arrives
    return out, deframer.stats(), deframer.buffered()


NO_P = st.binary(max_size=12).map(lambda b: b.replace(b"P", b"Q"))
PAYLOADS = st.lists(st.binary(max_size=MAX), max_size=8)
CUTS = st.lists(st.integers(0, 10_000), max_size=12)


@given(PAYLOADS, st.lists(NO_P, min_size=9, max_size=9), CUTS)
def test_every_frame_survives_any_chunking_and_noise(
    payloads: list[bytes], noise: list[bytes], cuts: list[int]
) -> None:
    stream = b"".join(n + frame(p) for n, p in zip(noise, payloads, strict=False)) + noise[-1]
    out = chunked(stream, cuts)
    assert out == reference(stream, MAX)
    if not any(b"PR" in p for p in payloads):  # else one may hold a frame, which wins
        assert out == payloads


@given(PAYLOADS, st.lists(NO_P, min_size=9, max_size=9))
def test_every_split_point_gives_the_same_frames(payloads: list[bytes], noise: list[bytes]) -> None:
    stream = b"".join(n + frame(p) for n, p in zip(noise, payloads, strict=False))
    whole = deframed(stream, [])
    if not any(b"PR" in p for p in payloads):
        assert whole[0] == payloads
    for cut in range(len(stream) + 1):
        assert deframed(stream, [cut]) == whole


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
    assert deframed(bytes(stream), cuts) == reference_stats(bytes(stream), MAX)


@st.composite
def tangled(draw: st.DrawFn, max_length: int = MAX) -> bytes:
    """Streams where candidates overlap: frames, frames inside frames, headers cut short or
    claiming any length, lone halves of a magic, noise, the forged ``ff ff`` frame."""
    small = st.binary(max_size=12)
    token = st.one_of(
        small.map(frame),
        small.map(lambda p: frame(frame(p))),  # loses to the frame inside it
        st.tuples(small, small).map(lambda pq: frame(pq[0] + frame(pq[1]) + pq[0])),
        st.tuples(small, st.integers(0, max_length + 2)).map(
            lambda pl: frame(pl[0])[: pl[1] % (len(pl[0]) + 6)]  # a frame cut short
        ),
        st.integers(0, min(max_length + 2, 0xFFFF)).map(lambda n: b"PR" + n.to_bytes(2, "little")),
        st.sampled_from([b"P", b"R", b"PR", FORGED]),
        small,
    )
    return b"".join(draw(st.lists(token, max_size=14)))


@given(tangled(), CUTS)
def test_overlapping_candidates_give_what_the_rules_give(stream: bytes, cuts: list[int]) -> None:
    assert deframed(stream, cuts) == reference_stats(stream, MAX)


@given(tangled(), CUTS)
def test_a_refusing_accept_gives_what_the_rules_give(stream: bytes, cuts: list[int]) -> None:
    def accept(payload: bytes) -> bool:
        return not payload.startswith(b"\xff") and len(payload) != 3

    assert deframed(stream, cuts, accept=accept) == reference_stats(stream, MAX, accept)


@settings(deadline=None)
@given(tangled(max_length=0xFFFF), CUTS)
def test_the_longest_maximum_gives_what_the_rules_give(stream: bytes, cuts: list[int]) -> None:
    assert deframed(stream, cuts, 0xFFFF) == reference_stats(stream, 0xFFFF)


@given(tangled(), st.data())
def test_the_counters_at_any_point_are_those_of_the_bytes_so_far(
    stream: bytes, data: st.DataObject
) -> None:
    cut = data.draw(st.integers(0, len(stream)))
    deframer = Deframer(max_length=MAX)
    deframer.feed(stream[:cut])
    _, stats, held = reference_stats(stream[:cut], MAX)
    assert (deframer.stats(), deframer.buffered()) == (stats, held)
    deframer.feed(stream[cut:])
    _, stats, held = reference_stats(stream, MAX)
    assert deframer.flush() == stream[len(stream) - held :]
    discarded = stats.discarded_bytes | ({"unfinished": held} if held else {})
    assert deframer.stats() == stats._replace(discarded_bytes=discarded)
    assert deframer.buffered() == 0


@st.composite
def runs(draw: st.DrawFn) -> bytes:
    """Runs of frames of one length back to back (the deframer checks those a batch at a time),
    the runs of a few lengths, some frames holding a frame or a header, some frames damaged in
    header, payload or CRC."""
    stream = bytearray()
    for _ in range(draw(st.integers(1, 4))):
        size = draw(st.sampled_from([0, 1, 7, 20, MAX, MAX + 1]))
        for _ in range(draw(st.integers(1, 40))):
            payload = draw(st.binary(min_size=size, max_size=size))
            if size >= 6 and draw(st.integers(0, 9)) == 0:
                inner = draw(st.one_of(st.binary(max_size=size - 6).map(frame), st.just(b"PR")))
                at = draw(st.integers(0, size - len(inner)))
                payload = payload[:at] + inner + payload[at + len(inner) :]
            stream += frame(payload)
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


def test_a_frame_behind_a_glitch_comes_out_at_its_last_byte() -> None:
    """A 4-byte glitch reads as a header claiming 240 bytes: the STOP frame after it must not
    wait for them (nor be lost when the stream ends first)."""
    assert frame(bytes.fromhex("820100")) == STOP
    stream = b"PR\xf0\x00" + STOP
    deframer = Deframer(max_length=255)
    assert deframer.feed(stream) == [STOP[4:-2]]
    assert deframer.stats() == DeframerStats(1, {"garbage": 3, "overtaken": 1}, {"overtaken": 1})
    assert deframer.buffered() == 0
    one_at_a_time = Deframer(max_length=255)
    out = [one_at_a_time.feed(stream[i : i + 1]) for i in range(len(stream))]
    assert out == [[]] * (len(stream) - 1) + [[STOP[4:-2]]]
    assert one_at_a_time.stats() == deframer.stats()


def test_the_command_line_decodes_the_frame_behind_a_glitch() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "erc_codec", "decode", "--framed", "--raw"],
        input=b"PR\xf0\x00" + STOP,
        capture_output=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["kind"] == "control_mode"
    assert done.stderr == (
        b"1 frame, 0 undecodable, 1 frame rejected (overtaken 1), "
        b"4 bytes discarded (garbage 3, overtaken 1)\n"
    )


def test_a_frame_holding_a_whole_frame_loses_to_it() -> None:
    inner = frame(b"inner")
    outer = frame(b"<" + inner + b">")
    deframer = Deframer(max_length=MAX)
    assert deframer.feed(outer) == [b"inner"]
    assert deframer.stats().rejected == {"overtaken": 1}
    assert sum(deframer.stats().discarded_bytes.values()) == len(outer) - len(inner)


def test_flush_discards_and_returns_what_the_end_of_the_stream_cut_off() -> None:
    deframer = Deframer(max_length=255)
    cut = frame(b"cut off at the end")[:-1]
    assert deframer.feed(b"x" + frame(b"kept") + cut) == [b"kept"]
    assert deframer.buffered() == len(cut)
    assert deframer.flush() == cut
    assert deframer.stats() == DeframerStats(1, {"garbage": 1, "unfinished": len(cut)}, {})
    assert (deframer.buffered(), deframer.flush()) == (0, b"")
    assert deframer.feed(b"R" + frame(b"next")) == [b"next"]  # afresh: the "R" is garbage
    assert deframer.stats().discarded_bytes == {"garbage": 2, "unfinished": len(cut)}


def test_flush_discards_overlapping_candidates_too() -> None:
    deframer = Deframer(max_length=0xFFFF)
    held = b"PR\xf0\x00" + b"PR\xff\xff" * 3 + frame(b"almost")[:-2]
    assert deframer.feed(held[:5]) + deframer.feed(held[5:]) == []
    assert deframer.flush() == held
    assert deframer.stats() == DeframerStats(0, {"unfinished": len(held)}, {})
    assert deframer.feed(b"PR\xf0\x00" + STOP) == [STOP[4:-2]]


def test_ff_ff_and_zeros_pass_the_crc() -> None:
    """CRC-16's blind spot: without more checks the forged frame is a frame."""
    assert all(crc16(b"\xff\xff" + bytes(n)) == 0 for n in range(300))
    deframer = Deframer(max_length=255)
    forged = [frame(b"\xff\xff" + bytes(n)) for n in (0, 1, 10)]
    assert forged[0] == FORGED
    assert deframer.feed(b"".join(forged)) == [
        b"\xff\xff",
        b"\xff\xff\x00",
        b"\xff\xff" + bytes(10),
    ]


def test_validation_rejects_a_frame_the_codec_cannot_decode(codec: erc_codec.Codec) -> None:
    deframer = Deframer.for_codec(codec, validate=True)
    assert deframer.feed(FORGED + STOP) == [STOP[4:-2]]
    assert deframer.stats() == DeframerStats(
        1, {"undecodable": 1, "garbage": len(FORGED) - 1}, {"undecodable": 1}
    )
    plain = Deframer.for_codec(codec)
    assert plain.feed(FORGED + STOP) == [b"\xff\xff", STOP[4:-2]]


def test_validation_finds_the_frame_a_forged_one_hid(codec: erc_codec.Codec) -> None:
    """A frame with a good CRC (forged, or a 1-in-65,536 accident) that starts before a real
    one and ends inside it would take the real one's place; validation gives it back."""
    inner = STOP
    k = 5  # the forged frame ends with the real one's 5th and 6th bytes as its CRC
    wanted = int.from_bytes(inner[k : k + 2], "little")
    junk = next(
        bytes([0xFF, a, b])
        for a in range(256)
        for b in range(256)
        if crc16(bytes([0xFF, a, b]) + inner[:k]) == wanted
    )
    outer = junk + inner[:k]
    stream = b"PR" + len(outer).to_bytes(2, "little") + outer + inner[k:]
    assert Deframer.for_codec(codec).feed(stream) == [outer]
    deframer = Deframer.for_codec(codec, validate=True)
    assert deframer.feed(stream) == [inner[4:-2]]
    assert deframer.stats().rejected == {"undecodable": 1}
    assert Deframer(max_length=255, accept=lambda p: p != outer).feed(stream) == [inner[4:-2]]


def adversarial(size: int) -> dict[str, bytes]:
    """The bad-input campaign's streams, about ``size`` bytes each."""
    rng = random.Random(20261201)
    glitch = b"".join(b"PR\xf0\x00" + frame(rng.randbytes(60)) for _ in range(size // 70))
    noise = b"".join(rng.randbytes(6) + b"PR" for _ in range(size // 8))
    return {
        "PR ff ff": b"PR\xff\xff" * (size // 4),
        "PR": b"PR" * (size // 2),
        "a glitch before every frame": glitch,
        "noise full of PR": noise,
    }


@pytest.mark.parametrize("max_length", [0xFFFF, 255])
def test_crc_work_is_linear_in_the_bytes_fed(
    monkeypatch: pytest.MonkeyPatch, max_length: int
) -> None:
    """Each candidate costs a bounded amount of CRC work, not up to max_length bytes: at most
    three passes over each byte (once whole, twice by the running CRCs of overlaps)."""
    crc_hqx = binascii.crc_hqx
    fed = [0]

    def counted(data: bytes, value: int) -> int:
        fed[0] += len(data)
        return crc_hqx(data, value)

    Deframer(max_length=0xFFFF).feed(b"PR\x00\x00" * 3)  # builds the zeros' tables
    monkeypatch.setattr(binascii, "crc_hqx", counted)
    for chunk in (4096, 777):
        for name, stream in adversarial(150_000).items():
            fed[0] = 0
            deframer = Deframer(max_length=max_length)
            for start in range(0, len(stream), chunk):
                deframer.feed(stream[start : start + chunk])
            assert fed[0] <= 3 * len(stream), (name, chunk, fed[0] / len(stream))


def test_a_run_of_frames_stops_at_a_frame_holding_a_frame() -> None:
    payloads = [bytes([n]) * 20 for n in range(40)]
    payloads[25] = b"ab" + frame(b"xyz") + bytes(9)  # the frame inside comes out instead
    stream = b"".join(frame(p) for p in payloads)
    expected = [*payloads[:25], b"xyz", *payloads[26:]]
    assert reference(stream, MAX) == expected
    for chunk in (len(stream), 4096, 100, 7):
        deframer = Deframer(max_length=MAX)
        out = [p for at in range(0, len(stream), chunk) for p in deframer.feed(stream[at:][:chunk])]
        assert out == expected
        assert deframer.stats() == reference_stats(stream, MAX)[1]


def test_a_run_of_frames_stops_at_a_header_holding_a_frame() -> None:
    """A length of 0x5250 is written "PR": each header holds a candidate, two bytes in."""
    length = 0x5250
    harmless = b"\xff\xff" + bytes(length - 2)  # that candidate is longer than its frame
    holding = b"\x03\x00abc" + crc16(b"abc").to_bytes(2, "little") + bytes(length - 7)
    payloads = [harmless] * 6 + [holding] + [harmless] * 3
    stream = b"".join(frame(p) for p in payloads)
    for chunk in (len(stream), 4096):
        deframer = Deframer(max_length=0xFFFF)
        out = [p for at in range(0, len(stream), chunk) for p in deframer.feed(stream[at:][:chunk])]
        assert out == [harmless] * 6 + [b"abc"] + [harmless] * 3
        assert deframer.stats().rejected == {"overtaken": 1}
