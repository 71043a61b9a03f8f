"""What ``listen``'s table shows per kind: its arrivals over a sliding window, and when it last
arrived. The clock is the caller's (``now``, in seconds)."""

from collections import deque

__all__ = ["SlidingRates"]

_BUCKET = 0.25  # seconds
_WINDOW = 5.0  # seconds the rate is measured over
_BUCKETS = int(_WINDOW / _BUCKET)


class SlidingRates:
    """Arrivals per kind over a sliding window (``_WINDOW`` seconds in ``_BUCKETS`` buckets):
    the rate shown falls to 0 once a kind stops, and a burst counts as what it is, so many
    datagrams in the window, not as the rate between two of them."""

    def __init__(self) -> None:
        self.last: dict[str, float] = {}  # kind → when it last arrived
        self._first: dict[str, float] = {}
        self._buckets: dict[str, deque[list[int]]] = {}  # kind → [bucket number, arrivals]

    def seen(self, kind: str, now: float) -> None:
        number = int(now / _BUCKET)
        buckets = self._buckets.get(kind)
        if buckets is None:
            buckets = self._buckets[kind] = deque(maxlen=_BUCKETS)
            self._first[kind] = now
        if buckets and buckets[-1][0] == number:
            buckets[-1][1] += 1
        else:
            buckets.append([number, 1])
        self.last[kind] = now

    def rate(self, kind: str, now: float) -> float:
        """Arrivals per second over the window (or since the first arrival, if that is later,
        but at least a second: one arrival is no rate of thousands)."""
        buckets = self._buckets.get(kind)
        if not buckets:
            return 0.0
        oldest = int(now / _BUCKET) - _BUCKETS
        arrivals = sum(count for number, count in buckets if number > oldest)
        span = min(_WINDOW, max(now - self._first[kind], 1.0))
        return arrivals / span
