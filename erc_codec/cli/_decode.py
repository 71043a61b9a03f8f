"""``erc-codec decode``: datagrams (hex, standard input, a serial stream, a capture) to JSON."""

import sys
from collections.abc import Iterable
from pathlib import Path

import click

from .._codec import Codec
from .._errors import DecodeError
from .._framing import Deframer
from ._input import hex_lines, read_stdin
from ._pcap import Capture
from ._record import capture_to_mcap
from ._shared import Fatal, emit, load, one_line, plural, schema_options, to_dict, unhex

__all__ = ["decode"]


class _Decoder:
    """Decodes datagrams and prints one JSON line for each, counting the failures."""

    def __init__(self, codec: Codec) -> None:
        self._decode = codec.decode
        self.datagrams = 0
        self.failed = 0
        self.bad_lines = 0

    def datagram(self, data: bytes, where: dict[str, object] | None = None) -> None:
        self.datagrams += 1
        try:
            kind, message = self._decode(data)
        except DecodeError as error:
            self.failed += 1
            emit(
                {
                    **(where or {}),
                    "error": one_line(str(error)),
                    "reason": error.reason,
                    "length": len(data),
                }
            )
            return
        emit({**(where or {}), "kind": kind, "length": len(data), "message": to_dict(message)})

    def each(self, datagrams: Iterable[bytes]) -> None:
        """Decode every datagram in turn."""
        for data in datagrams:
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


def _deframe(decoder: _Decoder, chunks: Iterable[bytes], deframer: Deframer) -> str:
    """Decode the payload of every frame in a serial byte stream; the summary line."""
    for chunk in chunks:
        for payload in deframer.feed(chunk):
            decoder.datagram(payload)
    stats = deframer.stats()  # before flush: what the stream itself threw away
    parts = [plural(stats.frames, "frame"), f"{decoder.failed} undecodable"]
    discarded = stats.discarded_bytes
    if discarded:
        reasons = ", ".join(f"{reason} {count}" for reason, count in sorted(discarded.items()))
        parts.append(f"{plural(sum(discarded.values()), 'byte')} discarded ({reasons})")
    if unfinished := len(deframer.flush()):
        parts.append(f"{plural(unfinished, 'byte')} left in an unfinished frame")
    if decoder.bad_lines:
        parts.append(f"{plural(decoder.bad_lines, 'line')} not hex")
    return ", ".join(parts)


@click.command()
@click.argument("data", nargs=-1, metavar="[HEX... | -]")
@click.option(
    "--pcap",
    "capture",
    type=click.Path(path_type=Path),
    metavar="FILE",
    help="Decode every UDP payload of a pcap or pcapng capture (needs the pcap extra: dpkt).",
)
@click.option(
    "--mcap",
    type=click.Path(dir_okay=False, path_type=Path),
    metavar="OUT.mcap",
    help="With --pcap: write the datagrams to an MCAP file (a channel per kind, drops too) "
    "instead of JSON lines (needs the mcap extra).",
)
@click.option(
    "--framed",
    is_flag=True,
    help="The input is a serial byte stream of Proton frames: decode each frame's payload.",
)
@schema_options
def decode(
    data: tuple[str, ...],
    capture: Path | None,
    mcap: Path | None,
    framed: bool,
    tree: Path | None,
    root: str,
) -> None:
    """Decode datagrams to JSON: one object per datagram, one per line, on stdout.

    \b
    Input, one of:
      HEX...      one datagram in hex; spaces and colons may separate the
                  digits: 0a:05:0d... or '0a 05 0d ...' (quoted or not)
      - or none   standard input: hex text, one datagram per non-empty line
                  (text whose first non-empty line is hex), else raw bytes:
                  one datagram
      --pcap FILE every UDP payload (IPv4, IPv6) in a pcap or pcapng capture
                  of Ethernet, Linux cooked, raw IP or loopback packets
    With --framed, HEX or standard input is a serial stream of Proton frames.

    \b
    Output, one line per datagram:
      {"kind": "gps_info", "length": 24, "message": {...}}
      {"error": "...", "reason": "unknown_member", "length": 3}
    An undecodable datagram is an "error" object on stdout (reason: empty,
    too_long, no_payload, unknown_member or corrupt; not_hex, with "line",
    for a line of standard input that is not hex), so the stream stays one
    JSON object a line, and decoding goes on with the next datagram. With
    --pcap every object starts with "time", "src" and "dst" (address:port);
    --pcap and --framed end with a summary line on stderr (packets skipped
    and why, bytes discarded between frames).

    The message shows every field, defaults included: on the wire a zero is
    indistinguishable from a field the sender never set, and when debugging
    "speed": 0.0 says more than a missing "speed". Enums show their names (an
    undeclared value its number); 64-bit integers are strings and bytes are
    base64, as in protobuf's JSON mapping.

    \b
    Exit status: 0 every datagram decoded (bytes discarded between frames
    show in the summary only); 1 at least one did not, or a line was not hex;
    2 usage error, unreadable or damaged capture (after decoding what comes
    before the damage), schema that does not load, or --pcap without dpkt.
    """
    if capture is not None and (data or framed):
        raise click.UsageError("--pcap reads the capture only: give no HEX, '-' or --framed")
    if mcap is not None and capture is None:
        raise click.UsageError("--mcap writes a capture's datagrams: give --pcap CAPTURE")
    if "-" in data and len(data) > 1:
        raise click.UsageError("'-' (standard input) cannot be combined with HEX")
    given = None
    if data and data != ("-",):
        try:
            given = unhex(" ".join(data))
        except ValueError as error:
            raise click.BadParameter(str(error), param_hint="HEX") from None
    summary: str | None = None
    if capture is not None:
        decoder, summary = _capture(capture, mcap, load(tree, root))
    else:
        codec = load(tree, root)
        decoder = _Decoder(codec)
        if given is not None:
            hex_text, chunks = False, iter([given])
        else:
            hex_text, chunks = read_stdin()
        if hex_text:
            chunks = hex_lines(chunks, decoder.not_hex)
        if framed:
            summary = _deframe(decoder, chunks, Deframer.for_codec(codec))
        elif hex_text:
            decoder.each(chunks)
        else:  # one datagram: HEX (even an empty one), or raw standard input unless empty
            whole = b"".join(chunks)
            decoder.each([whole] if whole or given is not None else [])
    if summary is not None:
        click.echo(summary, err=True)
    sys.exit(1 if decoder.failed or decoder.bad_lines else 0)


def _capture(path: Path, mcap: Path | None, codec: Codec) -> tuple[_Decoder, str]:
    """Decode a capture to JSON lines, or with ``mcap`` write it to that MCAP file."""
    with Capture(path) as packets:
        decoder = _Decoder(codec)
        if mcap is not None:
            decoder.failed, summary = capture_to_mcap(packets, codec, mcap)
        else:
            summary = _from_capture(decoder, packets)
    return decoder, summary


def _from_capture(decoder: _Decoder, capture: Capture) -> str:
    """Decode every UDP payload of a capture; the summary line.

    A capture damaged after its header (cut off while it was written) is decoded up to the
    damage, then the summary and the damage are reported and the command exits 2.
    """
    for datagram in capture.datagrams():
        where = {"time": datagram.time, "src": datagram.source, "dst": datagram.destination}
        decoder.datagram(datagram.data, where)
    skipped = capture.skipped
    reasons = ", ".join(f"{count} {why}" for why, count in sorted(skipped.items()))
    summary = (
        f"{plural(decoder.datagrams, 'datagram')}, {decoder.failed} undecodable, "
        f"{plural(sum(skipped.values()), 'packet')} skipped" + (f" ({reasons})" if reasons else "")
    )
    if capture.damage:
        click.echo(summary, err=True)
        raise Fatal(one_line(capture.damage))
    return summary
