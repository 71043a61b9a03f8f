"""A sans-IO Proton node: its registry of signal values, the bundles it owes its peers, the
bundles and heartbeats it receives.

Guarantees: the clock is the caller's (``now`` in seconds, any origin, kept to the microsecond);
nothing here reads time, sleeps, starts a thread or touches a socket. ``poll(now)`` returns every
bundle due at ``now``, encoded, in the order Proton's node manager (``proton_node_update``, called
until it has nothing left) sends them: triggered bundles first, then periodic ones; within each,
the most overdue first, the higher id first among equals (the C node picks the last of its
id-sorted table). The first ``poll`` is the node's boot, as uptime 0 is the C node's: every bundle
counts as sent then, so a periodic bundle first goes out ``period_ms`` after it, and then whenever
``period_ms`` has passed since it was last sent (when triggered too). A late poll delays what
follows, as in C (the period counts from the actual send). A clock that steps back never makes a
bundle due early (the C node's unsigned uptime would make every bundle due at once).

The registry holds the signals of the bundles the node produces or consumes (those Proton's
generator puts in its registry), starting at their configured defaults; ``set`` refuses, with an
``EncodeError``, what a signal cannot send unchanged, so every due bundle encodes. ``receive``
decodes one message, applies its values and calls the bundle's handler; anything undecodable, or a
bundle this node does not consume, is a ``DecodeError`` and changes nothing.

Heartbeats, as the seed describes them (bundle id 0, one uint32 signal): a node producing bundle 0
adds one to its counter (modulo 2**32) each time it sends it. A peer producing bundle 0 that this
node consumes is watched (an ``erc_codec.Watchdog``): INACTIVE until its first heartbeat, ACTIVE
while they arrive, INACTIVE once none came within the timeout; a peer without heartbeats (or whose
heartbeat has no period) is UNCONFIGURED. Proton's sources set no timeout. A sender following
Proton's node manager sends heartbeats a period apart or more (later by however long its polls
come after they are due), so a timeout of exactly one period would mark a healthy peer INACTIVE
between its heartbeats: the default is the ``Watchdog``'s, three periods.
A received heartbeat never overwrites the counter of a node that sends heartbeats itself.
"""

from collections.abc import Callable
from typing import NamedTuple, TypeVar

from .._errors import DecodeError, EncodeError
from .._watchdog import Liveness, Watchdog
from ._codec import Bundle, BundleCodec
from ._config import BundleConfig, Config, ProtonConfigError
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
    """One node of a Proton configuration, speaking ``version`` to its peers."""

    def __init__(
        self,
        config: Config,
        name: str,
        version: Version = "2.0",
        heartbeat_timeout: float | None = None,
        on_peer: PeerHandler | None = None,
    ) -> None:
        """``heartbeat_timeout``: seconds without a heartbeat before a peer is INACTIVE (default:
        three heartbeat periods). ``on_peer(peer, state)`` hears every change of a peer's state."""
        if all(node.name != name for node in config.nodes):
            known = ", ".join(node.name for node in config.nodes)
            raise ProtonConfigError(
                config.source, None, "", f"no node is called {name!r} ({known})"
            )
        self.name = name
        self.codec = BundleCodec(config, version)
        self.on_peer = on_peer
        self._peers = tuple(dict.fromkeys(peer.name for _, peer, _ in config.peers(name)))
        mine = [b for b in config.bundles if name in b.producers or name in b.consumers]
        self._values: dict[str, Value] = {
            signal: config.signal(signal).default for bundle in mine for signal in bundle.signals
        }
        self._produced = {
            b.name: _Schedule(b, tuple(p for p in b.consumers if p in self._peers))
            for b in mine
            if name in b.producers
        }
        self._consumed = {b.id for b in mine if name in b.consumers}
        self._handlers: dict[str, Handler] = {}
        self._booted = False
        self._watchdog = Watchdog()
        self._heartbeat = next((b for b in mine if b.id == _HEARTBEAT), None)
        if self._heartbeat is not None and self._heartbeat.id in self._consumed:
            period = self._heartbeat.period_ms / 1000
            for peer in self._beating_peers():
                if period > 0:
                    self._watchdog.watch(peer, period, heartbeat_timeout)

    @property
    def peers(self) -> tuple[str, ...]:
        """The nodes this node is connected to, in the configuration's order."""
        return self._peers

    # -- the registry --------------------------------------------------------------------------

    def set(self, signal: str, value: object) -> None:
        """Give ``signal`` a new value, sent with the next bundle that carries it."""
        if signal not in self._values:
            self.codec.signal(signal)  # an unknown name says so
            raise EncodeError(
                f"signal {signal!r} is in no bundle node {self.name!r} produces or consumes"
            )
        self._values[signal] = self.codec.check(signal, value)

    def get(self, signal: str) -> Value:
        """The signal's value: its default, what was set, or what was last received."""
        if signal not in self._values:
            self.codec.signal(signal)
            raise EncodeError(
                f"signal {signal!r} is in no bundle node {self.name!r} produces or consumes"
            )
        value = self._values[signal]
        return value.copy() if isinstance(value, list) else value  # the caller's to change

    # -- sending -------------------------------------------------------------------------------

    def trigger(self, bundle: str) -> None:
        """Send ``bundle`` at the next ``poll``, before the periodic ones."""
        self._schedule(bundle).triggered = True

    def poll(self, now: float) -> list[Sent]:
        """Every bundle due at ``now``, in the order to send them."""
        clock = round(now * _MICROSECONDS)
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
        sent = [self._send(schedule, clock) for _, _, schedule in order]
        for peer in self._watchdog.poll(now):
            self._tell(peer, Liveness.INACTIVE)
        return sent

    def _send(self, schedule: _Schedule, clock: int) -> Sent:
        bundle = schedule.config
        if bundle.id == _HEARTBEAT:
            (counter,) = bundle.signals
            beats = self._values[counter]
            assert isinstance(beats, int)  # the configuration makes it a uint32
            self._values[counter] = (beats + 1) % (1 << 32)
        data = self.codec.encode(bundle.name, {n: self._values[n] for n in bundle.signals})
        schedule.last, schedule.triggered = clock, False
        return Sent(bundle.name, data, schedule.peers)

    def _schedule(self, bundle: str) -> _Schedule:
        schedule = self._produced.get(bundle)
        if schedule is None:
            self.codec.bundle(bundle)  # an unknown name says so
            raise EncodeError(f"bundle {bundle!r} is not produced by node {self.name!r}")
        return schedule

    # -- receiving -----------------------------------------------------------------------------

    def register(self, bundle: str, handler: Handler) -> None:
        """Call ``handler(received)`` (a ``Bundle``) after each ``bundle`` received and applied."""
        config = self.codec.bundle(bundle)
        if config.id not in self._consumed:
            raise ProtonConfigError(
                self.codec.config.source,
                config.line,
                f"bundle {bundle!r}",
                f"is not consumed by node {self.name!r} (its consumers: "
                f"{', '.join(config.consumers)})",
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
        bundle. ``peer``: who sent it, when the transport knows; a heartbeat from an unnamed
        sender counts for the one peer producing heartbeats, if there is just one."""
        received = self.codec.decode(data)
        if received.id not in self._consumed:
            raise DecodeError(
                f"bundle {received.name!r} is not consumed by node {self.name!r}", "not_consumed"
            )
        if received.id == _HEARTBEAT:
            self._heard(peer, now)
        for signal, value in received.signals.items():
            if received.id != _HEARTBEAT or received.name not in self._produced:
                self._values[signal] = value
        handler = self._handlers.get(received.name)
        if handler is not None:
            handler(received)
        return received

    def peer_state(self, peer: str) -> Liveness:
        """``peer``'s state, as its heartbeats show it."""
        if peer not in self._peers:
            raise KeyError(f"{peer!r} is not a peer of node {self.name!r}")
        return self._watchdog.state(peer)

    def _heard(self, peer: str | None, now: float) -> None:
        beating = self._beating_peers()
        if peer is None and len(beating) == 1:
            peer = beating[0]
        if peer is None or peer not in beating:
            return
        before = self._watchdog.state(peer)
        self._watchdog.seen(peer, now)
        after = self._watchdog.state(peer)
        if after is not before:
            self._tell(peer, after)

    def _beating_peers(self) -> tuple[str, ...]:
        if self._heartbeat is None:
            return ()
        return tuple(p for p in self._peers if p in self._heartbeat.producers)

    def _tell(self, peer: str, state: Liveness) -> None:
        if self.on_peer is not None:
            self.on_peer(peer, state)


def _priority(key: tuple[int, int, _Schedule]) -> tuple[int, int]:
    overdue, bundle_id, _ = key
    return -overdue, -bundle_id
