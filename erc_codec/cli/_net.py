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
import signal
import socket
import sys
import time
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, Any, TextIO, cast

import click
from google.protobuf.message import Message

from erc_schema import EncodeError

from ..capture import FoxgloveView
from ..codec import Codec, Mode
from ..runtime import Dispatcher, DispatchStats, Drop, Watchdog
from ..transport import UdpEndpoint, UdpStats, open_udp
from ._live import foxglove_view
from ._shared import (
    FINITE,
    MODE,
    Fatal,
    envelope_from_json,
    load,
    one_line,
    parse_address,
    resolve,
    schema_options,
    shown,
    to_dict,
)

if TYPE_CHECKING:
    import asyncio

__all__ = ["listen", "send"]

_REDRAW = 0.5  # seconds between two drawings of the table
_NAP = 3600.0  # the longest sleep between two sends (time.sleep refuses years)


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
    tree: str | None,
    root: str | None,
) -> None:
    """Send one payload (protobuf JSON, as for encode; - reads it from standard
    input, a line erc-codec decode printed too) to HOST:PORT, COUNT times at RATE Hz.

    \b
      erc-codec send 127.0.0.1:5000 drive_motor \\
          '{"distance_to_go": 1.5}' --rate 10 --count 50

    It prints how many it sent on stderr when done, or when Ctrl-C or SIGTERM
    stops it (exit status 0 then too).
    """
    host, port = parse_address(target)
    codec = load(tree, root)
    envelope = envelope_from_json(codec, kind, sys.stdin.read() if payload == "-" else payload)
    try:
        data = codec.encode(envelope, cast(Mode, mode))
    except EncodeError as error:
        raise click.ClickException(one_line(str(error))) from None
    family, target_address = resolve(host, port)
    where = shown(target_address)
    sent, stopped = 0, ""
    with socket.socket(family, socket.SOCK_DGRAM) as sock, _signals_interrupt():
        start = time.monotonic()
        try:
            for i in range(count):
                if rate is not None:
                    due = start + i / rate
                    while (wait := due - time.monotonic()) > 0:
                        time.sleep(min(wait, _NAP))
                try:
                    sock.sendto(data, target_address)
                except OSError as error:
                    raise Fatal(f"cannot send to {where}: {error}") from None
                sent += 1
        except KeyboardInterrupt:  # Ctrl-C, or SIGTERM: stop, and say how far it got
            stopped = " (stopped by a signal)"
    total = f"{sent}" if sent == count else f"{sent} of {count}"
    click.echo(f"sent {total} datagram(s) of {len(data)} bytes to {where}{stopped}", err=True)


@contextlib.contextmanager
def _signals_interrupt() -> Iterator[None]:
    """SIGTERM raises ``KeyboardInterrupt`` as Ctrl-C does, for the block (so ``kill`` ends a
    command as Ctrl-C does: with its summary, exit status 0)."""
    previous = signal.signal(signal.SIGTERM, _interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _interrupt(number: int, frame: object) -> None:
    raise KeyboardInterrupt


def _watches(
    ctx: click.Context, param: click.Parameter, values: tuple[str, ...]
) -> tuple[tuple[str, float], ...]:
    """``KIND=PERIOD`` each: a kind expected every PERIOD seconds (positive, finite)."""
    watches = []
    for value in values:
        kind, equals, period = value.partition("=")
        if not equals or not kind:
            raise click.BadParameter(f"{value!r}: expected KIND=PERIOD (seconds), e.g. gps_info=1")
        try:
            watches.append((kind, float(FINITE.convert(period, param, ctx))))
        except click.BadParameter:
            raise click.BadParameter(
                f"{value!r}: the period must be a positive, finite number of seconds"
            ) from None
    return tuple(watches)


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
@click.option(
    "--watch",
    "watches",
    multiple=True,
    callback=_watches,
    metavar="KIND=PERIOD",
    help="Expect KIND every PERIOD seconds: an alert when none came for 3 periods, and when it "
    "is back (repeatable).",
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
    watches: tuple[tuple[str, float], ...],
    foxglove: bool,
    foxglove_address: str,
    tree: str | None,
    root: str | None,
) -> None:
    """Print the datagrams arriving on [HOST:]PORT (host 127.0.0.1 unless given), decoded.

    Port 0 takes any free port; the address actually bound is the first line on stderr. JSON
    lines: one per datagram, an error object for each one dropped (with its reason), and with
    --watch an alert object when a kind goes silent ({"alert": "silent", "kind": ...,
    "period": ..., "timeout": ..., "silent_for": ...}) and when it is back ({"alert": "back",
    ...}); a kind whose sender advertises a timeout is watched by it without --watch. The table
    shows per kind its count, its rate over the last 5 seconds (falling to 0 when it stops),
    how long ago it was last seen and, watched, whether it is SILENT; below it, the datagrams
    dropped by reason, the kernel's drops included, as they happen.

    The counters are printed on stderr when it stops (after --count datagrams, --seconds,
    Ctrl-C or SIGTERM: exit status 0): datagrams received, handled by kind, undecodable by
    reason, dropped; the fields beside the payloads that the schema does not know, which no
    line shows, by number (unkept: datagrams carrying each of the first 256 numbers seen;
    unkept_unlisted: the fields of any other number); and those that never reached it: dropped
    by the kernel (its receive buffer full: null where the system does not say), unread (still
    queued when it stopped), with the receive buffer granted, in bytes (4 MiB is asked for;
    Linux grants up to twice net.core.rmem_max). With --foxglove, a Foxglove client
    (ws://127.0.0.1:8765 unless --foxglove-address says otherwise) sees every kind on
    /erc/<kind>, drops on /erc-codec/drops, the GPS fix on /erc-codec/fix and rates on
    /erc-codec/stats.
    """
    import asyncio

    host, port = parse_address(address, default_host="127.0.0.1")
    codec = load(tree, root)
    kinds = set(codec.kinds().values())
    for kind, _ in watches:
        if kind not in kinds:
            raise Fatal(f"--watch: unknown kind {kind!r}: {codec.root} has {', '.join(kinds)}")
    _, local = resolve(host, port)
    table = output == "table" or (output == "auto" and sys.stdout.isatty())
    live = foxglove_view(codec, *parse_address(foxglove_address, "127.0.0.1")) if foxglove else None
    session = _Listening(codec, _Table() if table else None, count, dict(watches), live)
    with contextlib.suppress(KeyboardInterrupt):  # Ctrl-C before the loop runs: as --count
        try:
            asyncio.run(session.run(local, seconds))
        finally:
            if live is not None:
                live.close()
    session.flush()
    stats = session.dispatcher.stats()
    udp = session.udp or UdpStats(0, 0, 0, 0, 0)  # stopped before the socket was open
    summary = {
        "received": udp.received,
        "handled": stats.handled,
        "undecodable": stats.undecodable,
        "dropped": stats.dropped,
        "kernel_dropped": udp.kernel_dropped,
        "unread": udp.unread,
        "receive_buffer": udp.receive_buffer,
    }
    if stats.unkept:  # fields beside the payloads, unknown to the schema, which no line shows
        summary["unkept"] = {str(number): n for number, n in sorted(stats.unkept.items())}
    if stats.unkept_unlisted:  # fields of the numbers past those listed
        summary["unkept_unlisted"] = stats.unkept_unlisted
    click.echo(f"counters: {json.dumps(summary)}", err=True)


class _Listening:
    """One ``listen``: an endpoint whose every datagram is shown as a JSON line, or counted in a
    table with its rate; kinds watched raise alerts through a ``Watchdog``."""

    def __init__(
        self,
        codec: Codec,
        view: "_Table | None",
        count: int | None,
        watches: dict[str, float],
        live: FoxgloveView | None = None,
    ) -> None:
        self.dispatcher = Dispatcher(codec, on_drop=self._dropped)
        for kind in codec.kinds().values():
            self.dispatcher.register(kind, self._shower(kind))
        self.watches = watches
        # Kinds --watch names, and those whose senders advertise a timeout on the wire.
        self.watchdog = Watchdog(on_timeout=self._silent, on_recover=self._back)
        for kind, period in watches.items():
            self.watchdog.watch(kind, period)
        self.silent: set[str] = set()
        self.udp: UdpStats | None = None  # the endpoint's counters, once it is closed
        self._endpoint: UdpEndpoint | None = None
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

        def stop() -> None:  # --count reached, Ctrl-C or SIGTERM
            if not finished.done():
                finished.set_result(None)

        def heard(data: bytes, sender: Any) -> None:
            self._heard += 1
            if sender != self._sender:
                self._sender, self._source = sender, shown(sender)
            self._length = len(data)
            if self._count is not None and self._heard >= self._count:
                if endpoint is not None:
                    endpoint.close()  # this one is still dispatched; none after it is read
                stop()

        for number in (signal.SIGINT, signal.SIGTERM):
            with contextlib.suppress(NotImplementedError, RuntimeError):  # not on every system
                loop.add_signal_handler(number, stop)
        try:
            endpoint = self._endpoint = await open_udp(
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
            self._render(self._view)

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
            self._render(view)
            await asyncio.sleep(_REDRAW)

    def _render(self, view: "_Table") -> None:
        live = self._endpoint.stats() if self._endpoint is not None else None
        view.render(self.dispatcher.stats(), live, self.watches, self.silent, self.watchdog)

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

    def _silent(self, kind: str) -> None:
        self.silent.add(kind)
        if self._view is None:
            record = {"alert": "silent", **self._watch(kind)}
            self._show({**record, "silent_for": self._silent_for(kind)})

    def _back(self, kind: str) -> None:
        self.silent.discard(kind)
        if self._view is None:
            self._show({"alert": "back", **self._watch(kind)})

    def _watch(self, kind: str) -> dict[str, object]:
        """What an alert says of the watch: the kind, the period --watch gave (``None`` for a
        kind watched only by its sender's advertised timeout) and the timeout that passed."""
        return {
            "kind": kind,
            "period": self.watches.get(kind),
            "timeout": self.watchdog.timeout(kind),
        }

    def _silent_for(self, kind: str) -> float | None:
        """Seconds since ``kind`` last arrived, by the clock the watchdog was told the arrival
        on (``open_udp``'s, ``time.monotonic``), rounded up to the millisecond: never less than
        the timeout that passed. ``None`` if it never arrived (the watchdog then stays quiet)."""
        last = self.watchdog.last_seen(kind)
        if last is None:
            return None
        return math.ceil((time.monotonic() - last) * 1000) / 1000


class _Table:
    """A per-kind table of counts, rates and ages, with the drops by reason below it."""

    def render(
        self,
        stats: DispatchStats,
        udp: UdpStats | None,
        watches: dict[str, float],
        silent: set[str],
        watchdog: Watchdog,
    ) -> None:
        now = time.monotonic()
        lines = [f"{'kind':<34}{'count':>8}{'rate Hz':>10}{'last seen':>12}  watch"]
        for kind in sorted(set(stats.handled) | set(watches)):
            last = watchdog.last_seen(kind)
            age = "never" if last is None else f"{now - last:.1f} s ago"
            watch = ""
            timeout = watchdog.timeout(kind)
            if timeout is not None:
                state = "SILENT" if kind in silent else "ok" if last is not None else "waiting"
                every = f"every {watches[kind]:g} s" if kind in watches else "advertised"
                watch = f"{state} ({every}, timeout {timeout:g} s)"
            lines.append(
                f"{kind:<34}{stats.handled.get(kind, 0):>8}{watchdog.recent_rate(kind, now):>10.1f}"
                f"{age:>12}  {watch}".rstrip()
            )
        drops = [
            *(f"undecodable {why}: {n}" for why, n in sorted(stats.undecodable.items())),
            *(f"no handler for {kind}: {n}" for kind, n in sorted(stats.unhandled.items())),
            *(f"handler error in {kind}: {n}" for kind, n in sorted(stats.handler_errors.items())),
        ]
        if udp is not None and udp.kernel_dropped:
            drops.append(f"dropped by the kernel: {udp.kernel_dropped}")
        lines += ["", "dropped: " + ("; ".join(drops) if drops else "none")]
        if silent:
            lines.append(f"ALERT silent: {', '.join(sorted(silent))}")
        click.echo("\x1b[H\x1b[2J" + "\n".join(lines))
