"""A sans-IO Proton node: its registry of signal values, the bundles it owes its peers, the
bundles and heartbeats it receives.

The clock:
- The clock is the caller's: ``now`` in seconds, any origin, kept to the microsecond.
- Anything but a finite number is a ``ValueError`` naming ``now``.
  So no NaN ever reaches a schedule or a peer's last arrival.
- Nothing here reads time, sleeps, starts a thread or touches a socket.

Polling:
- ``poll(now)`` returns every bundle due at ``now``, encoded.
- They come in the order Proton's node manager sends them (``proton_node_update``, called until
  it has nothing left):
  - triggered bundles first, then periodic ones;
  - within each, the most overdue first;
  - among equals, the higher id first, as the C node picks the last of its id-sorted table.
- The first ``poll`` is the node's boot, as uptime 0 is the C node's.
  Every bundle counts as sent then.
- A periodic bundle first goes out ``period_ms`` after the boot.
  It then goes out whenever ``period_ms`` has passed since it was last sent, triggered or not.
- A late poll delays what follows, as in C: the period counts from the actual send.
- A clock that steps back never makes a bundle due early.
  The C node's unsigned uptime would make every bundle due at once.
- ``poll`` encodes every due bundle before it changes any schedule or counter.
  It either returns them all or, raising, changes nothing.

The registry:
- It holds the signals of the bundles the node produces or consumes, those Proton's generator
  puts in its registry.
- They start at their configured defaults.
- ``set`` refuses, with an ``EncodeError``, what a signal cannot send unchanged.
  So every due bundle encodes.
- ``receive`` decodes one message, applies its values and calls the bundle's handler.
- Anything undecodable, or a bundle this node does not consume, is a ``DecodeError`` and changes
  nothing.
- The registry holds its own copies of list values.
  What ``get`` returns, and a received ``Bundle``'s lists, are the caller's to change.

Heartbeats, as the rover's Proton 1.0 design has them: a bundle with id 0 and one uint32 signal. A
node producing it adds one to its counter (modulo 2**32) each time it sends it; a received heartbeat
never overwrites the counter of a node that sends heartbeats itself.

Peers (``peer_state``, as ``erc_codec.runtime.Liveness``):
- Proton defines UNCONFIGURED, INACTIVE and ACTIVE as a node's lifecycle and sets no timeout.
  Here a peer's state is what this node can tell of it.
- A peer is watched when it produces a periodic bundle this node consumes.
- Its period is its heartbeat's period if it sends one, else the shortest ``period_ms`` of those
  bundles.
- A watched peer is INACTIVE until it is first heard.
- It is ACTIVE while any bundle it produces keeps arriving; any bundle proves it alive, not only
  heartbeats.
- It is INACTIVE once none came within the timeout.
- A peer sending this node only triggered bundles, or nothing, is UNCONFIGURED.
  Nothing says when to expect it.
- The timeout is three periods unless given (``peer_timeout``).
  A sender following Proton's node manager sends a period apart or more, later by however long
  its polls come after they are due.
  So a rule of "within the period" would mark a healthy peer INACTIVE between its heartbeats.
"""

import math
from collections.abc import Callable
from typing import NamedTuple, TypeVar

from erc_schema import DecodeError

from ..runtime import Liveness, Watchdog
from ..runtime.checks import duration
from ._codec import SCRATCH_BUFFER_SIZE, Bundle, BundleCodec
from ._config import BundleConfig, Config
from ._types import Value, Version

__all__ = ["Node", "Sent"]

Handler = Callable[[Bundle], object]
H = TypeVar("H", bound=Handler)
PeerHandler = Callable[[str, Liveness], object]

_HEARTBEAT = 0
_MICROSECONDS = 1_000_000


class Sent(NamedTuple):
    """A bundle to send: its name, the encoded message (unframed) and the peers it is for (its
    consumers among the node's connections)."""

    bundle: str
    data: bytes
    peers: tuple[str, ...]


class _Schedule:
    __slots__ = ("config", "last", "peers", "period", "triggered")

    def __init__(self, config: BundleConfig, peers: tuple[str, ...]) -> None:
        self.config = config
        self.period = config.period_ms * 1000  # microseconds
        self.peers = peers
        self.last = 0  # when it was last sent (microseconds; the first poll, until it is)
        self.triggered = False


class Node:
    """One node of a Proton configuration, speaking ``version`` to its peers.

    Mistakes, one kind each:
    - A name the configuration or this node's part in it does not have is a ``KeyError``.
      This covers a node, signal, bundle or peer.
      It also covers a bundle the node does not produce, given to ``trigger``, or does not
      consume, given to ``register``.
    - A value a signal cannot send is an ``EncodeError``.
    - A message that does not decode, or that this node does not consume, is a ``DecodeError``.
    - A configuration this version cannot use is a ``ProtonConfigError``.
    - A ``now`` that is not a finite number is a ``ValueError``."""

    def __init__(
        self,
        config: Config,
        name: str,
        version: Version = "2.0",
        peer_timeout: float | None = None,
        on_peer: PeerHandler | None = None,
        scratch_buffer_size: int = SCRATCH_BUFFER_SIZE,
    ) -> None:
        """``peer_timeout``: seconds without hearing a watched peer before it is INACTIVE
        (default: three of its periods). ``on_peer(peer, state)`` hears every change of a
        peer's state. ``scratch_buffer_size``: as for ``BundleCodec``."""
        config.node(name)  # a KeyError naming it if there is none
        if peer_timeout is not None:  # checked even when no peer is watched: it is a mistake
            duration("peer_timeout", peer_timeout)
        self.name = name
        self.codec = BundleCodec(config, version, scratch_buffer_size)
        self.on_peer = on_peer
        self._peers = tuple(dict.fromkeys(peer.name for _, peer, _ in config.peers(name)))
        mine = [b for b in config.bundles if name in b.producers or name in b.consumers]
        self._values: dict[str, Value] = {
            signal: _own(config.signal(signal).default)
            for bundle in mine
            for signal in bundle.signals
        }
        self._produced = {
            b.name: _Schedule(b, tuple(p for p in b.consumers if p in self._peers))
            for b in mine
            if name in b.producers
        }
        consumed = [b for b in mine if name in b.consumers]
        self._consumed = {b.id for b in consumed}
        self._handlers: dict[str, Handler] = {}
        self._booted = False
        self._watchdog = Watchdog()
        self._heartbeat = next((b for b in mine if _is_heartbeat(config, b)), None)
        for peer in self._peers:
            period = _watch_period(peer, consumed, self._heartbeat)
            if period is not None:
                self._watchdog.watch(peer, period / 1000, peer_timeout)

    @property
    def peers(self) -> tuple[str, ...]:
        """The nodes this node is connected to, in the configuration's order."""
        return self._peers

    # -- the registry --------------------------------------------------------------------------

    def set(self, signal: str, value: object) -> None:
        """Give ``signal`` a new value, sent with the next bundle that carries it."""
        self._registered(signal)
        self._values[signal] = self.codec.check(signal, value)  # a new value: check() copies

    def get(self, signal: str) -> Value:
        """The signal's value: its default, what was set, or what was last received."""
        return _own(self._values[self._registered(signal)])  # the caller's to change

    def _registered(self, signal: str) -> str:
        if signal not in self._values:
            self.codec.config.signal(signal)  # a KeyError naming an unknown name
            raise KeyError(
                f"signal {signal!r} is in no bundle node {self.name!r} produces or consumes"
            )
        return signal

    # -- sending -------------------------------------------------------------------------------

    def trigger(self, bundle: str) -> None:
        """Send ``bundle`` at the next ``poll``, before the periodic ones."""
        self._schedule(bundle).triggered = True

    def poll(self, now: float) -> list[Sent]:
        """Every bundle due at ``now``, in the order to send them."""
        clock = _microseconds(now)
        if not self._booted:  # uptime 0: everything counts as sent now
            self._booted = True
            for schedule in self._produced.values():
                schedule.last = clock
        triggered: list[tuple[int, int, _Schedule]] = []
        periodic: list[tuple[int, int, _Schedule]] = []
        for schedule in self._produced.values():
            if clock < schedule.last:
                schedule.last = clock  # the clock stepped back: count the period from here
            elapsed = clock - schedule.last
            overdue = max(0, elapsed - schedule.period)
            key = (overdue, schedule.config.id, schedule)
            if schedule.triggered:
                triggered.append(key)
            elif schedule.period and elapsed >= schedule.period:
                periodic.append(key)
        order = sorted(triggered, key=_priority) + sorted(periodic, key=_priority)
        counted: dict[str, Value] = {}  # the heartbeat counter, once it is sent
        sent = [self._encoded(schedule.config, counted) for _, _, schedule in order]
        for _, _, schedule in order:  # every bundle encoded: only now does anything change
            schedule.last, schedule.triggered = clock, False
        self._values.update(counted)
        for peer in self._watchdog.poll(now):
            self._tell(peer, Liveness.INACTIVE)
        return sent

    def _encoded(self, bundle: BundleConfig, counted: dict[str, Value]) -> Sent:
        values = {n: self._values[n] for n in bundle.signals}
        if bundle is self._heartbeat:
            (counter,) = bundle.signals
            beats = values[counter]
            assert isinstance(beats, int)  # the configuration makes it a uint32
            values[counter] = counted[counter] = (beats + 1) % (1 << 32)
        data = self.codec.encode(bundle.name, values)
        return Sent(bundle.name, data, self._produced[bundle.name].peers)

    def _schedule(self, bundle: str) -> _Schedule:
        schedule = self._produced.get(bundle)
        if schedule is None:
            self.codec.config.bundle(bundle)  # a KeyError naming an unknown name
            raise KeyError(f"node {self.name!r} produces no bundle {bundle!r}")
        return schedule

    # -- receiving -----------------------------------------------------------------------------

    def register(self, bundle: str, handler: Handler) -> None:
        """Call ``handler(received)`` (a ``Bundle``) after each ``bundle`` received and applied."""
        config = self.codec.config.bundle(bundle)  # a KeyError naming an unknown name
        if config.id not in self._consumed:
            raise KeyError(
                f"node {self.name!r} consumes no bundle {bundle!r} (its consumers: "
                f"{', '.join(config.consumers)})"
            )
        self._handlers[bundle] = handler

    def on(self, bundle: str) -> Callable[[H], H]:
        """The decorator form of ``register``: ``@node.on("status")``."""

        def decorate(handler: H) -> H:
            self.register(bundle, handler)
            return handler

        return decorate

    def receive(self, data: bytes, now: float, peer: str | None = None) -> Bundle:
        """Decode one message (unframed), apply it to the registry and call its handler; the
        bundle. ``peer``: who sent it, when the transport knows; unnamed, the sender is the
        bundle's one producer among this node's peers, if it has just one."""
        _microseconds(now)  # a ValueError before anything changes
        received = self.codec.decode(data)
        if received.id not in self._consumed:
            raise DecodeError(
                f"bundle {received.name!r} is not consumed by node {self.name!r}", "not_consumed"
            )
        heartbeat = self._heartbeat
        counts_its_own = (
            heartbeat is not None
            and received.name == heartbeat.name
            and heartbeat.name in self._produced
        )
        if not counts_its_own:
            for signal, value in received.signals.items():
                self._values[signal] = _own(value)  # the received Bundle's lists stay its own
        self._heard(received, peer, now)
        handler = self._handlers.get(received.name)
        if handler is not None:
            handler(received)
        return received

    def peer_state(self, peer: str) -> Liveness:
        """``peer``'s state, as what arrives from it shows it (see the module's docstring)."""
        if peer not in self._peers:
            raise KeyError(f"{peer!r} is not a peer of node {self.name!r}")
        return self._watchdog.state(peer)

    def _heard(self, received: Bundle, peer: str | None, now: float) -> None:
        if peer is None:
            producers = self.codec.config.bundle(received.name).producers
            candidates = [p for p in self._peers if p in producers]
            peer = candidates[0] if len(candidates) == 1 else None
        if peer is None or peer not in self._peers:
            return
        before = self._watchdog.state(peer)
        self._watchdog.seen(peer, now)
        after = self._watchdog.state(peer)
        if after is not before:
            self._tell(peer, after)

    def _tell(self, peer: str, state: Liveness) -> None:
        if self.on_peer is not None:
            self.on_peer(peer, state)


def _priority(key: tuple[int, int, _Schedule]) -> tuple[int, int]:
    overdue, bundle_id, _ = key
    return -overdue, -bundle_id


def _microseconds(now: float) -> int:
    """``now`` (seconds) on the node's microsecond clock; a ``ValueError`` for anything but a
    finite number (NaN would stop every timeout comparison, infinity every schedule)."""
    if isinstance(now, bool) or not isinstance(now, int | float) or not math.isfinite(now):
        raise ValueError(f"now must be a finite number of seconds, not {now!r}")
    return round(now * _MICROSECONDS)


def _own(value: Value) -> Value:
    """A value the registry (or its caller) holds alone: lists are copied."""
    return value.copy() if isinstance(value, list) else value


def _is_heartbeat(config: Config, bundle: BundleConfig) -> bool:
    """The heartbeat: bundle id 0 with one uint32 signal."""
    return (
        bundle.id == _HEARTBEAT
        and len(bundle.signals) == 1
        and config.signal(bundle.signals[0]).type == "uint32"
    )


def _watch_period(
    peer: str, consumed: list[BundleConfig], heartbeat: BundleConfig | None
) -> int | None:
    """The period (ms) to expect ``peer`` by: its heartbeat's, else its fastest periodic bundle
    this node consumes; ``None`` when nothing it sends here is periodic."""
    periodic = [b for b in consumed if peer in b.producers and b.period_ms > 0]
    if heartbeat is not None and heartbeat in periodic:
        return heartbeat.period_ms
    return min((b.period_ms for b in periodic), default=None)
