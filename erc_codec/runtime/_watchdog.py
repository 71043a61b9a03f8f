"""Liveness: which periodic messages are arriving, and the moment one stops ("engage the brakes").

Guarantees:
- The clock is the caller's: ``now`` in seconds, any origin.
- Nothing here reads time, sleeps or starts a thread.
- A clock that steps backwards never fires a timeout early. It delays one by at most one timeout,
  as the last arrival is re-anchored to the new clock.
- Memory per kind is bounded: 16 arrival times, 20 counters.
- Periods and timeouts must be positive and finite; ``now`` must be finite.
- A NaN or an infinity is a ``ValueError`` naming it, and changes nothing. A NaN arrival time
  would otherwise compare false with every later clock reading, and the kind would never time
  out again.

Each watched kind follows Proton's node states:
- INACTIVE until its first arrival;
- ACTIVE while arrivals keep within the timeout;
- INACTIVE again once ``poll`` sees the timeout pass, which calls ``on_timeout(kind)`` once;
- the next arrival calls ``on_recover(kind)``.

Every kind reported, watched or not, has its arrival rate measured two ways:
- ``rate``, over its last 16 arrivals;
- ``recent_rate``, over the 5 s before a given moment. This is what a live display shows. It
  falls to 0 once a kind stops. A burst counts as so many arrivals in the window, not as the rate
  between two of them.

Timeouts from the wire:
- ``seen(kind, now, timeout=...)`` takes the timeout the sender advertised: the envelope's
  ``timeout`` metadata, converted to seconds.
- An advertised timeout applies to the gap it promises, the one up to the next arrival, which
  brings its own.
- A configured kind is watched with the shorter of the configured and the advertised timeout. So
  a sender can make its watch stricter, never looser.
- An arrival advertising 0 or ``None`` is watched with the configured timeout. So a sender cannot
  switch its own brake off, nor leave a shortened timeout behind for arrivals that promise
  nothing.
- A kind nobody configured is watched while its arrivals advertise a timeout, and not after one
  that advertises none.
"""

import enum
import math
from collections import deque
from collections.abc import Callable

from .checks import duration, instant

__all__ = ["Liveness", "Watchdog"]

_RATE_WINDOW = 16  # arrivals the measured rate is computed over
_BUCKET = 0.25  # seconds: recent_rate counts arrivals per quarter second ...
_RECENT = 5.0  # ... over the last 5 s
_BUCKETS = int(_RECENT / _BUCKET)


class Liveness(enum.Enum):
    """Proton's node states, per watched kind."""

    UNCONFIGURED = "unconfigured"  # not watched
    INACTIVE = "inactive"  # watched, but nothing arrived within the timeout (or ever)
    ACTIVE = "active"  # arriving


class _Watched:
    __slots__ = ("configured", "last", "period", "state", "timed_out", "timeout")

    def __init__(self, period: float | None, timeout: float, configured: bool) -> None:
        self.period = period  # None: watched only because a sender advertised a timeout
        self.timeout = timeout
        self.configured = timeout if configured else math.inf  # the ceiling an advert cannot pass
        self.state = Liveness.INACTIVE
        self.last: float | None = None
        self.timed_out = False  # INACTIVE because a timeout passed, not because nothing came yet


class Watchdog:
    """Expected periods per payload kind, checked against the arrivals the caller reports."""

    def __init__(
        self,
        on_timeout: Callable[[str], object] | None = None,
        on_recover: Callable[[str], object] | None = None,
        timeout_periods: float = 3.0,
    ) -> None:
        self._on_timeout = on_timeout
        self._on_recover = on_recover
        self._timeout_periods = duration("timeout_periods", timeout_periods)
        self._watched: dict[str, _Watched] = {}
        self._arrivals: dict[str, deque[float]] = {}  # every kind seen: its last arrivals
        # Every kind seen: [quarter-second number, arrivals in it] of its last 5 s, and when it
        # first arrived (recent_rate).
        self._recent: dict[str, deque[list[int]]] = {}
        self._first: dict[str, float] = {}

    def watch(self, kind: str, period: float, timeout: float | None = None) -> None:
        """Expect ``kind`` every ``period`` seconds; time out after ``timeout`` (default: a
        multiple of the period, ``timeout_periods``) without one."""
        try:
            duration("period", period)
            if timeout is None:
                timeout = duration("period * timeout_periods", period * self._timeout_periods)
            else:
                duration("timeout", timeout)
        except ValueError as error:
            raise ValueError(f"{kind}: {error}") from None
        self._watched[kind] = _Watched(period, timeout, configured=True)

    def seen(self, kind: str, now: float, timeout: float | None = None) -> None:
        """``kind`` arrived at ``now``, its sender advertising ``timeout`` seconds until the next
        arrival (``None`` or 0: none).

        An unwatched kind arriving without a timeout only has its rate measured. With one, it
        becomes watched. A configured timeout wins over a longer advertised one. It applies again
        when an arrival advertises none.
        """
        instant("now", now)
        if timeout:
            try:
                duration("timeout", timeout)
            except ValueError as error:
                raise ValueError(f"{kind}: advertised {error}") from None
        arrivals = self._arrivals.get(kind)
        if arrivals is None:
            arrivals = self._arrivals[kind] = deque(maxlen=_RATE_WINDOW)
            self._recent[kind] = deque(maxlen=_BUCKETS)
            self._first[kind] = now
        arrivals.append(now)
        recent, number = self._recent[kind], int(now // _BUCKET)
        if recent and recent[-1][0] == number:
            recent[-1][1] += 1
        else:
            recent.append([number, 1])
        watched = self._watched.get(kind)
        if watched is None:
            if not timeout:
                return
            watched = self._watched[kind] = _Watched(None, timeout, configured=False)
        else:  # this arrival's promise replaces the last one's
            watched.timeout = min(watched.configured, timeout) if timeout else watched.configured
        watched.last = now
        if watched.state is Liveness.INACTIVE:
            watched.state = Liveness.ACTIVE
            if watched.timed_out:
                watched.timed_out = False
                if self._on_recover is not None:
                    self._on_recover(kind)
        if watched.timeout == math.inf:  # only its senders watched it, and this one promised none
            del self._watched[kind]

    def poll(self, now: float) -> list[str]:
        """Kinds whose timeout passed since the last poll (``on_timeout`` is called for each)."""
        instant("now", now)
        expired = []
        for kind, watched in self._watched.items():
            if watched.state is not Liveness.ACTIVE or watched.last is None:
                continue
            if now < watched.last:  # the clock stepped back: measure from here
                watched.last = now
            elif now - watched.last > watched.timeout:
                watched.state = Liveness.INACTIVE
                watched.timed_out = True
                expired.append(kind)
                if self._on_timeout is not None:
                    self._on_timeout(kind)
        return expired

    def state(self, kind: str) -> Liveness:
        """The kind's liveness."""
        watched = self._watched.get(kind)
        return Liveness.UNCONFIGURED if watched is None else watched.state

    def last_seen(self, kind: str) -> float | None:
        """When ``kind`` last arrived: the ``now`` of its last ``seen``, ``None`` before one."""
        arrivals = self._arrivals.get(kind)
        return arrivals[-1] if arrivals else None

    def rate(self, kind: str) -> float | None:
        """The measured arrival rate in Hz over the last arrivals, ``None`` before two."""
        arrivals = self._arrivals.get(kind)
        if arrivals is None or len(arrivals) < 2:
            return None
        span = arrivals[-1] - arrivals[0]
        return (len(arrivals) - 1) / span if span > 0 else None

    def recent_rate(self, kind: str, now: float) -> float:
        """Arrivals of ``kind`` per second over the 5 s before ``now``.

        - If its first arrival is later, the window starts there instead.
        - The window is at least a second, so one arrival is no rate of thousands.
        - It is 0.0 once the kind has not arrived for 5 s, and for a kind never seen.
        """
        instant("now", now)
        recent = self._recent.get(kind)
        if not recent:
            return 0.0
        oldest = int(now // _BUCKET) - _BUCKETS
        arrivals = sum(count for number, count in recent if number > oldest)
        return arrivals / min(_RECENT, max(now - self._first[kind], 1.0))

    def expected(self, kind: str) -> float | None:
        """The expected rate in Hz (1 / period), ``None`` for a kind with no configured period
        (unwatched, or watched only by its sender's advertised timeout)."""
        watched = self._watched.get(kind)
        return None if watched is None or watched.period is None else 1 / watched.period

    def timeout(self, kind: str) -> float | None:
        """The timeout ``kind`` is watched with now, in seconds; ``None`` for an unwatched kind."""
        watched = self._watched.get(kind)
        return None if watched is None else watched.timeout
