"""What both decode commands (``erc-codec decode``, ``erc-codec proton decode``) do with their
input: the datagrams of HEX arguments, of standard input (hex lines, or raw bytes with --raw),
of a serial stream of Proton frames (--framed) or of a capture (--pcap), each handed to a
``Printer``; then the summary on stderr and the exit status.

Guarantees: nothing is decoded that was not given (empty input and whitespace are no datagram);
every line of standard input that is not hex is an error object naming its line; every frame a
serial stream rejected, and every packet of a capture skipped, is counted in the summary, by
reason; the exit status is 0 only if everything given decoded.
"""

import sys
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any, TypeVar

import click

from ..runtime import Deframer
from ._input import LINE_LIMIT, hex_lines, read_stdin
from ._pcap import Capture
from ._shared import Fatal, emit, one_line, plural, unhex

__all__ = ["Printer", "check_usage", "decode_input", "input_options"]

_Command = TypeVar("_Command", bound=Callable[..., Any])


class Printer:
    """Decodes datagrams and prints one JSON line for each, counting what failed. A command
    defines ``datagram`` (a datagram, with where it was captured) and may define ``payload`` (a
    serial frame's payload: a datagram unless told otherwise)."""

    def __init__(self) -> None:
        self.datagrams = 0  # handed to ``datagram`` or ``payload``
        self.failed = 0  # of those, did not decode
        self.bad_lines = 0  # lines of standard input that are not hex
        self.long_lines = 0  # lines of standard input longer than LINE_LIMIT
        self.other_kinds = 0  # of those, decoded but of a kind not asked for (--kind)

    def datagram(self, data: bytes, where: dict[str, object] | None = None) -> None:
        raise NotImplementedError

    def payload(self, data: bytes) -> None:
        self.datagram(data)

    def not_hex(self, line: int, problem: str) -> None:
        """A line of hex text that spells no bytes: one error object, and on to the next."""
        self.bad_lines += 1
        emit(
            {
                "error": f"line {line} is not hex: {problem}",
                "reason": "not_hex",
                "length": None,
                "line": line,
            }
        )

    def too_long(self, line: int) -> None:
        """A line longer than any datagram's hex: one error object, and on to the next."""
        self.long_lines += 1
        emit(
            {
                "error": f"line {line} is longer than {LINE_LIMIT} characters: no datagram's "
                "hex is (a datagram is at most 65535 bytes)",
                "reason": "line_too_long",
                "length": None,
                "line": line,
            }
        )


def input_options(command: _Command) -> _Command:
    """--pcap, --port, --framed and --raw: how a decode command reads its datagrams."""
    for option in reversed(
        [
            click.option(
                "--pcap",
                "capture",
                type=click.Path(path_type=Path),
                metavar="FILE",
                help="Decode every UDP payload of a pcap or pcapng capture (needs the pcap "
                "extra: dpkt).",
            ),
            click.option(
                "--port",
                "ports",
                type=click.IntRange(0, 65535),
                multiple=True,
                metavar="PORT",
                help="With --pcap: only datagrams from or to this port (repeatable).",
            ),
            click.option(
                "--framed",
                is_flag=True,
                help="The input is a serial byte stream of Proton frames: decode each frame's "
                "payload.",
            ),
            click.option(
                "--raw",
                is_flag=True,
                help="Standard input is raw bytes (one datagram, or with --framed a byte "
                "stream), not hex lines.",
            ),
        ]
    ):
        command = option(command)
    return command


def decode_input(
    printer: Printer,
    data: tuple[str, ...],
    raw: bool,
    framed: bool,
    capture: Path | None,
    ports: tuple[int, ...],
    deframer: Callable[[], Deframer],
) -> None:
    """Decode what the command was given (HEX, standard input, --framed, --pcap), print the
    summary and exit: 0 all decoded, 1 anything did not (or nothing was given)."""
    check_usage(data, raw, framed, capture, ports)
    if capture is not None:
        with Capture(capture, frozenset(ports)) as packets:
            summary = _from_capture(printer, packets)
    else:
        chunks = _given(data, raw, printer)
        summary = _deframe(printer, chunks, deframer()) if framed else _each(printer, chunks, raw)
    if summary:
        click.echo(summary, err=True)
    nothing = not printer.datagrams and capture is None
    sys.exit(1 if printer.failed or printer.bad_lines or printer.long_lines or nothing else 0)


def check_usage(
    data: tuple[str, ...], raw: bool, framed: bool, capture: Path | None, ports: tuple[int, ...]
) -> None:
    """The usage errors of a decode command's input options (exit 2)."""
    if capture is not None and (data or framed or raw):
        raise click.UsageError("--pcap reads the capture only: give no HEX, '-', --raw or --framed")
    if ports and capture is None:
        raise click.UsageError("--port filters the packets of a capture: give --pcap FILE")
    if "-" in data and len(data) > 1:
        raise click.UsageError("'-' (standard input) cannot be combined with HEX")
    if raw and data and data != ("-",):
        raise click.UsageError("--raw is for standard input: HEX is hex")


def _each(printer: Printer, chunks: Iterator[bytes], raw: bool) -> str:
    """Decode each datagram (hex lines), or all of standard input as one (``raw``); the summary
    line, if there is one to say."""
    if raw:
        whole = b"".join(chunks)
        if whole:
            printer.datagram(whole)
    else:
        for datagram in chunks:
            printer.datagram(datagram)
    parts = _not_shown(printer)
    if printer.bad_lines:
        parts.append(
            f"{plural(printer.bad_lines, 'line')} not hex (raw bytes on standard input need --raw)"
        )
    parts += _too_long(printer)
    if not printer.datagrams and not parts:
        return "standard input holds no datagram: it is empty or only whitespace"
    return ", ".join(parts)


def _not_shown(printer: Printer) -> list[str]:
    """The summary's part for the datagrams --kind left out, if any were."""
    if not printer.other_kinds:
        return []
    return [f"{plural(printer.other_kinds, 'datagram')} of other kinds not shown"]


def _too_long(printer: Printer) -> list[str]:
    """The summary's part for the lines of standard input too long to read, if any were."""
    if not printer.long_lines:
        return []
    return [f"{plural(printer.long_lines, 'line')} longer than {LINE_LIMIT} characters skipped"]


def _given(data: tuple[str, ...], raw: bool, printer: Printer) -> Iterator[bytes]:
    """The datagrams (or, with --raw or --framed, the chunks) of HEX or standard input."""
    if data and data != ("-",):
        try:
            given = unhex(" ".join(data))
        except ValueError as error:
            raise click.BadParameter(str(error), param_hint="HEX") from None
        if not given:
            raise click.BadParameter("it spells no bytes: give a datagram in hex", param_hint="HEX")
        return iter([given])
    chunks = read_stdin()
    return chunks if raw else hex_lines(chunks, printer.not_hex, printer.too_long)


def _deframe(printer: Printer, chunks: Iterable[bytes], deframer: Deframer) -> str:
    """Decode the payload of every frame in a serial byte stream; the summary line."""
    for chunk in chunks:
        for payload in deframer.feed(chunk):
            printer.payload(payload)
    stats = deframer.stats()  # before flush: what the stream itself threw away
    parts = [plural(stats.frames, "frame"), f"{printer.failed} undecodable", *_not_shown(printer)]
    if stats.rejected:
        reasons = ", ".join(f"{reason} {count}" for reason, count in sorted(stats.rejected.items()))
        parts.append(f"{plural(sum(stats.rejected.values()), 'frame')} rejected ({reasons})")
    discarded = stats.discarded_bytes
    if discarded:
        reasons = ", ".join(f"{reason} {count}" for reason, count in sorted(discarded.items()))
        parts.append(f"{plural(sum(discarded.values()), 'byte')} discarded ({reasons})")
    if unfinished := len(deframer.flush()):
        parts.append(f"{plural(unfinished, 'byte')} left in an unfinished frame")
    if printer.bad_lines:
        parts.append(f"{plural(printer.bad_lines, 'line')} not hex")
    return ", ".join([*parts, *_too_long(printer)])


def _from_capture(printer: Printer, capture: Capture) -> str:
    """Decode every UDP payload of a capture; the summary line.

    A capture damaged after its header (cut off while it was written) is decoded up to the
    damage, then the summary and the damage are reported and the command exits 2.
    """
    for datagram in capture.datagrams():
        where: dict[str, object] = {
            "time": datagram.time,  # null: a pcapng Simple Packet Block carries no time
            "src": datagram.source,
            "dst": datagram.destination,
        }
        printer.datagram(datagram.data, where)
    skipped = capture.skipped
    reasons = ", ".join(f"{count} {why}" for why, count in sorted(skipped.items()))
    parts = [plural(printer.datagrams, "datagram"), f"{printer.failed} undecodable"]
    parts += _not_shown(printer)
    parts.append(
        f"{plural(sum(skipped.values()), 'packet')} skipped" + (f" ({reasons})" if reasons else "")
    )
    summary = ", ".join(parts)
    if capture.damage:
        click.echo(summary, err=True)
        raise Fatal(one_line(capture.damage))
    return summary
