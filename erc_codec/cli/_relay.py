"""``erc-codec relay CONFIG.toml``: the ``Router`` on asyncio UDP endpoints (the comms node).

The configuration (documented, with the rover's, in README.md) names the listening endpoints,
the destinations (address, form, and the endpoint they are sent from), optionally named senders,
the routes, the failsafes and a debug destination. Every key is checked: an unknown one, a bad
address, an unknown kind or destination is one line naming the file and the key, exit 2.

While it runs it prints, every ``interval`` seconds, a status line on stderr (or, with
``status = "json"``, one JSON object a line on stdout): per destination the datagrams forwarded,
failsafe datagrams; drops by reason; failsafe events; the latency the relay adds
(from a datagram's read to its send, p50/p99/max over the last 10,000); per listening endpoint
what the kernel dropped and the sends that failed. SIGTERM and SIGINT end it, printing the
same counters on stderr.
"""

import contextlib
import json
import signal
import sys
import time
from collections import deque
from pathlib import Path
from typing import Any, NamedTuple, cast

import click
from google.protobuf import json_format

from .._codec import Codec
from .._envelope import Mode
from .._errors import CodecError
from .._router import Failsafe, FailsafeEvent, Route, Router
from .._transport import UdpEndpoint, open_udp
from ._shared import Fatal, load, one_line, parse_address, resolve, schema_options, shown

__all__ = ["relay"]

_LATENCIES = 10_000  # latency samples kept for the percentiles
_TICK = 0.002  # seconds between two polls of the failsafes


class Destination(NamedTuple):
    address: tuple[Any, ...]
    form: Mode
    via: str  # the listening endpoint it is sent from


class Config(NamedTuple):
    listen: dict[str, tuple[Any, ...]]  # name → socket address to bind
    destinations: dict[str, Destination]
    sources: dict[tuple[str, int], str]  # sender (host, port) → name
    routes: list[Route]
    failsafes: list[Failsafe]
    debug: str | None
    status: str  # "line", "json" or "none"
    interval: float


@click.command()
@click.argument("config", metavar="CONFIG.toml", type=click.Path(dir_okay=False, path_type=Path))
@schema_options
def relay(config: Path, tree: str | None, root: str | None) -> None:
    """Route datagrams between UDP peers as CONFIG.toml says (see README: the relay).

    Each datagram goes to the destinations whose routes take its kind, direction or source, in
    each destination's form (exact, strip or pad); failsafe messages go out while a watched kind
    is silent. The addresses bound are printed on stderr first; SIGTERM or SIGINT print the
    counters and end it.
    """
    import asyncio

    codec = load(tree, root)
    settings = read_config(config, codec)
    try:
        session = _Relay(codec, settings)
    except (ValueError, CodecError) as error:  # what the configuration names does not exist
        raise Fatal(f"{config}: {one_line(str(error))}") from None
    with contextlib.suppress(KeyboardInterrupt):
        asyncio.run(session.run())
    click.echo(f"counters: {json.dumps(session.metrics())}", err=True)


def read_config(path: Path, codec: Codec) -> Config:
    """The relay configuration in ``path``, checked against ``codec``'s schema."""
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # tomllib is tomli, joined to the standard library in 3.11
        import tomli as tomllib
    try:
        document = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as error:
        raise Fatal(f"{path}: {error.strerror or error}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as error:
        raise Fatal(f"{path}: not TOML: {one_line(str(error))}") from None
    reader = _Reader(path, codec)
    try:
        return reader.config(document)
    except (ValueError, click.BadParameter, Fatal) as error:
        text = error.format_message() if isinstance(error, click.ClickException) else str(error)
        raise Fatal(f"{path}: {one_line(text)}") from None


class _Reader:
    def __init__(self, path: Path, codec: Codec) -> None:
        self.path, self.codec = path, codec

    def config(self, document: dict[str, Any]) -> Config:
        _only(document, "", {"relay", "listen", "destinations", "sources", "routes", "failsafes"})
        settings = _table(document, "relay")
        _only(settings, "relay", {"debug", "status", "interval"})
        listen = {
            name: self.address(f"listen.{name}", text, default_host="127.0.0.1")
            for name, text in _table(document, "listen").items()
        }
        if not listen:
            raise ValueError("[listen] names no endpoint: the relay needs at least one")
        first = next(iter(listen))
        destinations = {}
        for name, entry in _table(document, "destinations").items():
            where = f"destinations.{name}"
            if not isinstance(entry, dict):
                raise ValueError(f"{where} must be a table {{ address = ..., form = ... }}")
            _only(entry, where, {"address", "form", "via"})
            form = entry.get("form", "exact")
            if form not in ("exact", "strip", "pad"):
                raise ValueError(f"{where}.form must be exact, strip or pad, not {form!r}")
            via = entry.get("via", first)
            if via not in listen:
                raise ValueError(f"{where}.via: no [listen] endpoint {via!r}")
            if "address" not in entry:
                raise ValueError(f"{where}.address is missing")
            address = self.address(f"{where}.address", entry["address"])
            destinations[name] = Destination(address, cast(Mode, form), via)
        sources = {}
        for name, text in _table(document, "sources").items():
            host, port = self.address(f"sources.{name}", text)[:2]
            sources[(host, port)] = name
        routes = [self.route(i, entry) for i, entry in enumerate(_list(document, "routes"))]
        failsafes = [
            self.failsafe(i, entry) for i, entry in enumerate(_list(document, "failsafes"))
        ]
        status = settings.get("status", "line")
        if status not in ("line", "json", "none"):
            raise ValueError(f"relay.status must be line, json or none, not {status!r}")
        interval = settings.get("interval", 1.0)
        if isinstance(interval, bool) or not isinstance(interval, (int, float)) or interval <= 0:
            raise ValueError(
                f"relay.interval must be a positive number of seconds, not {interval!r}"
            )
        return Config(
            listen,
            destinations,
            sources,
            routes,
            failsafes,
            settings.get("debug"),
            status,
            interval,
        )

    def address(self, where: str, text: Any, default_host: str | None = None) -> tuple[Any, ...]:
        if not isinstance(text, str):
            raise ValueError(f'{where} must be a string "HOST:PORT", not {text!r}')
        try:
            host, port = parse_address(text, default_host)
        except click.BadParameter as error:
            raise ValueError(f"{where}: {error.format_message()}") from None
        return resolve(host, port)[1]

    def route(self, index: int, entry: Any) -> Route:
        where = f"routes[{index}]"
        if not isinstance(entry, dict):
            raise ValueError(f"{where} must be a table")
        _only(entry, where, {"to", "kinds", "sources", "sender", "receiver"})
        return Route(
            _names(entry, "to", where, required=True) or (),
            _names(entry, "kinds", where),
            _names(entry, "sources", where),
            _text(entry, "sender", where),
            _text(entry, "receiver", where),
        )

    def failsafe(self, index: int, entry: Any) -> Failsafe:
        where = f"failsafes[{index}]"
        if not isinstance(entry, dict):
            raise ValueError(f"{where} must be a table")
        _only(entry, where, {"kind", "message", "to", "rate", "timeout"})
        kind = _text(entry, "kind", where)
        if kind is None or kind not in self.codec.kinds().values():
            raise ValueError(f"{where}.kind: {kind!r} is not a payload kind of {self.codec.root}")
        message = self.codec.message_class(kind)()
        try:
            json_format.ParseDict(entry.get("message", {}), message)
        except json_format.ParseError as error:
            raise ValueError(f"{where}.message: {error}") from None
        rate, timeout = entry.get("rate"), entry.get("timeout")
        if rate is None:
            raise ValueError(f"{where}.rate is missing (failsafe messages a second)")
        return Failsafe(
            kind, message, _names(entry, "to", where, required=True) or (), rate, timeout
        )


def _table(document: dict[str, Any], key: str) -> dict[str, Any]:
    value = document.get(key, {})
    if not isinstance(value, dict):
        raise ValueError(f"[{key}] must be a table")
    return value


def _list(document: dict[str, Any], key: str) -> list[Any]:
    value = document.get(key, [])
    if not isinstance(value, list):
        raise ValueError(f"{key} must be an array of tables ([[{key}]])")
    return value


def _only(table: dict[str, Any], where: str, keys: set[str]) -> None:
    unknown = sorted(set(table) - keys)
    if unknown:
        prefix = f"{where}." if where else ""
        raise ValueError(f"unknown key {prefix}{unknown[0]} (known: {', '.join(sorted(keys))})")


def _names(
    entry: dict[str, Any], key: str, where: str, required: bool = False
) -> tuple[str, ...] | None:
    value = entry.get(key)
    if value is None:
        if required:
            raise ValueError(f"{where}.{key} is missing")
        return None
    if not isinstance(value, list) or not all(isinstance(item, str) for item in value):
        raise ValueError(f"{where}.{key} must be a list of names, not {value!r}")
    return tuple(value)


def _text(entry: dict[str, Any], key: str, where: str) -> str | None:
    value = entry.get(key)
    if value is not None and not isinstance(value, str):
        raise ValueError(f"{where}.{key} must be a string, not {value!r}")
    return value


class _Relay:
    """One running relay: its router, endpoints, counters and latency samples."""

    def __init__(self, codec: Codec, config: Config) -> None:
        self.config = config
        self.events: list[FailsafeEvent] = []
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
        self._targets: dict[str, tuple[UdpEndpoint, tuple[Any, ...]]] = {}

    async def run(self) -> None:
        import asyncio

        loop = asyncio.get_running_loop()
        stop = loop.create_future()

        def finish() -> None:
            if not stop.done():
                stop.set_result(None)

        for signum in (signal.SIGTERM, signal.SIGINT):
            loop.add_signal_handler(signum, finish)
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
            bound = ", ".join(
                f"{name} {shown(endpoint.address)}" for name, endpoint in self.endpoints.items()
            )
            click.echo(f"relaying: listening on {bound}", err=True)
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
        return {
            "routes": routes,
            "dropped": stats.dropped,
            "debug": stats.debug,
            "failsafe": {"engaged": stats.engaged, "released": stats.released},
            "engaged": sorted(self.router.engaged()),
            "latency_us": _percentiles(self.latencies),
            "listen": listening,
        }

    def _heard(self, listener: str) -> Any:
        sources, route, clock = self.config.sources, self.router.route, time.monotonic
        send, latencies = self._send, self.latencies

        def heard(data: bytes, sender: Any) -> None:
            start = time.perf_counter()
            source = sources.get(sender[:2], listener) if sources else listener
            for outgoing in route(data, source, clock()):
                send(outgoing.destination, outgoing.data)
            latencies.append(time.perf_counter() - start)

        return heard

    def _send(self, name: str, data: bytes) -> None:
        endpoint, address = self._targets[name]
        endpoint.send_datagram(data, address)

    def _event(self, event: FailsafeEvent) -> None:
        self.events.append(event)
        state = "engaged" if event.engaged else "released"
        click.echo(f"failsafe {event.kind} {state}", err=True)

    async def _poll(self) -> None:
        import asyncio

        poll, clock = self.router.poll, time.monotonic
        while True:
            for outgoing in poll(clock()):
                self._send(outgoing.destination, outgoing.data)
            await asyncio.sleep(_TICK)

    async def _report(self) -> None:
        import asyncio

        while True:
            await asyncio.sleep(self.config.interval)
            metrics = self.metrics()
            if self.config.status == "json":
                click.echo(json.dumps(metrics))
            else:
                click.echo(_line(metrics), err=True)


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
    dropped = sum(metrics["dropped"].values())
    latency = metrics["latency_us"]
    engaged = ",".join(metrics["engaged"]) or "-"
    return f"relay: {routes} dropped={dropped} engaged={engaged} p99={latency['p99']}us"
