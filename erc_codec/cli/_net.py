"""``erc-codec send`` and ``erc-codec listen``: a message onto UDP, and what arrives, shown live.

``send`` is the fleet's ``udp_client`` made general. ``listen`` prints one JSON line per datagram
(or, on a terminal, a table per kind with measured rates), counts every datagram that is dropped,
by reason, and prints the counters when it stops.
"""

import json
import socket
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, cast

import click
from google.protobuf.message import Message

from ._cli import (
    _emit,
    _Fatal,
    _load,
    _one_line,
    _schema_options,
    _to_dict,
    envelope_from_json,
    main,
)
from ._dispatch import Dispatcher, Drop
from ._envelope import Mode
from ._errors import EncodeError

__all__ = ["listen", "send"]

_LARGEST_DATAGRAM = 65535


def _address(text: str, default_host: str | None = None) -> tuple[str, int]:
    host, _, port = text.rpartition(":")
    host = host.removeprefix("[").removesuffix("]") if host.startswith("[") else host
    if not host and default_host is None:
        raise click.BadParameter(f"{text!r}: expected HOST:PORT")
    try:
        number = int(port)
    except ValueError:
        raise click.BadParameter(f"{text!r}: the port is not a number") from None
    if not 0 <= number <= 65535:
        raise click.BadParameter(f"{text!r}: the port must be within 0..65535")
    return (host or cast(str, default_host)), number


def _resolve(host: str, port: int) -> tuple[socket.AddressFamily, tuple[Any, ...]]:
    """The family and socket address of ``host`` (a name or an IPv4 or IPv6 address). A name
    with addresses of both families takes IPv4, as the boards speak it: ``listen localhost:P``
    must hear a board that sends to 127.0.0.1, wherever the system lists ::1 first."""
    try:
        found = socket.getaddrinfo(host, port, type=socket.SOCK_DGRAM)
    except (OSError, UnicodeError) as error:
        reason = error.strerror if isinstance(error, OSError) and error.strerror else error
        raise _Fatal(f"cannot resolve {host!r}: {reason}") from None
    family, _, _, _, address = min(found, key=lambda entry: entry[0] != socket.AF_INET)
    return family, address


def _shown(address: tuple[Any, ...]) -> str:
    """``host:port``, with an IPv6 host in brackets so the port stays readable."""
    host, port = address[0], address[1]
    return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"


@main.command()
@click.argument("target", metavar="HOST:PORT")
@click.argument("kind")
@click.argument("payload", metavar="JSON")
@click.option("--count", type=click.IntRange(min=1), default=1, show_default=True)
@click.option("--rate", type=click.FloatRange(min=0, min_open=True), help="Sends per second.")
@click.option(
    "--mode", type=click.Choice(["strip", "exact", "pad"]), default="strip", show_default=True
)
@_schema_options
def send(
    target: str,
    kind: str,
    payload: str,
    count: int,
    rate: float | None,
    mode: str,
    tree: Path | None,
    root: str,
) -> None:
    """Send one payload (protobuf JSON, as for encode) to HOST:PORT, COUNT times at RATE Hz.

    \b
      erc-codec send 127.0.0.1:5000 driving_motor_message \\
          '{"distance_to_go": 1.5}' --rate 10 --count 50
    """
    host, port = _address(target)
    codec = _load(tree, root)
    envelope = envelope_from_json(codec, kind, payload)
    try:
        data = codec.encode(envelope, cast(Mode, mode))
    except EncodeError as error:
        raise click.ClickException(_one_line(str(error))) from None
    family, target_address = _resolve(host, port)
    shown = _shown(target_address)
    with socket.socket(family, socket.SOCK_DGRAM) as sock:
        start = time.monotonic()
        for i in range(count):
            if rate is not None:
                time.sleep(max(0.0, start + i / rate - time.monotonic()))
            try:
                sock.sendto(data, target_address)
            except OSError as error:
                raise _Fatal(f"cannot send to {shown}: {error}") from None
    click.echo(f"sent {count} datagram(s) of {len(data)} bytes to {shown}", err=True)


@main.command()
@click.argument("address", metavar="[HOST:]PORT")
@click.option("--count", type=click.IntRange(min=1), help="Stop after this many datagrams.")
@click.option(
    "--seconds", type=click.FloatRange(min=0, min_open=True), help="Stop after this long."
)
@click.option(
    "--format",
    "output",
    type=click.Choice(["auto", "json", "table"]),
    default="auto",
    show_default=True,
    help="auto: a live table on a terminal, JSON lines otherwise.",
)
@_schema_options
def listen(
    address: str,
    count: int | None,
    seconds: float | None,
    output: str,
    tree: Path | None,
    root: str,
) -> None:
    """Print the datagrams arriving on [HOST:]PORT (host 127.0.0.1 unless given), decoded.

    Port 0 takes any free port; the address actually bound is the first line on stderr. The drop
    counters are printed when it stops: after --count datagrams, --seconds, or Ctrl-C.
    """
    host, port = _address(address, default_host="127.0.0.1")
    codec = _load(tree, root)
    table = output == "table" or (output == "auto" and sys.stdout.isatty())
    view = _Table() if table else None
    source: list[str] = [""]  # the sender of the datagram being dispatched

    def show(kind: str, message: Message, size: int) -> None:
        if view is not None:
            view.arrived(kind)
        else:
            _emit({"from": source[0], "kind": kind, "length": size, "message": _to_dict(message)})

    def dropped(drop: Drop) -> None:
        if view is None:
            error = _one_line(str(drop.error)) if drop.error else f"no handler for {drop.kind}"
            record = {"from": source[0], "error": error, "reason": drop.reason}
            _emit({**record, "length": len(drop.data)})

    dispatcher = Dispatcher(codec, on_drop=dropped)
    sizes: list[int] = [0]

    def handler(kind: str) -> Callable[[Message], None]:
        return lambda message: show(kind, message, sizes[0])

    for kind in codec.kinds().values():
        dispatcher.register(kind, handler(kind))
    family, local = _resolve(host, port)
    received = 0
    with socket.socket(family, socket.SOCK_DGRAM) as sock:
        try:
            sock.bind(local)
        except OSError as error:
            raise _Fatal(f"cannot listen on {_shown(local)}: {error}") from None
        click.echo(f"listening on {_shown(sock.getsockname())}", err=True)
        deadline = None if seconds is None else time.monotonic() + seconds
        try:
            while count is None or received < count:
                wait = 0.5 if deadline is None else deadline - time.monotonic()
                if wait <= 0:
                    break
                sock.settimeout(min(wait, 0.5))
                try:
                    data, sender = sock.recvfrom(_LARGEST_DATAGRAM)
                except TimeoutError:
                    if view is not None:
                        view.render()
                    continue
                received += 1
                source[0], sizes[0] = _shown(sender), len(data)
                dispatcher.feed(data)
                if view is not None:
                    view.render()
        except KeyboardInterrupt:
            pass
    stats = dispatcher.stats()
    summary = {
        "received": received,
        "handled": stats.handled,
        "undecodable": stats.undecodable,
        "dropped": stats.dropped,
    }
    click.echo(f"counters: {json.dumps(summary)}", err=True)


class _Table:
    """A per-kind table of counts and measured rates, redrawn at most twice a second."""

    def __init__(self) -> None:
        self._counts: dict[str, int] = {}
        self._first: dict[str, float] = {}
        self._last: dict[str, float] = {}
        self._drawn = 0.0

    def arrived(self, kind: str) -> None:
        now = time.monotonic()
        self._counts[kind] = self._counts.get(kind, 0) + 1
        self._first.setdefault(kind, now)
        self._last[kind] = now

    def render(self) -> None:
        now = time.monotonic()
        if now - self._drawn < 0.5:
            return
        self._drawn = now
        lines = [f"{'kind':<34}{'count':>8}{'rate Hz':>10}"]
        for kind in sorted(self._counts):
            span = self._last[kind] - self._first[kind]
            rate = (self._counts[kind] - 1) / span if span > 0 else 0.0
            lines.append(f"{kind:<34}{self._counts[kind]:>8}{rate:>10.1f}")
        click.echo("\x1b[H\x1b[2J" + "\n".join(lines))
