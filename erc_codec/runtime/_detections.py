"""Reassembly of camera frames sent one ``BasestationDetectedObject`` per datagram.

Each object carries ``frame_id``, ``total_count`` and its ``index`` (0 ≤ index < total_count).
A frame with no detections is one object with ``total_count`` 0.

Guarantees:
- A frame is returned once, when all ``total_count`` objects have arrived.
- Its objects are ordered by index, whatever the arrival order.
- Duplicates are ignored, and counted.
- An object that cannot belong to its frame is rejected, counted and reported. That is an index
  out of range, a ``total_count`` other than the frame's, or more objects than ``max_objects``.
- An incomplete frame is dropped when ``timeout`` passes after its first object.
- An incomplete frame is also dropped when starting a newer frame would leave more than
  ``keep_frames`` incomplete.
- Each drop is counted, and reported with how many objects had arrived.
- Memory stays bounded whatever arrives: at most ``keep_frames`` frames of at most
  ``max_objects`` objects, and the ids of the last completed frames (to recognise late repeats).

Inputs:
- The clock is the caller's ``now``; nothing here reads time.
- ``timeout`` must be positive and finite seconds.
- ``keep_frames`` and ``max_objects`` must be whole numbers of at least 1.
- ``now`` must be finite.
- Anything else (NaN, an infinity, a float count) is a ``ValueError`` naming it, and changes
  nothing.
"""

from collections import deque
from collections.abc import Callable
from typing import Any, NamedTuple

from .checks import count, duration, instant

__all__ = ["AssemblerStats", "DetectionAssembler", "DetectionFrame", "DetectionLoss", "Rejected"]

_REMEMBERED = 64  # completed frame ids kept to recognise late duplicates


class DetectionFrame(NamedTuple):
    """A whole camera frame: its id and its detected objects."""

    frame_id: int
    objects: tuple[Any, ...]  # the frame's BasestationDetectedObject messages, by index


class DetectionLoss(NamedTuple):
    """An incomplete frame that was given up."""

    frame_id: int
    received: int  # objects that had arrived
    expected: int  # its total_count
    reason: str  # "timeout" or "superseded"


class Rejected(NamedTuple):
    """A detected object that cannot belong to its frame.

    ``index`` is the object's own index field; as a field of a named tuple it hides
    ``tuple.index`` (use ``tuple(rejected).index(value)`` for that)."""

    frame_id: int
    index: int  # type: ignore[assignment]  # the object's index, as its message names it
    total_count: int
    reason: str  # "index_out_of_range", "total_count_changed" or "too_many_objects"


class AssemblerStats(NamedTuple):
    """A DetectionAssembler's counters since it was made (copies)."""

    completed: int  # frames returned
    duplicates: int  # objects that had arrived before (or whose frame was returned already)
    lost: dict[str, int]  # reason → frames
    rejected: dict[str, int]  # reason → objects


class _Pending:
    __slots__ = ("objects", "started", "total")

    def __init__(self, total: int, started: float) -> None:
        self.total = total
        self.started = started
        self.objects: dict[int, Any] = {}


class DetectionAssembler:
    """Collects detected objects by frame and returns each frame once it is whole."""

    def __init__(
        self,
        timeout: float = 1.0,
        keep_frames: int = 4,
        max_objects: int = 256,
        on_loss: Callable[[DetectionLoss], object] | None = None,
        on_reject: Callable[[Rejected], object] | None = None,
    ) -> None:
        self._timeout = duration("timeout", timeout)
        self._keep = count("keep_frames", keep_frames)
        self._max_objects = count("max_objects", max_objects)
        self._on_loss = on_loss
        self._on_reject = on_reject
        self._pending: dict[int, _Pending] = {}  # in the order frames started
        self._done: deque[int] = deque(maxlen=_REMEMBERED)
        self._completed = 0
        self._duplicates = 0
        self._lost: dict[str, int] = {}
        self._rejected: dict[str, int] = {}

    def add(self, detected: Any, now: float) -> DetectionFrame | None:
        """Take one ``BasestationDetectedObject``; the frame it completes, if any."""
        instant("now", now)
        frame_id, total, index = detected.frame_id, detected.total_count, detected.index
        pending = self._pending.get(frame_id)
        if pending is None and frame_id in self._done:
            self._duplicates += 1  # a late repeat of a frame already returned
            return None
        if total > self._max_objects:
            return self._reject(Rejected(frame_id, index, total, "too_many_objects"))
        if pending is not None and total != pending.total:
            return self._reject(Rejected(frame_id, index, total, "total_count_changed"))
        if total == 0:  # "no detections in this frame"
            return self._complete(frame_id, [])
        if index >= total:
            return self._reject(Rejected(frame_id, index, total, "index_out_of_range"))
        if pending is None:
            while len(self._pending) >= self._keep:
                self._lose(next(iter(self._pending)), "superseded")
            pending = self._pending[frame_id] = _Pending(total, now)
        if index in pending.objects:
            self._duplicates += 1
            return None
        pending.objects[index] = detected
        if len(pending.objects) < total:
            return None
        del self._pending[frame_id]
        return self._complete(frame_id, [pending.objects[i] for i in range(total)])

    def poll(self, now: float) -> list[DetectionLoss]:
        """Drop the frames whose timeout passed; what was lost."""
        instant("now", now)
        lost = []
        for frame_id, pending in list(self._pending.items()):
            if now < pending.started:  # the clock stepped back: measure from here
                pending.started = now
            elif now - pending.started > self._timeout:
                lost.append(self._lose(frame_id, "timeout"))
        return lost

    def pending(self) -> int:
        """How many incomplete frames are held."""
        return len(self._pending)

    def stats(self) -> AssemblerStats:
        """A snapshot of the counters."""
        return AssemblerStats(
            self._completed, self._duplicates, dict(self._lost), dict(self._rejected)
        )

    def _complete(self, frame_id: int, objects: list[Any]) -> DetectionFrame:
        self._done.append(frame_id)
        self._completed += 1
        return DetectionFrame(frame_id, tuple(objects))

    def _reject(self, rejected: Rejected) -> DetectionFrame | None:
        """Count and report ``rejected``; ``add`` returns what this returns (no frame)."""
        self._rejected[rejected.reason] = self._rejected.get(rejected.reason, 0) + 1
        if self._on_reject is not None:
            self._on_reject(rejected)
        return None

    def _lose(self, frame_id: int, reason: str) -> DetectionLoss:
        pending = self._pending.pop(frame_id)
        loss = DetectionLoss(frame_id, len(pending.objects), pending.total, reason)
        self._lost[reason] = self._lost.get(reason, 0) + 1
        if self._on_loss is not None:
            self._on_loss(loss)
        return loss
