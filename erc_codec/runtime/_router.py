"""Routing: each datagram to the destinations that want its kind, in each destination's form, and
a failsafe message while a watched command stream is silent.

The router is sans-IO, like the ``Dispatcher`` beside it. The caller passes datagrams, their
source and the clock. The router returns what to send where.

Every datagram routed ends in exactly one place:
- forwarded, counted per destination;
- dropped as ``unrouted``: no route wants it;
- dropped as ``contract``: it decodes but breaks the fixed-size contract, so it cannot be re-sent
  as is to a fixed-size receiver;
- dropped as its ``DecodeError.reason``: ``unknown_member`` for a member this schema does not
  know, ``corrupt``, ...

With a ``debug`` destination, every dropped datagram goes there too, raw, as it arrived.

Forms: each destination takes one of
- ``exact``: prost and Google protobuf receivers, and boards decoding with plain ``pb_decode`` on
  the datagram's length;
- ``strip``: receivers that follow the envelope contract and restore the zeros;
- ``pad``.

A datagram is decoded once and encoded once, exact. The encoding carries the metadata it carried
(``timeout``). It also carries the fields this schema does not know, the payload's and those
beside it on the envelope, byte for byte. So a newer sender's fields reach a newer receiver
through an older relay. The stripped and padded forms are cut from that exact encoding.

Failsafe: the router watches ``kind`` for each ``Failsafe(kind, ...)``, one per kind.
- It watches with the failsafe's configured timeout.
- A sender's advertised ``timeout`` metadata can shorten that timeout for the gap up to the next
  arrival, never lengthen it (see ``Watchdog``).
- The timing is bounded: a timeout from 1 ms to 1 h, a rate from 0.01 to 1000 Hz. A value outside
  can only mean always braking or never.
- Only what reaches the failsafe's destinations counts as an arrival. That is a datagram of the
  kind forwarded to at least one of them, from one of its ``sources`` when it names them.
- A datagram dropped, or routed elsewhere only, does not release the brake.
- The first ``poll`` counts as an arrival. So a kind that never arrives engages its failsafe one
  timeout after the router started.
- Once the kind stays silent past its timeout, ``poll`` returns the failsafe message for its
  destinations at once. It then returns it every ``1 / rate`` seconds, until the kind arrives
  again.
- Each change is a ``FailsafeEvent``.
"""

from collections.abc import Callable, Iterable, Mapping
from typing import NamedTuple

from google.protobuf.message import Message

from erc_schema import DecodeError, EncodeError, SchemaError

from ..codec import Codec, Mode, in_form
from ._watchdog import Liveness, Watchdog
from .checks import duration

__all__ = [
    "Failsafe",
    "FailsafeEvent",
    "Outgoing",
    "Route",
    "Router",
    "RouterStats",
    "failsafe_timing",
]

_FORMS = ("exact", "strip", "pad")
_CACHED_SOURCES = 1024  # (source, kind) pairs whose destinations are remembered
_RATES = (0.01, 1000.0)  # Hz: a failsafe repeats at least every 100 s, at most every millisecond
_TIMEOUTS = (0.001, 3600.0)  # seconds of silence before a failsafe engages


class Route(NamedTuple):
    """Datagrams that match every criterion given go ``to`` these destinations.

    The criteria:
    - of one of ``kinds``;
    - from one of ``sources``;
    - of a member whose ``// direction:`` names this ``sender`` or ``receiver``.

    A route with no criterion takes every datagram.
    """

    to: tuple[str, ...]
    kinds: tuple[str, ...] | None = None
    sources: tuple[str, ...] | None = None
    sender: str | None = None
    receiver: str | None = None


class Failsafe(NamedTuple):
    """While ``kind`` is silent past ``timeout`` seconds, send ``message`` ``to`` these
    destinations, ``rate`` times a second.

    - The silence is counted from the router's first poll too.
    - ``message`` is a payload of the envelope.
    - Only a datagram of ``kind`` forwarded to one of these destinations counts as an arrival.
    - It must come from one of ``sources``; ``None`` means any source.
    """

    kind: str
    message: Message
    to: tuple[str, ...]
    rate: float
    timeout: float
    sources: tuple[str, ...] | None = None


class Outgoing(NamedTuple):
    """One datagram to send: the destination's name and the bytes, in its form."""

    destination: str
    data: bytes


class FailsafeEvent(NamedTuple):
    """A failsafe engaged (its kind went silent) or released (its kind arrived again)."""

    kind: str
    engaged: bool
    at: float  # the caller's clock


class RouterStats(NamedTuple):
    """Counters since the router was made (copies)."""

    forwarded: dict[str, int]  # destination → datagrams routed to it
    dropped: dict[str, int]  # reason → datagrams forwarded nowhere (but to debug)
    debug: int  # datagrams sent raw to the debug destination
    failsafe_sent: dict[str, int]  # destination → failsafe datagrams
    engaged: dict[str, int]  # kind → times its failsafe engaged
    released: dict[str, int]  # kind → times it recovered


class _Engaged:
    __slots__ = ("due",)

    def __init__(self, due: float) -> None:
        self.due = due


class Router:
    """Routes datagrams by kind, direction or source to named destinations, each in its form."""

    def __init__(
        self,
        codec: Codec,
        destinations: Mapping[str, Mode],
        routes: Iterable[Route],
        failsafes: Iterable[Failsafe] = (),
        debug: str | None = None,
        on_event: Callable[[FailsafeEvent], object] | None = None,
    ) -> None:
        """``destinations``: name → form. ``debug``: a destination name, or ``None``."""
        self._codec = codec
        self._decode, self._encode = codec.decode, codec.encode
        self._max = codec.max_size(codec.root)
        for name, form in destinations.items():
            if form not in _FORMS:
                raise ValueError(
                    f"destination {name!r}: form must be exact, strip or pad, not {form!r}"
                )
        self._forms = dict(destinations)
        self._routes = [self._resolved(route) for route in routes]
        if debug is not None:
            self._known(debug, "the debug destination")
        self._debug = debug
        self._on_event = on_event
        self._watchdog = Watchdog()
        self._failsafes: dict[str, tuple[float, list[Outgoing]]] = {}
        self._brakes: dict[str, tuple[frozenset[str], frozenset[object] | None]] = {}
        for failsafe in failsafes:
            self._add_failsafe(failsafe)
        self._started = False  # the first poll counts as an arrival of every watched kind
        self._engaged: dict[str, _Engaged] = {}
        self._table: dict[tuple[object, str], tuple[tuple[str, ...], bool]] = {}
        self._forwarded = dict.fromkeys(self._forms, 0)
        self._dropped: dict[str, int] = {}
        self._debug_sent = 0
        self._failsafe_sent = dict.fromkeys(self._forms, 0)
        self._engaged_count: dict[str, int] = {}
        self._released_count: dict[str, int] = {}

    @property
    def codec(self) -> Codec:
        """The codec this router decodes and encodes with."""
        return self._codec

    def route(self, data: bytes, source: object, now: float) -> list[Outgoing]:
        """The datagrams to send for ``data``, which arrived from ``source`` at ``now``."""
        try:
            decoded = self._decode(data)
        except DecodeError as error:
            return self._drop(error.reason, data)
        kind = decoded.kind
        key = (source, kind)
        entry = self._table.get(key)
        if entry is None:
            entry = self._targets(kind, source)
            if len(self._table) < _CACHED_SOURCES:
                self._table[key] = entry
        targets, brake = entry
        if not targets:
            return self._drop("unrouted", data)
        metadata = decoded.metadata
        try:
            if decoded.envelope_unknown_fields:  # sent on as they came, as protobuf relays do
                exact = self._codec.reencode(decoded, "exact")
            elif metadata:
                exact = self._encode(decoded.message, "exact", **metadata)
            else:
                exact = self._encode(decoded.message, "exact")
        except EncodeError:
            return self._drop("contract", data)
        if brake:  # it reaches the failsafe's destinations: an arrival
            advertised = decoded.timeout
            self._watchdog.seen(kind, now, advertised / 1000 if advertised else None)
            if kind in self._engaged:
                self._release(kind, now)
        out = []
        forwarded = self._forwarded
        for name in targets:
            out.append(Outgoing(name, in_form(exact, self._forms[name], self._max)))
            forwarded[name] += 1
        return out

    def poll(self, now: float) -> list[Outgoing]:
        """The failsafe datagrams due at ``now``.

        Call it often, every few milliseconds. The first call starts the watch, so a kind that
        has not arrived yet counts as arriving now.
        """
        if not self._started:
            self._start(now)
        for kind in self._watchdog.poll(now):
            if kind in self._failsafes:
                self._engage(kind, now)
        out: list[Outgoing] = []
        for kind, engaged in self._engaged.items():
            if engaged.due > now:
                continue
            interval, datagrams = self._failsafes[kind]
            out += datagrams
            for outgoing in datagrams:
                self._failsafe_sent[outgoing.destination] += 1
            engaged.due += interval
            if engaged.due <= now:  # a late poll: no burst to catch up
                engaged.due = now + interval
        return out

    def bypassing(self, kind: str) -> list[int]:
        """The routes (by index) that deliver ``kind`` to its failsafe's destinations from
        senders the failsafe's ``sources`` does not name.

        While the failsafe is engaged, those destinations receive those routes' commands between
        the failsafe's own datagrams.
        """
        to, sources = self._brakes[kind]
        if sources is None:
            return []
        return [
            index
            for index, (targets, kinds, accepted) in enumerate(self._routes)
            if (kinds is None or kind in kinds)
            and not to.isdisjoint(targets)
            and (accepted is None or not accepted <= sources)
        ]

    def engaged(self) -> frozenset[str]:
        """The kinds whose failsafe is engaged now."""
        return frozenset(self._engaged)

    def stats(self) -> RouterStats:
        """A snapshot of the counters."""
        return RouterStats(
            dict(self._forwarded),
            dict(self._dropped),
            self._debug_sent,
            dict(self._failsafe_sent),
            dict(self._engaged_count),
            dict(self._released_count),
        )

    # -- set-up --------------------------------------------------------------------------------

    def _known(self, name: str, what: str) -> None:
        if name not in self._forms:
            known = ", ".join(sorted(self._forms)) or "none"
            raise ValueError(f"{what}: no destination {name!r} (destinations: {known})")

    def _resolved(
        self, route: Route
    ) -> tuple[tuple[str, ...], frozenset[str] | None, frozenset[object] | None]:
        """A route as (destinations, the kinds it takes or None for all, its sources or None)."""
        for name in route.to:
            self._known(name, f"route to {', '.join(route.to)}")
        kinds: set[str] | None = None
        if route.kinds is not None:
            kinds = set(route.kinds)
            unknown = kinds - set(self._codec.kinds().values())
            if unknown:
                raise SchemaError(
                    f"route to {', '.join(route.to)}: {', '.join(sorted(unknown))} is not a "
                    f"payload kind of {self._codec.root}"
                )
        if route.sender is not None or route.receiver is not None:
            members = self._codec.members()
            directed = {
                member.kind
                for member in members
                if member.direction is not None
                and route.sender in (None, member.direction.sender)
                and route.receiver in (None, member.direction.receiver)
            }
            if not directed:
                parties = sorted(
                    {p for m in members if m.direction is not None for p in m.direction}
                )
                raise ValueError(
                    f"route to {', '.join(route.to)}: no member of {self._codec.root} is sent "
                    f"{route.sender or 'by anyone'} -> {route.receiver or 'anyone'} "
                    f"(the directions name: {', '.join(parties) or 'nobody'})"
                )
            kinds = directed if kinds is None else kinds & directed
        sources = frozenset(route.sources) if route.sources is not None else None
        return tuple(route.to), (frozenset(kinds) if kinds is not None else None), sources

    def _add_failsafe(self, failsafe: Failsafe) -> None:
        kind = failsafe.kind
        if kind not in self._codec.kinds().values():
            raise SchemaError(f"failsafe: {kind!r} is not a payload kind of {self._codec.root}")
        if kind in self._failsafes:
            raise ValueError(f"failsafe {kind}: a second failsafe for {kind} (one per kind)")
        try:
            rate, timeout = failsafe_timing(failsafe.rate, failsafe.timeout)
        except ValueError as error:
            raise ValueError(f"failsafe {kind}: {error}") from None
        if not failsafe.to:
            raise ValueError(f"failsafe {kind}: to names no destination")
        if len(set(failsafe.to)) < len(failsafe.to):
            raise ValueError(f"failsafe {kind}: to names a destination twice: {failsafe.to}")
        datagrams = []
        for name in failsafe.to:
            self._known(name, f"failsafe {kind}")
            datagrams.append(
                Outgoing(name, self._codec.encode(failsafe.message, self._forms[name]))
            )
        sources = frozenset(failsafe.sources) if failsafe.sources is not None else None
        if not any(
            (kinds is None or kind in kinds)
            and (sources is None or accepted is None or sources & accepted)
            and set(to) & set(failsafe.to)
            for to, kinds, accepted in self._routes
        ):
            raise ValueError(
                f"failsafe {kind}: no route takes {kind} to {', '.join(failsafe.to)}"
                + (f" from {', '.join(sorted(map(str, sources)))}" if sources is not None else "")
                + ": it could never arrive"
            )
        self._watchdog.watch(kind, timeout, timeout)  # the period matters not: no rate check
        self._failsafes[kind] = (1 / rate, datagrams)
        self._brakes[kind] = (frozenset(failsafe.to), sources)

    # -- the hot path's helpers ---------------------------------------------------------------

    def _targets(self, kind: str, source: object) -> tuple[tuple[str, ...], bool]:
        """The destinations of ``kind`` from ``source``, and whether that is an arrival for a
        failsafe (some of them are its destinations, and it accepts the source)."""
        found: dict[str, None] = {}  # ordered, without repeats
        for to, kinds, sources in self._routes:
            if (kinds is None or kind in kinds) and (sources is None or source in sources):
                found.update(dict.fromkeys(to))
        brake = self._brakes.get(kind)
        arrival = brake is not None and (
            not brake[0].isdisjoint(found) and (brake[1] is None or source in brake[1])
        )
        return tuple(found), arrival

    def _start(self, now: float) -> None:
        watchdog = self._watchdog
        for kind in self._failsafes:
            if watchdog.state(kind) is Liveness.INACTIVE:  # not arrived since the router was made
                watchdog.seen(kind, now)
        self._started = True

    def _drop(self, reason: str, data: bytes) -> list[Outgoing]:
        self._dropped[reason] = self._dropped.get(reason, 0) + 1
        if self._debug is None:
            return []
        self._debug_sent += 1
        return [Outgoing(self._debug, bytes(data))]

    def _engage(self, kind: str, now: float) -> None:
        self._engaged[kind] = _Engaged(now)
        self._engaged_count[kind] = self._engaged_count.get(kind, 0) + 1
        if self._on_event is not None:
            self._on_event(FailsafeEvent(kind, True, now))

    def _release(self, kind: str, now: float) -> None:
        del self._engaged[kind]
        self._released_count[kind] = self._released_count.get(kind, 0) + 1
        if self._on_event is not None:
            self._on_event(FailsafeEvent(kind, False, now))


def failsafe_timing(rate: float, timeout: float) -> tuple[float, float]:
    """``(rate, timeout)`` if both are within a failsafe's bounds (a ``ValueError`` naming the
    one that is not): a rate from 0.01 to 1000 Hz, a timeout from 1 ms to 1 h."""
    low, high = _RATES
    if isinstance(rate, bool) or not isinstance(rate, (int, float)) or not low <= rate <= high:
        raise ValueError(f"rate must be a number of Hz from {low:g} to {high:g}, not {rate!r}")
    shortest, longest = _TIMEOUTS
    timeout = duration("timeout", timeout)
    if not shortest <= timeout <= longest:
        raise ValueError(
            f"timeout must be from {shortest:g} to {longest:g} seconds, not {timeout!r}"
        )
    return rate, timeout
