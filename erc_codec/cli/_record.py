"""``erc-codec record`` and ``erc-codec replay``: live datagrams into an MCAP file, and a recording
(MCAP, pcap/pcapng, decode's JSON lines) back onto UDP with its timing; and ``decode --pcap
--mcap``'s conversion (``listen --foxglove``'s server is ``_live``'s).

``record`` is ``listen`` writing instead of printing: an ``open_udp`` endpoint whose dispatcher
hands every payload to an ``McapWriter`` and every drop to its drops channel, with each
datagram's arrival time and sender. It ends as ``listen`` does (``--count``, ``--seconds``,
Ctrl-C, and SIGTERM and SIGHUP too), always with a complete file, and says what it received,
what it wrote and what the kernel dropped before the socket was read. ``replay`` sends each
recorded datagram re-encoded in the form asked for, at its recorded time (scaled by
``--speed``), and says what it sent, what it did not send and why, and how late it ran.
"""

import contextlib
import json
import math
import signal
import socket
import struct
import sys
import time
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any, BinaryIO, NamedTuple, cast

import click
from google.protobuf import json_format
from google.protobuf.message import DecodeError as ProtobufDecodeError
from google.protobuf.message import Message

from erc_schema import CodecError, EncodeError

from ..capture._mcap import McapWriter, holds_log_time, recorded_payloads, unkept_summary
from ..capture._recording import nanoseconds
from ..codec import Codec, Decoded, Mode
from ..runtime import Dispatcher, Drop
from ..transport import UdpEndpoint, open_udp
from ._pcap import Capture
from ._shared import (
    MODE,
    Fatal,
    load,
    one_line,
    parse_address,
    plural,
    resolve,
    schema_options,
    shown,
)
from ._writer import WriterProcess

__all__ = ["capture_to_mcap", "record", "replay"]

_UNTIMELY = "time outside MCAP's range"  # the skip reason of a datagram MCAP cannot log
_STOPS = ("SIGINT", "SIGTERM", "SIGHUP")  # what ends a recording (SIGHUP: not on Windows)
_MCAP_MAGIC = b"\x89MCAP0\r\n"
_CAPTURE_MAGICS = {
    b"\xd4\xc3\xb2\xa1",  # pcap, microseconds, little-endian
    b"\xa1\xb2\xc3\xd4",
    b"\x4d\x3c\xb2\xa1",  # pcap, nanoseconds
    b"\xa1\xb2\x3c\x4d",
    b"\x0a\x0d\x0d\x0a",  # pcapng section header block
}


def create(output: Path) -> BinaryIO:
    """A new file: an existing one (last week's run) is never overwritten, even one made
    between a check and the open (the open itself refuses)."""
    try:
        return output.open("xb")
    except FileExistsError:
        raise Fatal(f"{output} exists: remove it or choose another name") from None
    except OSError as error:
        raise Fatal(f"cannot write {output}: {error.strerror or error}") from None


# -- decode --pcap --mcap ------------------------------------------------------------------------


def capture_to_mcap(capture: Capture, codec: Codec, output: Path) -> tuple[int, str]:
    """Write every UDP datagram of a capture to an MCAP file: the number that are not messages
    in it (written as drops, or skipped for a time MCAP cannot hold) and the summary line.

    A datagram without a time (a pcapng Simple Packet Block's) is logged at the time of the one
    written before it (0, the epoch, if none was); one whose time MCAP cannot hold (before 1970,
    after 2554) is skipped, counted with the capture's skipped packets. A damaged capture is
    written up to the damage, the file finished, the summary printed, then the damage is the
    command's error (exit 2)."""
    file = create(output)
    untimely = 0  # datagrams whose time MCAP cannot hold
    try:
        writer = McapWriter(file, codec, source=f"capture {capture.path.name}")
        write = writer.write
        last = 0  # the log time of the datagram written last
        try:
            for at, source, destination, data in capture.datagrams():
                log_time = last if at is None else nanoseconds(at)
                if not holds_log_time(log_time):
                    untimely += 1
                    continue
                write(data, log_time, source, destination)
                last = log_time
        finally:
            skipped = dict(capture.skipped)
            if untimely:
                skipped[_UNTIMELY] = untimely
            extra = {f"capture.skipped.{why}": str(n) for why, n in sorted(skipped.items())}
            if capture.damage:
                extra["capture.damage"] = capture.damage
            writer.close(extra)
    except BaseException as error:  # no half-written file to block the retry
        file.close()
        output.unlink()
        if isinstance(error, ImportError):  # it names the extra to install
            raise Fatal(str(error)) from None
        if isinstance(error, OSError):
            raise Fatal(f"cannot write {output}: {error.strerror or error}") from None
        raise
    file.close()
    stats = writer.stats()
    messages, failed = sum(stats.messages.values()), sum(stats.drops.values())
    reasons = ", ".join(f"{count} {why}" for why, count in sorted(skipped.items()))
    summary = (
        f"{plural(messages + failed, 'datagram')}, {failed} undecodable, "
        f"{plural(sum(skipped.values()), 'packet')} skipped"
        + (f" ({reasons})" if reasons else "")
        + f"; {output}: {plural(messages, 'message')} on {plural(len(stats.messages), 'channel')}"
        + f", {plural(failed, 'drop')}"
        + _unkept(stats.unkept, stats.unkept_unlisted, codec.root)
    )
    if capture.damage:
        click.echo(summary, err=True)
        raise Fatal(one_line(capture.damage))
    return failed + untimely, summary


def _unkept(unkept: Mapping[int, int], unlisted: int, root: str) -> str:
    """The summary's words for fields beside the payloads that the recording could not keep:
    by number, and those of the numbers past the ones listed together."""
    if not unkept:
        return ""
    fields = [f"{number} ({count})" for number, count in sorted(unkept.items())]
    if unlisted:
        fields.append(f"other numbers ({unlisted})")
    return f"; not recorded: fields {root} does not know beside the payload: {', '.join(fields)}"


# -- record --------------------------------------------------------------------------------------


@click.command()
@click.argument("address", metavar="[HOST:]PORT")
@click.argument("output", metavar="OUT.mcap", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--count", type=click.IntRange(min=1), help="Stop after this many datagrams.")
@click.option(
    "--seconds", type=click.FloatRange(min=0, min_open=True), help="Stop after this long."
)
@schema_options
def record(
    address: str,
    output: Path,
    count: int | None,
    seconds: float | None,
    tree: str | None,
    root: str | None,
) -> None:
    """Record the datagrams arriving on [HOST:]PORT (host 127.0.0.1 unless given) to an MCAP file.

    \b
      erc-codec record 0.0.0.0:5000 run.mcap
    One channel per envelope member (/erc/<kind>, protobuf, the payload's
    schema with its imports), every datagram that does not decode on
    /erc-codec/drops with its bytes, reason and sender; log time is the
    arrival time. The file opens in Foxglove and reads with any MCAP reader
    (erc_codec.capture.read_mcap in Python). It stops after --count datagrams,
    --seconds, Ctrl-C, SIGTERM or SIGHUP (a dropped ssh session), always
    with a complete file; the first line on stderr is the address bound,
    the last what was received, written and dropped (by the kernel, before
    it was read: on Linux).

    \b
    Exit status: 0 recorded; 2 usage error, an address that cannot be
    bound, a file that cannot be written, a schema that does not load, or
    no mcap package (pip install 'erc-codec[mcap]').
    """
    import asyncio

    host, port = parse_address(address, default_host="127.0.0.1")
    codec = load(tree, root)
    _, local = resolve(host, port)
    if output.exists():
        raise Fatal(f"{output} exists: remove it or choose another name")
    writer = WriterProcess(codec)
    try:
        session = _Recording(codec, writer, output, count)
        asyncio.run(session.run(local, seconds))
    finally:
        writer.shutdown()
    click.echo(f"recorded: {json.dumps(session.summary)}", err=True)


class _Recording:
    """One ``record``: an endpoint whose dispatcher hands every payload and every drop, with its
    arrival time and sender, to the writer process."""

    def __init__(
        self, codec: Codec, writer: WriterProcess, output: Path, count: int | None
    ) -> None:
        self._writer = writer
        self.dispatcher = Dispatcher(codec, on_drop=self._dropped)
        for kind in codec.kinds().values():
            self.dispatcher.register(kind, self._writer_of(kind))
        self._output = output
        self._count = count
        self.received = 0
        self.summary: dict[str, Any] = {}
        self._now = 0  # arrival time (ns) and sender of the datagram being dispatched
        self._source = ""
        self._senders: dict[Any, str] = {}
        self._failure: Exception | None = None
        self._stop: Callable[[], None] = lambda: None

    async def run(self, local: tuple[Any, ...], seconds: float | None) -> None:
        import asyncio

        loop = asyncio.get_running_loop()
        finished = loop.create_future()
        endpoint: UdpEndpoint | None = None
        kernel: list[int | None] = []  # read once, just before the socket closes

        def stop() -> None:
            if endpoint is not None and not kernel:
                kernel.append(kernel_drops(endpoint.address))
                endpoint.close()  # a datagram being dispatched still is; none after it is read
            if not finished.done():
                finished.set_result(None)

        self._stop = stop

        def heard(data: bytes, sender: Any) -> None:
            self.received += 1
            self._now = time.time_ns()
            source = self._senders.get(sender)
            if source is None:
                if len(self._senders) > 4096:  # a flood of senders: forget the old ones
                    self._senders.clear()
                source = self._senders[sender] = shown(sender)
            self._source = source
            if self._count is not None and self.received >= self._count:
                stop()

        try:
            endpoint = await open_udp(self.dispatcher, local[0], local[1], on_datagram=heard)
        except OSError as error:
            self._writer.abort()
            raise Fatal(f"cannot listen on {shown(local)}: {error}") from None
        bound = endpoint.address
        try:
            self._writer.open(self._output, f"udp {shown(bound)}")
        except Fatal:
            endpoint.close()
            raise
        click.echo(f"recording on {shown(bound)} to {self._output}", err=True)
        # SIGHUP: an ssh session drops, which would kill the recorder before its file is done.
        signals = [getattr(signal, name) for name in _STOPS if hasattr(signal, name)]
        for signum in signals:
            with contextlib.suppress(NotImplementedError, RuntimeError):  # not on this platform
                loop.add_signal_handler(signum, stop)
        flushing = loop.create_task(self._flush_every(0.05))
        try:
            await asyncio.wait([finished], timeout=seconds)
        finally:
            stop()
            flushing.cancel()
            for signum in signals:
                with contextlib.suppress(NotImplementedError, RuntimeError):
                    loop.remove_signal_handler(signum)
        self._finish(kernel[0])

    async def _flush_every(self, interval: float) -> None:
        """Hand the batch over while traffic is slow too, so the file keeps up with it."""
        import asyncio

        while True:
            await asyncio.sleep(interval)
            self._guarded(self._writer.flush)

    def _finish(self, kernel: int | None) -> None:
        extra = {"received": str(self.received)}
        if kernel is not None:
            extra["dropped_by_kernel"] = str(kernel)
        stats = self.dispatcher.stats()  # the writer sees payloads only
        unkept, unlisted = stats.unkept, stats.unkept_unlisted
        extra.update(unkept_summary(unkept, unlisted))
        if self._failure is not None:
            raise self._failure
        written, size = self._writer.close(extra)
        self.summary = {
            "received": self.received,
            "messages": written.messages,
            "drops": written.drops,
            "dropped_by_kernel": kernel,
            "file": str(self._output),
            "bytes": size,
        }
        if unkept:  # fields beside the payloads, unknown to the schema, which no channel holds
            self.summary["unkept"] = {str(number): n for number, n in sorted(unkept.items())}
        if unlisted:  # fields of the numbers past those listed
            self.summary["unkept_unlisted"] = unlisted

    def _guarded(self, step: Callable[[], None]) -> None:
        """Run a hand-over; a writer that failed stops the recording with its error."""
        try:
            step()
        except Fatal as failure:
            self._failure = self._failure or failure
            self._stop()

    def _writer_of(self, kind: str) -> Callable[[Message], None]:
        writer = self._writer

        def write(message: Message) -> None:
            writer.message(kind, message.SerializeToString(), self._now, self._source)

        return write

    def _dropped(self, drop: Drop) -> None:
        if drop.reason == "handler_error":  # the writer failed: stop there
            self._failure = self._failure or cast(Exception, drop.error)
            self._stop()
            return
        error = str(drop.error) if drop.error is not None else ""
        self._guarded(
            lambda: self._writer.drop(drop.data, self._now, drop.reason, error, self._source)
        )


def kernel_drops(address: tuple[Any, ...]) -> int | None:
    """Datagrams the kernel dropped on the UDP socket bound to ``address`` (its receive buffer
    was full), from Linux's /proc/net/udp; ``None`` where that cannot be read or is ambiguous."""
    host, port = address[0], address[1]
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    packed = socket.inet_pton(family, host)
    # /proc/net/udp{,6} spells an address as 32-bit words in the host's byte order, in hex.
    words = struct.unpack(f"={len(packed) // 4}I", packed)
    local = "".join(f"{word:08X}" for word in words) + f":{port:04X}"
    try:
        lines = Path("/proc/net/udp6" if family == socket.AF_INET6 else "/proc/net/udp")
        rows = [line.split() for line in lines.read_text().splitlines()[1:]]
    except OSError:
        return None
    found = [int(row[-1]) for row in rows if len(row) >= 13 and row[1] == local]
    return found[0] if len(found) == 1 else None


# -- replay --------------------------------------------------------------------------------------


class _Entry(NamedTuple):
    """One recorded datagram: when, what (a payload of ``kind``, or the bytes of a drop)."""

    time: int | None  # nanoseconds since the epoch; None where the source has no time
    kind: str | None  # the envelope member; None for a datagram that did not decode
    message: Message | None  # the payload (kind given)
    data: bytes | None  # a drop's bytes as received (None where the source did not keep them)
    # a capture's datagram as decoded: re-encoded whole, with what its envelope carried beside
    # the payload (metadata, fields the schema does not know); None where only payloads are kept
    decoded: Decoded | None = None
    unsent: bool = False  # a JSON line listing unknown fields, which it cannot hold
    beside: Message | None = None  # a JSON line's metadata (timeout ...), as an envelope


@click.command()
@click.argument("source", metavar="FILE", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("target", metavar="HOST:PORT")
@click.option(
    "--speed",
    type=click.FloatRange(min=0, min_open=True),
    default=1.0,
    show_default=True,
    help="Play the recorded timing this many times faster.",
)
@click.option(
    "--as-fast-as-possible", "flat_out", is_flag=True, help="Send back to back, no timing."
)
@MODE
@click.option(
    "--kind",
    "kinds",
    multiple=True,
    metavar="KIND",
    help="Send only this kind (repeatable); the others are counted as skipped.",
)
@click.option(
    "--drops",
    "with_drops",
    is_flag=True,
    help="Also send the datagrams that did not decode, exactly as they were received.",
)
@schema_options
def replay(
    source: Path,
    target: str,
    speed: float,
    flat_out: bool,
    mode: str,
    kinds: tuple[str, ...],
    with_drops: bool,
    tree: str | None,
    root: str | None,
) -> None:
    """Send a recording's datagrams to HOST:PORT with their recorded timing.

    \b
      erc-codec replay run.mcap 127.0.0.1:5000 --speed 2
    FILE is an MCAP file (record's, or decode --pcap --mcap's), a pcap or
    pcapng capture (every UDP datagram in it, needs the pcap extra), or
    decode's JSON lines (with --pcap's "time"; a line without one, like a
    pcapng Simple Packet Block, is sent right after the one before). Each
    payload is re-encoded in --mode (the fleet's strip by default), a
    capture's with all its envelope carried (metadata, fields the schema
    does not know); a datagram that did not decode is sent as received only
    with --drops. An MCAP file is read as erc_codec.capture.read_mcap reads
    it: a channel that is not protobuf, a schema that does not load or a
    message that does not parse with it stops the replay there, with its
    error. The last line on stderr says what was sent (by kind), how late the latest send ran
    ("latest_ms"), and what was skipped: "drops" (without --drops),
    "drops_without_bytes" (JSON lines keep none), "other_kinds" (--kind),
    "unknown_kind" (not in this schema), "not_valid" (a payload or line that
    does not parse) or "not_sendable" (a payload a fixed-size receiver would
    drop); "unknown_fields_unsent" counts the JSON lines sent without the
    unknown fields they list (decode's JSON names them, it holds no bytes).

    \b
    Exit status: 0 sent; 1 the file ends in damage after what was sent, or
    a line or message in it is not valid (or not readable, as above); 2
    usage error, unreadable file,
    a schema that does not load, or a missing extra.
    """
    host, port = parse_address(target)
    codec = load(tree, root)
    known = set(codec.kinds().values())
    unknown = [kind for kind in kinds if kind not in known]
    if unknown:
        raise click.BadParameter(
            f"{unknown[0]!r} is not a kind of {codec.root}", param_hint="--kind"
        )
    family, address = resolve(host, port)
    player = _Player(codec, cast(Mode, mode), set(kinds), with_drops, 0.0 if flat_out else speed)
    entries = _entries(source, codec, player.skip)
    with socket.socket(family, socket.SOCK_DGRAM) as sock:

        def send(data: bytes) -> None:
            try:
                sock.sendto(data, address)
            except OSError as error:  # a send's error, never the file's
                raise Fatal(f"cannot send to {shown(address)}: {error}") from None

        try:
            player.play(entries, send)
        except Fatal:
            click.echo(f"replayed: {json.dumps(player.summary())}", err=True)
            raise
        except OSError as error:  # reading the file
            click.echo(f"replayed: {json.dumps(player.summary())}", err=True)
            raise Fatal(f"cannot read {source}: {error.strerror or error}") from None
        except CodecError as error:
            click.echo(f"replayed: {json.dumps(player.summary())}", err=True)
            raise click.ClickException(one_line(str(error))) from None
    click.echo(f"replayed: {json.dumps(player.summary())}", err=True)
    sys.exit(1 if player.skipped.get("not_valid") else 0)


class _Player:
    """Sends entries at their recorded times, scaled by ``speed`` (0: no waiting), counting."""

    def __init__(
        self, codec: Codec, mode: Mode, kinds: set[str], with_drops: bool, speed: float
    ) -> None:
        self._codec = codec
        self._envelope = codec.message_class(codec.root)
        self._mode = mode
        self._kinds = kinds
        self._with_drops = with_drops
        self._speed = speed
        self.sent: dict[str, int] = {}
        self.skipped: dict[str, int] = {}
        self.unsent = 0  # datagrams sent without the unknown fields their source listed
        self.bytes = 0
        self.late = 0.0  # the latest a send ran behind its time, in seconds
        self.first: int | None = None
        self.last: int | None = None
        self.elapsed = 0.0

    def skip(self, why: str) -> None:
        self.skipped[why] = self.skipped.get(why, 0) + 1

    def play(self, entries: Iterator[_Entry], send: Callable[[bytes], object]) -> None:
        """Send every entry; the clock starts at the first one with a time."""
        start = began = time.monotonic()
        try:
            for entry in entries:
                data = self._datagram(entry)
                if data is None:
                    continue
                if entry.time is not None:
                    if self.first is None:
                        self.first, start = entry.time, time.monotonic()
                    self.last = entry.time
                    if self._speed:
                        due = start + (entry.time - self.first) / 1e9 / self._speed
                        ahead = due - time.monotonic()
                        if ahead > 0:
                            time.sleep(ahead)
                        self.late = max(self.late, time.monotonic() - due)
                send(data)
                self.bytes += len(data)
        finally:
            self.elapsed = time.monotonic() - began

    def _datagram(self, entry: _Entry) -> bytes | None:
        """The bytes to send for an entry, or None (counted under why)."""
        if entry.kind is None:
            if not self._with_drops:
                self.skip("drops")
                return None
            if entry.data is None:  # an empty datagram was received too: it is sent
                self.skip("drops_without_bytes")
                return None
            self.sent["drops"] = self.sent.get("drops", 0) + 1
            return entry.data
        if self._kinds and entry.kind not in self._kinds:
            self.skip("other_kinds")
            return None
        try:
            if entry.decoded is not None:
                data = self._codec.reencode(entry.decoded, self._mode)
            else:
                envelope = self._envelope()
                assert entry.message is not None
                if entry.beside is not None:
                    envelope.MergeFrom(entry.beside)
                getattr(envelope, entry.kind).CopyFrom(entry.message)
                data = self._codec.encode(envelope, self._mode)
        except EncodeError:
            self.skip("not_sendable")
            return None
        self.sent[entry.kind] = self.sent.get(entry.kind, 0) + 1
        self.unsent += entry.unsent
        return data

    def summary(self) -> dict[str, Any]:
        span = (self.last - self.first) / 1e9 if self.first is not None and self.last else 0.0
        return {
            "sent": sum(self.sent.values()),
            "by_kind": dict(sorted(self.sent.items())),
            "bytes": self.bytes,
            "skipped": dict(sorted(self.skipped.items())),
            **({"unknown_fields_unsent": self.unsent} if self.unsent else {}),
            "seconds": round(self.elapsed, 3),
            "recorded_seconds": round(span, 3),
            "latest_ms": round(self.late * 1e3, 3),
        }


def _entries(path: Path, codec: Codec, skip: Callable[[str], None]) -> Iterator[_Entry]:
    """The entries of a recording, whatever its format (told by its first bytes)."""
    try:
        with path.open("rb") as file:
            head = file.read(8)
    except OSError as error:
        raise Fatal(f"cannot read {path}: {error.strerror or error}") from None
    if head.startswith(_MCAP_MAGIC):
        try:
            return _from_mcap(path, codec, skip, recorded_payloads(path))
        except ImportError as error:
            raise Fatal(str(error)) from None
    if head[:4] in _CAPTURE_MAGICS:
        return _from_capture(Capture(path), codec)
    return _from_json_lines(path, codec, skip)


def _from_mcap(
    path: Path,
    codec: Codec,
    skip: Callable[[str], None],
    payloads: Iterator[tuple[int, str | None, bytes]],
) -> Iterator[_Entry]:
    classes = {kind: codec.payload_class(kind) for kind in codec.kinds().values()}
    for log_time, kind, data in payloads:
        if kind is None:
            yield _Entry(log_time, None, None, data)
            continue
        payload = classes.get(kind)
        if payload is None:
            skip("unknown_kind")
            continue
        try:
            yield _Entry(log_time, kind, payload.FromString(data), b"")
        except ProtobufDecodeError:
            skip("not_valid")


def _from_capture(capture: Capture, codec: Codec) -> Iterator[_Entry]:
    """A capture's datagrams; one without a time (a pcapng Simple Packet Block's) is sent right
    after the one before."""
    with capture:
        decode = codec.decode
        for datagram in capture.datagrams():
            at = None if datagram.time is None else nanoseconds(datagram.time)
            try:
                decoded = decode(datagram.data)
            except CodecError:
                yield _Entry(at, None, None, datagram.data)
                continue
            yield _Entry(at, decoded.kind, decoded.message, b"", decoded)
        if capture.damage:
            raise CodecError(capture.damage)


def _from_json_lines(path: Path, codec: Codec, skip: Callable[[str], None]) -> Iterator[_Entry]:
    """decode's output: ``{"kind": ..., "message": {...}}`` lines (with ``time`` from --pcap),
    ``{"error": ...}`` lines (drops, whose bytes decode does not print)."""
    kinds = set(codec.kinds().values())
    with path.open(encoding="utf-8", errors="replace") as lines:
        for number, line in enumerate(lines, start=1):
            if not line.strip():
                continue
            try:
                record = json.loads(line)
            except ValueError:
                raise CodecError(
                    f"{path}:{number}: not a JSON line (replay reads MCAP, pcap, pcapng or "
                    "decode's JSON lines)"
                ) from None
            when = record.get("time") if isinstance(record, dict) else None
            at = (
                nanoseconds(when) if isinstance(when, int | float) and math.isfinite(when) else None
            )
            kind = record.get("kind") if isinstance(record, dict) else None
            if kind is None and isinstance(record, dict) and "error" in record:
                yield _Entry(at, None, None, None)
                continue
            if not isinstance(kind, str) or kind not in kinds:
                skip("not_valid")
                continue
            if not isinstance(record.get("message"), dict):
                skip("not_valid")
                continue
            message = codec.payload_class(kind)()
            try:
                json_format.ParseDict(record["message"], message)
            except json_format.ParseError:
                skip("not_valid")
                continue
            beside = None
            metadata = record.get("metadata")
            if metadata is not None:
                beside = codec.message_class(codec.root)()
                try:
                    if not isinstance(metadata, dict):
                        raise json_format.ParseError("metadata is not an object")
                    json_format.ParseDict(metadata, beside)
                except json_format.ParseError:
                    skip("not_valid")
                    continue
            unsent = bool(record.get("unknown_fields"))
            yield _Entry(at, kind, message, b"", unsent=unsent, beside=beside)
