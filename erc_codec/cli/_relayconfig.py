"""The ``erc-codec relay`` configuration: the TOML file read and checked against the schema.

Every key is checked: an unknown one, a bad address, an unknown kind or destination is a
``Fatal`` of one line naming the file and the key (exit 2). So is what could only misbehave: a
destination the relay itself receives on, however it is spelled (it would forward to itself
forever), a destination or named sender at port 0, a wildcard host or the relay's own listener,
a destination of the other family than the socket it is sent from (an IPv4 one from ``[::]`` is
sent to as its IPv4-mapped address), one name twice in a list, two ``[sources]`` names for one
address, failsafe timings out of their bounds, and a file over 1 MiB.
"""

import sys
from pathlib import Path
from typing import Any, NamedTuple, cast

import click
from google.protobuf import json_format

from ..codec import Codec, Mode
from ..runtime._router import Failsafe, Route, failsafe_timing
from ..runtime.checks import duration
from ._local import WILDCARDS, canonical, receives, spellings
from ._shared import Fatal, one_line, parse_address, resolve

__all__ = ["TICK", "Config", "Destination", "read_config"]

TICK = 0.002  # seconds between two polls of the failsafes: they repeat at most 1 / TICK a second
_INTERVALS = (0.01, 3600.0)  # seconds between two status reports (a hundred lines a second)
_SLOWEST = 0.01  # Hz: the slowest failsafe rate, as the Router allows it
_LARGEST = 1 << 20  # bytes: a relay configuration is a page or two of TOML


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


def read_config(path: Path, codec: Codec) -> Config:
    """The relay configuration in ``path``, checked against ``codec``'s schema."""
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # tomllib is tomli, joined to the standard library in 3.11
        import tomli as tomllib
    try:
        with path.open("rb") as file:
            data = file.read(_LARGEST + 1)
    except OSError as error:
        raise Fatal(f"{path}: {error.strerror or error}") from None
    if len(data) > _LARGEST:
        raise Fatal(f"{path}: larger than {_LARGEST >> 20} MiB: not a relay configuration")
    try:
        document = tomllib.loads(data.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as error:
        raise Fatal(f"{path}: not TOML: {one_line(str(error))}") from None
    except RecursionError:
        raise Fatal(f"{path}: not TOML: nested too deeply") from None
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
        listen: dict[str, tuple[Any, ...]] = {}
        for name, text in _table(document, "listen").items():
            address = self.address(f"listen.{name}", text, default_host="127.0.0.1")
            for other, bound in listen.items():  # port 0: a free port, another each time
                if address[1] and (receives(bound, address) or receives(address, bound)):
                    raise ValueError(f"listen.{name}: {text!r} is where listen.{other} listens")
            listen[name] = address
        if not listen:
            raise ValueError("[listen] names no endpoint: the relay needs at least one")
        destinations = self.destinations(document, listen)
        sources = self.sources(document, listen)
        senders = set(listen) | set(sources.values())
        targets = set(destinations)
        routes = [
            self.route(i, entry, senders, targets)
            for i, entry in enumerate(_list(document, "routes"))
        ]
        failsafes = self.failsafes(document, senders, targets)
        status = settings.get("status", "line")
        if status not in ("line", "json", "none"):
            raise ValueError(f"relay.status must be line, json or none, not {status!r}")
        interval = duration("relay.interval", settings.get("interval", 1.0))
        shortest, longest = _INTERVALS
        if not shortest <= interval <= longest:
            raise ValueError(
                f"relay.interval must be from {shortest:g} to {longest:g} s, not {interval!r}"
            )
        debug = _text(settings, "debug", "relay")
        if debug is not None and debug not in destinations:
            raise ValueError(
                f"relay.debug: no destination {debug!r} "
                f"(destinations: {', '.join(destinations) or 'none'})"
            )
        return Config(listen, destinations, sources, routes, failsafes, debug, status, interval)

    def destinations(
        self, document: dict[str, Any], listen: dict[str, tuple[Any, ...]]
    ) -> dict[str, Destination]:
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
            via = _text(entry, "via", where) or first
            if via not in listen:
                raise ValueError(f"{where}.via: no [listen] endpoint {via!r}")
            if "address" not in entry:
                raise ValueError(f"{where}.address is missing")
            address = self.address(f"{where}.address", entry["address"])
            _peer(f"{where}.address", address, listen, "destination")
            destinations[name] = Destination(
                _sendable(f"{where}.address", address, via, listen[via]), cast(Mode, form), via
            )
        return destinations

    def sources(
        self, document: dict[str, Any], listen: dict[str, tuple[Any, ...]]
    ) -> dict[tuple[str, int], str]:
        sources: dict[tuple[str, int], str] = {}
        for name, text in _table(document, "sources").items():
            if name in listen:
                raise ValueError(
                    f"sources.{name}: {name!r} names a [listen] endpoint too: a route's sources "
                    "could not tell them apart"
                )
            address = self.address(f"sources.{name}", text)
            _peer(f"sources.{name}", address, listen, "sender")
            host, port = address[:2]
            named = sources.get((canonical(host), port))
            if named is not None:
                raise ValueError(f"sources.{name}: {text!r} is sources.{named} already")
            for spelling in spellings(host):  # as a dual-stack socket reports it, too
                sources[(spelling, port)] = name
        return sources

    def failsafes(
        self, document: dict[str, Any], senders: set[str], targets: set[str]
    ) -> list[Failsafe]:
        failsafes: list[Failsafe] = []
        for i, entry in enumerate(_list(document, "failsafes")):
            failsafe = self.failsafe(i, entry, senders, targets)
            for j, other in enumerate(failsafes):
                if other.kind == failsafe.kind:
                    raise ValueError(
                        f"failsafes[{i}].kind: {failsafe.kind} has a failsafe already "
                        f"(failsafes[{j}]): one per kind"
                    )
            failsafes.append(failsafe)
        return failsafes

    def address(self, where: str, text: Any, default_host: str | None = None) -> tuple[Any, ...]:
        if not isinstance(text, str):
            raise ValueError(f'{where} must be a string "HOST:PORT", not {text!r}')
        try:
            host, port = parse_address(text, default_host)
            return resolve(host, port)[1]
        except click.ClickException as error:  # BadParameter, or Fatal: a name not resolved
            raise ValueError(f"{where}: {error.format_message()}") from None

    def route(self, index: int, entry: Any, senders: set[str], targets: set[str]) -> Route:
        where = f"routes[{index}]"
        if not isinstance(entry, dict):
            raise ValueError(f"{where} must be a table")
        _only(entry, where, {"to", "kinds", "sources", "sender", "receiver"})
        return Route(
            _targets(entry, where, targets),
            self.kinds(entry, where),
            _senders(entry, where, senders),
            _text(entry, "sender", where),
            _text(entry, "receiver", where),
        )

    def kinds(self, entry: dict[str, Any], where: str) -> tuple[str, ...] | None:
        """``entry``'s ``kinds``: each a payload kind of the schema."""
        names = _names(entry, "kinds", where)
        known = set(self.codec.kinds().values())
        for name in names or ():
            if name not in known:
                raise ValueError(
                    f"{where}.kinds: {name!r} is not a payload kind of {self.codec.root}"
                )
        return names

    def failsafe(self, index: int, entry: Any, senders: set[str], targets: set[str]) -> Failsafe:
        where = f"failsafes[{index}]"
        if not isinstance(entry, dict):
            raise ValueError(f"{where} must be a table")
        _only(entry, where, {"kind", "message", "to", "rate", "timeout", "sources"})
        kind = _text(entry, "kind", where)
        if kind is None or kind not in self.codec.kinds().values():
            raise ValueError(f"{where}.kind: {kind!r} is not a payload kind of {self.codec.root}")
        message = self.codec.message_class(kind)()
        fields = entry.get("message", {})
        if not isinstance(fields, dict):
            raise ValueError(
                f"{where}.message must be a table (the payload's fields), not {fields!r}"
            )
        try:
            json_format.ParseDict(fields, message)
        except json_format.ParseError as error:
            raise ValueError(f"{where}.message: {error}") from None
        rate, timeout = entry.get("rate"), entry.get("timeout")
        if rate is None:
            raise ValueError(f"{where}.rate is missing (failsafe messages a second)")
        number = not isinstance(rate, bool) and isinstance(rate, (int, float))
        if not number or not _SLOWEST <= rate <= 1 / TICK:
            raise ValueError(
                f"{where}.rate must be a number of Hz from {_SLOWEST:g} to {1 / TICK:g} (the "
                f"relay polls every {TICK * 1000:g} ms), not {rate!r}"
            )
        if timeout is None:
            raise ValueError(f"{where}.timeout is missing (seconds of silence before it engages)")
        try:
            failsafe_timing(rate, timeout)
        except ValueError as error:
            raise ValueError(f"{where}.{error}") from None
        return Failsafe(
            kind,
            message,
            _targets(entry, where, targets),
            rate,
            timeout,
            _senders(entry, where, senders),
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
    if not value:  # a route or failsafe that could never take anything
        advice = "name at least one" if required else "leave it out or name at least one"
        raise ValueError(f"{where}.{key} = [] names nothing: {advice}")
    twice = next((name for i, name in enumerate(value) if name in value[:i]), None)
    if twice is not None:
        raise ValueError(f"{where}.{key} names {twice!r} twice")
    return tuple(value)


def _targets(entry: dict[str, Any], where: str, targets: set[str]) -> tuple[str, ...]:
    """``entry``'s ``to``: each a [destinations] name."""
    names = _names(entry, "to", where, required=True) or ()
    for name in names:
        if name not in targets:
            raise ValueError(
                f"{where}.to: no destination {name!r} (destinations: "
                f"{', '.join(sorted(targets)) or 'none'})"
            )
    return names


def _senders(entry: dict[str, Any], where: str, senders: set[str]) -> tuple[str, ...] | None:
    """``entry``'s ``sources``: each a [listen] endpoint or a [sources] name."""
    names = _names(entry, "sources", where)
    for name in names or ():
        if name not in senders:
            raise ValueError(
                f"{where}.sources: no sender {name!r} (the [listen] endpoints and [sources] "
                f"names: {', '.join(sorted(senders))})"
            )
    return names


def _peer(
    where: str, address: tuple[Any, ...], listen: dict[str, tuple[Any, ...]], role: str
) -> None:
    """Refuse a peer (a destination, or a named sender) that cannot be one: at port 0, at a
    wildcard host, or where the relay itself receives (sent there, a datagram would be forwarded
    forever; sent from there, it is the relay's own and dropped)."""
    if address[1] == 0:
        raise ValueError(f"{where}: port 0 is no {role}")
    if canonical(address[0]) in WILDCARDS:
        raise ValueError(f"{where}: {address[0]} means every local address, no {role}")
    for name, bound in listen.items():
        if receives(bound, address):
            raise ValueError(f"{where}: the relay listens there itself ([listen] {name})")


def _sendable(
    where: str, address: tuple[Any, ...], via: str, bound: tuple[Any, ...]
) -> tuple[Any, ...]:
    """``address`` as the socket of [listen] ``via`` sends to it: an IPv4 address from a
    dual-stack socket (bound to ``::``) as its IPv4-mapped IPv6 address; an address of the other
    family from any other socket is refused, as no send could reach it."""
    if (len(address) == 4) == (len(bound) == 4):
        return address
    if len(bound) == 4 and canonical(bound[0]) == "::":
        return (f"::ffff:{address[0]}", address[1], 0, 0)
    family, other = ("IPv4", "IPv6") if len(bound) == 2 else ("IPv6", "IPv4")
    raise ValueError(
        f"{where}: an {other} address, and via = {via!r} is an {family} socket: send it from "
        f"a [listen] endpoint of its family{' or from [::]' if other == 'IPv4' else ''}"
    )


def _text(entry: dict[str, Any], key: str, where: str) -> str | None:
    value = entry.get(key)
    if value is not None and not isinstance(value, str):
        raise ValueError(f"{where}.{key} must be a string, not {value!r}")
    return value
