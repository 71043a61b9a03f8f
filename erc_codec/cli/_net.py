"""``erc-codec send`` and ``erc-codec listen``: a message onto UDP, and what arrives, shown live.

``send`` is the fleet's ``udp_client`` made general. ``listen`` is an ``open_udp`` endpoint: it
prints one JSON line per datagram (or, on a terminal, a table per kind with the rates a
``Watchdog`` measures), counts every datagram that is dropped, by reason (those the kernel
dropped before they could be read, too), and prints the counters when it stops. Its JSON lines
are written a batch at a time (one write per batch of datagrams read): what listen costs per
datagram is then mostly the message's conversion to JSON (``benchmarks/bench_listen.py``).
"""

import contextlib
import json
import math
import socket
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO, cast

import click
from google.protobuf.message import Message

from .._codec import Codec
from .._dispatch import Dispatcher, DispatchStats, Drop
from .._envelope import Mode
from .._errors import EncodeError
from .._foxglove import FoxgloveView
from .._transport import UdpEndpoint, UdpStats, open_udp
from .._watchdog import Watchdog
from ._encode import MODE
from ._live import foxglove_view
from ._shared import Fatal, envelope_from_json, load, one_line, schema_options, to_dict

if TYPE_CHECKING:
    import asyncio

__all__ = ["FINITE", "listen", "parse_address", "resolve", "send", "shown"]

_REDRAW = 0.5  # seconds between two drawings of the table
_NAP = 3600.0  # the longest sleep between two sends (time.sleep refuses years)


class _Finite(click.FloatRange):
    """A positive, finite number: click's ``FloatRange`` lets ``nan`` and ``inf`` through (NaN
    fails no comparison with its bounds)."""

    name = "positive number"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        number = super().convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value!r} is not a finite number.", param, ctx)
        return number


FINITE = _Finite(min=0, min_open=True)  # --seconds, --rate: a positive, finite number


def parse_address(text: str, default_host: str | None = None) -> tuple[str, int]:
    """``HOST:PORT`` (``[v6]:PORT`` too) as (host, port); ``PORT`` alone with a default host."""
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


def resolve(host: str, port: int) -> tuple[socket.AddressFamily, tuple[Any, ...]]:
    """The family and socket address of ``host`` (a name or an IPv4 or IPv6 address). A name
    with addresses of both families takes IPv4, as the boards speak it: ``listen localhost:P``
    must hear a board that sends to 127.0.0.1, wherever the system lists ::1 first."""
    try:
        found = socket.getaddrinfo(host, port, type=socket.SOCK_DGRAM)
    except (OSError, UnicodeError) as error:
        reason = error.strerror if isinstance(error, OSError) and error.strerror else error
        raise Fatal(f"cannot resolve {host!r}: {reason}") from None
    family, _, _, _, address = min(found, key=lambda entry: entry[0] != socket.AF_INET)
    return family, address


def shown(address: tuple[Any, ...]) -> str:
    """``host:port``, with an IPv6 host in brackets so the port stays readable."""
    host, port = address[0], address[1]
    return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"


@click.command()
@click.argument("target", metavar="HOST:PORT")
@click.argument("kind")
@click.argument("payload", metavar="JSON")
@click.option("--count", type=click.IntRange(min=1), default=1, show_default=True)
@click.option("--rate", type=FINITE, help="Sends per second.")
@MODE
@schema_options
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
      erc-codec send 127.0.0.1:5000 drive_motor \\
          '{"distance_to_go": 1.5}' --rate 10 --count 50
    """
    host, port = parse_address(target)
    codec = load(tree, root)
    envelope = envelope_from_json(codec, kind, payload)
    try:
        data = codec.encode(envelope, cast(Mode, mode))
    except EncodeError as error:
        raise click.ClickException(one_line(str(error))) from None
    family, target_address = resolve(host, port)
    where = shown(target_address)
    with socket.socket(family, socket.SOCK_DGRAM) as sock:
        start = time.monotonic()
        for i in range(count):
            if rate is not None:
                due = start + i / rate
                while (wait := due - time.monotonic()) > 0:
                    time.sleep(min(wait, _NAP))
            try:
                sock.sendto(data, target_address)
            except OSError as error:
                raise Fatal(f"cannot send to {where}: {error}") from None
    click.echo(f"sent {count} datagram(s) of {len(data)} bytes to {where}", err=True)


@click.command()
@click.argument("address", metavar="[HOST:]PORT")
@click.option("--count", type=click.IntRange(min=1), help="Stop after this many datagrams.")
@click.option("--seconds", type=FINITE, help="Stop after this long.")
@click.option(
    "--format",
    "output",
    type=click.Choice(["auto", "json", "table"]),
    default="auto",
    show_default=True,
    help="auto: a live table on a terminal, JSON lines otherwise.",
)
@click.option("--foxglove", is_flag=True, help="Also serve what arrives to Foxglove, live.")
@click.option(
    "--foxglove-address",
    metavar="[HOST:]PORT",
    default="127.0.0.1:8765",
    show_default=True,
    help="Where the Foxglove WebSocket server listens (needs the foxglove extra).",
)
@schema_options
def listen(
    address: str,
    count: int | None,
    seconds: float | None,
    output: str,
    foxglove: bool,
    foxglove_address: str,
    tree: Path | None,
    root: str,
) -> None:
    """Print the datagrams arriving on [HOST:]PORT (host 127.0.0.1 unless given), decoded.

    Port 0 takes any free port; the address actually bound is the first line on stderr. The
    counters are printed on stderr when it stops (after --count datagrams, --seconds, or
    Ctrl-C): datagrams received, handled by kind, undecodable by reason, dropped; and those that
    never reached it: dropped by the kernel (its receive buffer full: null where the system does
    not say), unread (still queued when it stopped), with the receive buffer granted, in bytes
    (4 MiB is asked for; Linux grants up to twice net.core.rmem_max).
    With --foxglove, a Foxglove client (ws://127.0.0.1:8765 unless --foxglove-address says
    otherwise) sees every kind on /erc/<kind>, drops on /erc-codec/drops, the GPS fix on
    /erc-codec/fix and rates on /erc-codec/stats.
    """
    import asyncio

    host, port = parse_address(address, default_host="127.0.0.1")
    codec = load(tree, root)
    _, local = resolve(host, port)
    table = output == "table" or (output == "auto" and sys.stdout.isatty())
    live = foxglove_view(codec, *parse_address(foxglove_address, "127.0.0.1")) if foxglove else None
    session = _Listening(codec, _Table() if table else None, count, live)
    with contextlib.suppress(KeyboardInterrupt):  # Ctrl-C ends it as --count would
        try:
            asyncio.run(session.run(local, seconds))
        finally:
            if live is not None:
                live.close()
    session.flush()
    stats = session.dispatcher.stats()
    udp = session.udp or UdpStats(0, 0, 0, 0, 0)  # Ctrl-C before the socket was open
    summary = {
        "received": udp.received,
        "handled": stats.handled,
        "undecodable": stats.undecodable,
        "dropped": stats.dropped,
        "kernel_dropped": udp.kernel_dropped,
        "unread": udp.unread,
        "receive_buffer": udp.receive_buffer,
    }
    click.echo(f"counters: {json.dumps(summary)}", err=True)


class _Listening:
    """One ``listen``: an endpoint whose every datagram is shown as a JSON line, or counted in a
    table with the rates a watchdog measures."""

    def __init__(
        self, codec: Codec, view: "_Table | None", count: int | None, live: FoxgloveView | None
    ) -> None:
        self.dispatcher = Dispatcher(codec, on_drop=self._dropped)
        for kind in codec.kinds().values():
            self.dispatcher.register(kind, self._shower(kind))
        self.watchdog = Watchdog() if view is not None else None  # rates: for the table only
        self.udp: UdpStats | None = None  # the endpoint's counters, once it is closed
        self._to_dict = to_dict  # the fastest conversion there is: what listen can keep up with
        self._view = view
        self._live = live
        self._count = count
        self._heard = 0
        self._sender: Any = None  # the sender of the datagram being dispatched, as shown, and
        self._source = ""  # its length
        self._length = 0
        self._lines: list[str] = []  # JSON lines not written yet
        self._out: TextIO = sys.stdout
        self._loop: asyncio.AbstractEventLoop | None = None
        self._finished: asyncio.Future[None] | None = None  # --count reached, or output failed

    async def run(self, local: tuple[Any, ...], seconds: float | None) -> None:
        import asyncio

        loop = self._loop = asyncio.get_running_loop()
        finished = self._finished = loop.create_future()
        endpoint: UdpEndpoint | None = None

        def heard(data: bytes, sender: Any) -> None:
            self._heard += 1
            if sender != self._sender:
                self._sender, self._source = sender, shown(sender)
            self._length = len(data)
            if self._count is not None and self._heard >= self._count:
                if endpoint is not None:
                    endpoint.close()  # this one is still dispatched; none after it is read
                if not finished.done():
                    finished.set_result(None)

        try:
            endpoint = await open_udp(
                self.dispatcher, local[0], local[1], watchdog=self.watchdog, on_datagram=heard
            )
        except OSError as error:
            raise Fatal(f"cannot listen on {shown(local)}: {error}") from None
        host, port = endpoint.address
        click.echo(f"listening on {shown((host, port))}", err=True)
        drawing = loop.create_task(self._draw(self._view)) if self._view is not None else None
        try:
            await asyncio.wait([finished], timeout=seconds)
        finally:
            if drawing is not None:
                drawing.cancel()
            endpoint.close()
            self.udp = endpoint.stats()
        if finished.done() and finished.exception() is not None:
            raise cast(BaseException, finished.exception())  # the output could not be written
        if self._view is not None:
            self._view.render(self.dispatcher.stats(), self.watchdog)

    def flush(self) -> None:
        """Write the JSON lines not written yet, in one go."""
        if self._lines:
            text = "\n".join(self._lines) + "\n"
            self._lines.clear()
            self._out.write(text)
            self._out.flush()

    def _show(self, record: dict[str, object]) -> None:
        """One JSON line, written with the others of its batch (once the endpoint has read the
        datagrams waiting and the loop moves on)."""
        self._lines.append(json.dumps(record))
        if len(self._lines) == 1:
            assert self._loop is not None
            self._loop.call_soon(self._flush_or_fail)

    def _flush_or_fail(self) -> None:
        try:
            self.flush()
        except OSError as error:  # a closed pipe or a full disk ends the command
            if self._finished is not None and not self._finished.done():
                self._finished.set_exception(error)

    async def _draw(self, view: "_Table") -> None:
        import asyncio

        while True:
            view.render(self.dispatcher.stats(), self.watchdog)
            await asyncio.sleep(_REDRAW)

    def _shower(self, kind: str) -> Callable[[Message], None]:
        def show(message: Message) -> None:
            if self._live is not None:
                self._live.message(kind, message)
            if self._view is None:
                self._show(
                    {
                        "from": self._source,
                        "kind": kind,
                        "length": self._length,
                        "message": self._to_dict(message),
                    }
                )

        return show

    def _dropped(self, drop: Drop) -> None:
        if self._live is not None:
            self._live.drop(drop, self._source)
        if self._view is None:
            error = one_line(str(drop.error)) if drop.error else f"no handler for {drop.kind}"
            record = {"from": self._source, "error": error, "reason": drop.reason}
            self._show({**record, "length": len(drop.data)})


class _Table:
    """A per-kind table of counts and measured rates."""

    def render(self, stats: DispatchStats, watchdog: Watchdog | None) -> None:
        lines = [f"{'kind':<34}{'count':>8}{'rate Hz':>10}"]
        for kind in sorted(stats.handled):
            rate = (watchdog.rate(kind) if watchdog is not None else None) or 0.0
            lines.append(f"{kind:<34}{stats.handled[kind]:>8}{rate:>10.1f}")
        click.echo("\x1b[H\x1b[2J" + "\n".join(lines))
