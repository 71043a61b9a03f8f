"""DetectionAssembler: whole frames once, in order; every loss and rejection reported; bounded."""

import math
import random

import pytest
from google.protobuf.message import Message
from hypothesis import given
from hypothesis import strategies as st

import erc_codec
from erc_codec.runtime import DetectionAssembler, DetectionFrame, DetectionLoss, Rejected

CODEC = erc_codec.Codec.default()
Detected = CODEC.message_class("BasestationDetectedObject")


def obj(frame: int, total: int, index: int, class_id: int = 0) -> Message:
    return Detected(frame_id=frame, total_count=total, index=index, class_id=class_id)


def test_a_frame_comes_out_whole_and_in_order() -> None:
    assembler = DetectionAssembler()
    parts = [obj(7, 3, i, class_id=10 + i) for i in (2, 0, 1)]
    assert assembler.add(parts[0], 0.0) is None
    assert assembler.add(parts[1], 0.1) is None
    frame = assembler.add(parts[2], 0.2)
    assert frame is not None
    assert frame.frame_id == 7
    assert [o.index for o in frame.objects] == [0, 1, 2]
    assert assembler.pending() == 0
    assert assembler.stats().completed == 1


def test_duplicates_are_ignored_also_after_completion() -> None:
    assembler = DetectionAssembler()
    assert assembler.add(obj(1, 2, 0), 0) is None
    assert assembler.add(obj(1, 2, 0), 0) is None
    assert assembler.add(obj(1, 2, 1), 0) is not None
    assert assembler.add(obj(1, 2, 1), 0) is None  # late repeat of a returned frame
    assert assembler.stats().duplicates == 2
    assert assembler.stats().completed == 1


def test_an_empty_frame() -> None:
    frame = DetectionAssembler().add(obj(3, 0, 0), 0)
    assert frame == DetectionFrame(3, ())


@pytest.mark.parametrize(
    ("first", "second", "reason"),
    [
        (obj(1, 2, 0), obj(1, 2, 2), "index_out_of_range"),
        (obj(1, 2, 0), obj(1, 3, 1), "total_count_changed"),
        (obj(1, 2, 0), obj(2, 1000, 0), "too_many_objects"),
    ],
)
def test_impossible_objects_are_rejected(first: Message, second: Message, reason: str) -> None:
    rejected: list[Rejected] = []
    assembler = DetectionAssembler(on_reject=rejected.append)
    assembler.add(first, 0)
    assert assembler.add(second, 0) is None
    assert [r.reason for r in rejected] == [reason]
    assert assembler.stats().rejected == {reason: 1}


def test_incomplete_frames_time_out_or_are_superseded() -> None:
    lost: list[DetectionLoss] = []
    assembler = DetectionAssembler(timeout=0.5, keep_frames=2, on_loss=lost.append)
    assembler.add(obj(1, 3, 0), 0.0)
    assembler.add(obj(2, 3, 0), 0.1)
    assembler.add(obj(3, 2, 1), 0.2)  # a third incomplete frame: the oldest goes
    assert lost == [DetectionLoss(1, 1, 3, "superseded")]
    assert assembler.poll(0.55) == []  # frame 2 started at 0.1: not yet
    assert assembler.poll(0.65) == [DetectionLoss(2, 1, 3, "timeout")]
    assert assembler.poll(0.75) == [DetectionLoss(3, 1, 2, "timeout")]
    assert assembler.stats().lost == {"superseded": 1, "timeout": 2}
    assert assembler.pending() == 0


@st.composite
def traffic(draw: st.DrawFn) -> tuple[dict[int, int], list[tuple[int, int]], list[float]]:
    totals = draw(st.dictionaries(st.integers(0, 2**32 - 1), st.integers(0, 6), max_size=8))
    sent: list[tuple[int, int]] = []
    for frame, total in totals.items():
        for index in range(max(total, 1)):
            copies = draw(st.sampled_from([0, 1, 1, 1, 2]))  # lost, once, or duplicated
            sent += [(frame, index)] * copies
    order = draw(st.randoms(use_true_random=False))
    order.shuffle(sent)
    steps = draw(
        st.lists(st.floats(-1, 0.3, allow_nan=False), min_size=len(sent), max_size=len(sent))
    )
    return totals, sent, steps


@given(traffic(), st.integers(1, 4))
def test_nothing_is_lost_or_invented_silently(
    case: tuple[dict[int, int], list[tuple[int, int]], list[float]], keep: int
) -> None:
    totals, sent, steps = case
    lost: list[DetectionLoss] = []
    assembler = DetectionAssembler(
        timeout=0.5, keep_frames=keep, max_objects=6, on_loss=lost.append
    )
    frames = []
    now = 0.0
    for (frame, index), step in zip(sent, steps, strict=True):
        now += step  # mostly forward, sometimes back
        done = assembler.add(obj(frame, totals[frame], index), now)
        if done is not None:
            frames.append(done)
        assert set(assembler.poll(now)) <= set(lost)  # returned and reported alike
        assert assembler.pending() <= keep
    assembler.poll(now + 10)
    stats = assembler.stats()
    for whole in frames:  # whole, ordered, and the objects that were sent
        total = totals[whole.frame_id]
        assert [o.index for o in whole.objects] == list(range(total))
        assert all(o.frame_id == whole.frame_id for o in whole.objects)
    started = {frame for frame, _ in sent}
    returned = {frame.frame_id for frame in frames}
    dropped = {loss.frame_id for loss in lost}
    # Every frame that got an object is either returned or reported lost (a late object can
    # restart a lost frame, which then is lost or returned again: count reports, not frames).
    assert started == returned | dropped
    assert stats.completed == len(frames)
    assert sum(stats.lost.values()) == len(lost)
    assert stats.rejected == {}


def test_memory_stays_bounded_under_a_flood() -> None:
    rng = random.Random(7)
    assembler = DetectionAssembler(keep_frames=4, max_objects=16)
    for _ in range(20_000):
        total = rng.randint(1, 16)
        assembler.add(obj(rng.getrandbits(32), total, rng.randrange(total)), 0.0)
        assert assembler.pending() <= 4


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, -1.0, 0, True, "1"])
def test_the_timeout_is_positive_finite_seconds(bad: object) -> None:
    with pytest.raises(
        ValueError, match=rf"^timeout must be a positive, finite number of seconds, not {bad!r}$"
    ):
        DetectionAssembler(timeout=bad)  # type: ignore[arg-type]


@pytest.mark.parametrize("bad", [math.inf, math.nan, 0, -3, 4.0, True, "4"])
@pytest.mark.parametrize("name", ["keep_frames", "max_objects"])
def test_the_bounds_are_whole_numbers_of_at_least_one(name: str, bad: object) -> None:
    # keep_frames=inf or max_objects=nan would leave memory unbounded.
    with pytest.raises(ValueError, match=rf"^{name} must be a whole number of at least 1, not"):
        DetectionAssembler(**{name: bad})  # type: ignore[arg-type]


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_a_clock_reading_that_is_not_finite_is_refused_and_changes_nothing(bad: float) -> None:
    lost: list[DetectionLoss] = []
    assembler = DetectionAssembler(timeout=0.5, on_loss=lost.append)
    assert assembler.add(obj(1, 2, 0), 0.0) is None
    with pytest.raises(ValueError, match=rf"^now must be a .* in seconds, not {bad}$"):
        assembler.add(obj(2, 2, 0), bad)
    with pytest.raises(ValueError, match=r"^now must be a finite clock reading"):
        assembler.poll(bad)
    assert assembler.pending() == 1  # frame 2 was not started, frame 1 not dropped
    assert assembler.poll(1.0) == [DetectionLoss(1, 1, 2, "timeout")]  # and the timeout still works
    assert lost == [DetectionLoss(1, 1, 2, "timeout")]
