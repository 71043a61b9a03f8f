"""``erc-codec relay CONFIG.toml``: the ``Router`` on asyncio UDP endpoints (the comms node).

The configuration (documented, with the rover's, in README.md) names the listening endpoints,
the destinations (address, form, and the endpoint they are sent from), optionally named senders,
the routes, the failsafes and a debug destination; ``_relayconfig`` reads and checks it.

While it runs it prints, every ``interval`` seconds, a status line on stderr (or, with
``status = "json"``, one JSON object a line on stdout): per destination the datagrams forwarded,
failsafe datagrams; drops by reason; failsafe events; the latency the relay adds
(from a datagram's read to its send, p50/p99/max over the last 10,000); per listening endpoint
what the kernel dropped and the sends that failed; per output stream the lines written and
dropped. SIGTERM, SIGINT and SIGHUP end it, printing the same counters on stderr.

The failsafe's guarantee: nothing but the configuration decides when a brake datagram goes out.
Output never waits for its reader (``LineStream``: a slow or stuck reader costs lines, counted,
and a closed one ends that output alone); an exception in routing, polling, sending or reporting
is counted under ``errors`` by type and the loop goes on; a datagram from one of the relay's own
sockets is dropped (``looped``), so no spelling of its own address can make it forward to itself.
"""

import contextlib
import json
import signal
import time
from collections import deque
from pathlib import Path
from typing import Any

import click

from erc_schema import CodecError

from ..codec import Codec
from ..runtime import FailsafeEvent, Outgoing, Router
from ..transport import UdpEndpoint, open_udp
from ._lines import LineStream, flush_standard_streams
from ._local import receives
from ._relayconfig import TICK, Config, read_config
from ._shared import Fatal, load, one_line, schema_options, shown

__all__ = ["relay"]

_STOPS = ("SIGINT", "SIGTERM", "SIGHUP")  # what ends a relay (SIGHUP: a terminal closed)
_LATENCIES = 10_000  # latency samples kept for the percentiles
_SENDERS = 256  # senders on one of the relay's own ports whose verdict (itself or not) is kept
_DRAIN = 2.0  # seconds slow readers get, at the end, for the lines still queued (both streams)


@click.command()
@click.argument("config", metavar="CONFIG.toml", type=click.Path(dir_okay=False, path_type=Path))
@schema_options
def relay(config: Path, tree: str | None, root: str | None) -> None:
    """Route datagrams between UDP peers as CONFIG.toml says (see README: the relay).

    Each datagram goes to the destinations whose routes take its kind, direction or source, in
    each destination's form (exact, strip or pad); failsafe messages go out while a watched kind
    is silent. The addresses bound are printed on stderr first; SIGTERM, SIGINT or SIGHUP print
    the counters and end it.
    """
    import asyncio

    codec = load(tree, root)
    settings = read_config(config, codec)
    flush_standard_streams()
    stderr = LineStream(2, "stderr")

    def closed(name: str, reason: str) -> None:
        stderr.write(f"relay: {name} closed ({reason}): routing and braking go on without it")

    stdout = LineStream(1, "stdout", on_closed=closed)
    finished: _Relay | None = None  # the relay that ran and stopped, whose counters are due
    try:
        try:
            session = _Relay(codec, settings, stdout, stderr)
        except (ValueError, CodecError) as error:  # what the configuration names does not exist
            raise Fatal(f"{config}: {one_line(str(error))}") from None
        for warning in session.warnings():
            stderr.write(f"{config}: warning: {warning}")
        with contextlib.suppress(KeyboardInterrupt):
            asyncio.run(session.run())
        finished = session
    finally:
        # stdout drained first, so the counters say what it finally wrote and dropped.
        deadline = time.monotonic() + _DRAIN
        stdout.close(_DRAIN / 2)
        if finished is not None:
            stderr.write(f"counters: {json.dumps(finished.metrics())}")
        stderr.close(max(0.0, deadline - time.monotonic()))


class _Relay:
    """One running relay: its router, endpoints, output, counters and latency samples."""

    def __init__(self, codec: Codec, config: Config, stdout: LineStream, stderr: LineStream):
        self.config = config
        self.stdout, self.stderr = stdout, stderr
        self.router = Router(
            codec,
            {name: destination.form for name, destination in config.destinations.items()},
            config.routes,
            config.failsafes,
            config.debug,
            on_event=self._event,
        )
        self.endpoints: dict[str, UdpEndpoint] = {}
        self.latencies: deque[float] = deque(maxlen=_LATENCIES)
        self.errors: dict[str, int] = {}  # error type → times it stopped a step (none expected)
        self.looped = 0  # datagrams that came from one of the relay's own sockets
        self._targets: dict[str, tuple[UdpEndpoint, tuple[Any, ...]]] = {}
        self._ports: frozenset[int] = frozenset()  # the ports the relay's sockets are bound to
        self._own: dict[tuple[Any, ...], bool] = {}  # sender → whether it is one of them

    def warnings(self) -> list[str]:
        """What the configuration allows that a reader may not expect: a route that delivers a
        failsafe's kind to its destinations from senders its ``sources`` does not name."""
        found = []
        for index, failsafe in enumerate(self.config.failsafes):
            for route in self.router.bypassing(failsafe.kind):
                found.append(
                    f"routes[{route}] delivers {failsafe.kind} to {', '.join(failsafe.to)} from "
                    f"senders failsafes[{index}].sources does not name: while the brake is "
                    "engaged, their commands reach it between the brake datagrams"
                )
        return found

    async def run(self) -> None:
        import asyncio

        loop = asyncio.get_running_loop()
        stop = loop.create_future()

        def finish() -> None:
            if not stop.done():
                stop.set_result(None)

        for name in _STOPS:
            if hasattr(signal, name):
                loop.add_signal_handler(getattr(signal, name), finish)
        try:
            for name, address in self.config.listen.items():
                try:
                    self.endpoints[name] = await open_udp(
                        None, address[0], address[1], on_datagram=self._heard(name)
                    )
                except OSError as error:
                    raise Fatal(f"cannot listen on {shown(address)} ({name}): {error}") from None
            for name, destination in self.config.destinations.items():
                self._targets[name] = (self.endpoints[destination.via], destination.address)
            self._ports = frozenset(endpoint.address[1] for endpoint in self.endpoints.values())
            bound = ", ".join(
                f"{name} {shown(endpoint.address)}" for name, endpoint in self.endpoints.items()
            )
            self.stderr.write(f"relaying: listening on {bound}")
            tasks = [loop.create_task(self._poll())] if self.config.failsafes else []
            if self.config.status != "none":
                tasks.append(loop.create_task(self._report()))
            try:
                await stop
            finally:
                for task in tasks:
                    task.cancel()
        finally:
            for endpoint in self.endpoints.values():
                endpoint.close()

    def metrics(self) -> dict[str, Any]:
        stats = self.router.stats()
        routes = {
            name: {
                "forwarded": stats.forwarded.get(name, 0),
                "failsafe": stats.failsafe_sent.get(name, 0),
            }
            for name in self.config.destinations
        }
        listening = {}
        for name, endpoint in self.endpoints.items():
            udp = endpoint.stats()
            listening[name] = {
                "received": udp.received,
                "kernel_dropped": udp.kernel_dropped,
                "unread": udp.unread,
                "send_errors": udp.send_errors,  # of what was sent from it
            }
        dropped = dict(stats.dropped)
        if self.looped:
            dropped["looped"] = self.looped
        return {
            "routes": routes,
            "dropped": dropped,
            "debug": stats.debug,
            "failsafe": {"engaged": stats.engaged, "released": stats.released},
            "engaged": sorted(self.router.engaged()),
            "errors": dict(self.errors),
            "latency_us": _percentiles(self.latencies),
            "listen": listening,
            "output": {"stdout": self.stdout.stats(), "stderr": self.stderr.stats()},
        }

    def _heard(self, listener: str) -> Any:
        sources, route, clock = self.config.sources, self.router.route, time.monotonic
        deliver, latencies = self._deliver, self.latencies

        def heard(data: bytes, sender: Any) -> None:
            start = time.perf_counter()
            if sender[1] in self._ports and self._from_itself(sender):
                self.looped += 1
                return
            source = sources.get(sender[:2], listener) if sources else listener
            try:
                outgoing = route(data, source, clock())
            except Exception as error:  # a bug's, not the datagram's: counted, never a traceback
                self._count(error)
                return
            deliver(outgoing)
            latencies.append(time.perf_counter() - start)

        return heard

    def _from_itself(self, sender: tuple[Any, ...]) -> bool:
        """Whether ``sender`` is one of the relay's own sockets (a destination that leads back
        to the relay, under a name the configuration could not tell)."""
        key = sender[:2]
        verdict = self._own.get(key)
        if verdict is None:
            verdict = any(receives(e.address, key) for e in self.endpoints.values())
            if len(self._own) >= _SENDERS:  # asked again later: a host's addresses may change
                self._own.clear()
            self._own[key] = verdict
        return verdict

    def _count(self, error: Exception) -> None:
        name = type(error).__name__
        self.errors[name] = self.errors.get(name, 0) + 1

    def _deliver(self, outgoing: list[Outgoing]) -> None:
        """Send each datagram; one that fails is counted and the rest still go."""
        targets = self._targets
        for destination, data in outgoing:
            endpoint, address = targets[destination]
            try:
                endpoint.send_datagram(data, address)
            except Exception as error:  # counted; no destination waits on another's failure
                self._count(error)

    def _event(self, event: FailsafeEvent) -> None:
        """Said on stderr, counted by the router; not kept (a flapping brake is no memory)."""
        state = "engaged" if event.engaged else "released"
        self.stderr.write(f"failsafe {event.kind} {state}")

    async def _poll(self) -> None:
        import asyncio

        poll, clock, deliver = self.router.poll, time.monotonic, self._deliver
        while True:
            try:
                outgoing = poll(clock())
            except Exception as error:  # counted; the next tick polls again
                self._count(error)
            else:
                deliver(outgoing)
            await asyncio.sleep(TICK)

    async def _report(self) -> None:
        import asyncio

        while True:
            await asyncio.sleep(self.config.interval)
            try:
                metrics = self.metrics()
                if self.config.status == "json":
                    self.stdout.write(json.dumps(metrics))
                else:
                    self.stderr.write(_line(metrics))
            except Exception as error:  # counted; the next interval reports again
                self._count(error)


def _percentiles(samples: "deque[float]") -> dict[str, float | None]:
    if not samples:
        return {"p50": None, "p99": None, "max": None}
    ordered = sorted(samples)

    def at(share: float) -> float:
        return round(ordered[min(len(ordered) - 1, int(share * len(ordered)))] * 1e6, 1)

    return {"p50": at(0.5), "p99": at(0.99), "max": at(1.0)}


def _line(metrics: dict[str, Any]) -> str:
    routes = " ".join(
        f"{name}={route['forwarded']}" + (f"+{route['failsafe']}fs" if route["failsafe"] else "")
        for name, route in metrics["routes"].items()
    )
    dropped = sum(metrics["dropped"].values()) + sum(metrics["errors"].values())
    latency = metrics["latency_us"]
    engaged = ",".join(metrics["engaged"]) or "-"
    p99 = "-" if latency["p99"] is None else f"{latency['p99']}us"  # nothing relayed yet
    return f"relay: {routes} dropped={dropped} engaged={engaged} p99={p99}"
