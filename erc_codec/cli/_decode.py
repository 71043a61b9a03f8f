"""``erc-codec decode``: datagrams (hex, standard input, a serial stream, a capture) to JSON."""

import sys
from pathlib import Path

import click

from erc_schema import DecodeError

from ..codec import Codec
from ..runtime import Deframer
from ._pcap import Capture
from ._reading import Printer, check_usage, decode_input, input_options
from ._record import capture_to_mcap
from ._shared import Fatal, emit, load, one_line, schema_options

__all__ = ["decode"]


class _Decoder(Printer):
    """Decodes datagrams and prints one JSON line for each (of the kinds asked for)."""

    def __init__(self, codec: Codec, kinds: frozenset[str], strict: bool) -> None:
        super().__init__()
        self._decode = codec.decode
        self._strict = strict
        self._kinds = kinds

    def datagram(self, data: bytes, where: dict[str, object] | None = None) -> None:
        self.datagrams += 1
        try:
            decoded = self._decode(data, self._strict)
            if self._kinds and decoded.kind not in self._kinds:
                self.other_kinds += 1
                return
            record = decoded.to_dict()  # kind, message and any unknown fields, or "not_json"
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
        emit({**(where or {}), "kind": record.pop("kind"), "length": len(data), **record})


@click.command()
@click.argument("data", nargs=-1, metavar="[HEX... | -]")
@input_options
@click.option(
    "--kind",
    "kinds",
    multiple=True,
    metavar="KIND",
    help="Print only datagrams of this kind (repeatable); errors are printed all the same.",
)
@click.option(
    "--mcap",
    type=click.Path(dir_okay=False, path_type=Path),
    metavar="OUT.mcap",
    help="With --pcap: write the datagrams to an MCAP file (a channel per kind, drops too) "
    "instead of JSON lines (needs the mcap extra).",
)
@click.option(
    "--strict",
    is_flag=True,
    help="A datagram with fields the schema does not know is an error (reason unknown_fields).",
)
@schema_options
def decode(
    data: tuple[str, ...],
    capture: Path | None,
    ports: tuple[int, ...],
    framed: bool,
    raw: bool,
    kinds: tuple[str, ...],
    mcap: Path | None,
    strict: bool,
    tree: str | None,
    root: str | None,
) -> None:
    """Decode datagrams to JSON: one object per datagram, one per line, on stdout.

    \b
    Input, one of:
      HEX...      one datagram in hex; spaces and colons may separate the
                  digits: 0a:05:0d... or '0a 05 0d ...' (quoted or not)
      - or none   standard input: hex text, one datagram per non-empty line
                  (blank lines and whitespace are no datagram); with --raw,
                  raw bytes: one datagram
      --pcap FILE every UDP payload (IPv4, IPv6) in a pcap or pcapng capture
                  of Ethernet, Linux cooked, raw IP or loopback packets; with
                  --port (repeatable) only those from or to these ports
    With --framed, HEX or standard input (hex lines, or --raw bytes) is a
    serial stream of Proton frames. --kind (repeatable) prints only the
    datagrams of these kinds (the others are counted in the summary line on
    stderr, not shown).

    \b
    Output, one line per datagram (Decoded.to_dict() with its length):
      {"kind": "gps_info", "length": 24, "message": {...}}
      {"kind": "gps_info", "length": 4, "message": {...},
       "unknown_fields": [{"path": "", "number": 13, "wire_type": 0}]}
      {"error": "...", "reason": "unknown_member", "length": 3}
    "metadata" holds the envelope's fields beside the payload that the
    datagram carried ({"timeout": 300}); encode - and send take them back.
    "unknown_fields" lists the fields the schema does not know (a number it
    lacks, or a wire type its field does not have: another schema sent it);
    with --strict such a datagram is an error (reason unknown_fields).
    An undecodable datagram is an "error" object on stdout (reason: empty,
    too_long, no_payload, unknown_member, truncated, corrupt or
    unknown_fields; not_hex, with "line", for a line of standard input that
    is not hex; line_too_long, with "line", for one longer than 262144
    characters, dropped unread), so the stream stays one JSON object a line,
    and decoding goes on with the next datagram. With
    --pcap every object starts with "time" (null for a pcapng Simple Packet
    Block, which has none), "src" and "dst" (address:port);
    --pcap and --framed end with a summary line on stderr (packets skipped
    and why; frames rejected and why, bytes discarded between frames), and
    standard input with lines that are not hex with their count; any input
    does when --kind left datagrams out (their count).

    The message shows every field, defaults included: on the wire a zero is
    indistinguishable from a field the sender never set, and when debugging
    "speed": 0.0 says more than a missing "speed". Enums show their names (an
    undeclared value its number); 64-bit integers are strings and bytes are
    base64, as in protobuf's JSON mapping.

    \b
    Exit status: 0 every datagram decoded (frames rejected or bytes discarded
    between frames show in the summary only, if a frame decoded); 1 at least
    one did not, a line was not hex or too long, there was nothing to decode
    (empty input, no frame), or with --mcap a datagram's time is outside what
    MCAP holds (1970 to 2554: skipped, counted; a Simple Packet Block's
    datagram takes the time of the one before); 2 usage error (HEX that
    spells no bytes or odd digits, unknown --kind), unreadable or damaged
    capture (after decoding what comes before the damage), schema that does
    not load, or --pcap without dpkt.
    Every error is one line.
    """
    codec = load(tree, root)
    unknown = sorted(set(kinds) - set(codec.kinds().values()))
    if unknown:
        known = ", ".join(codec.kinds().values())
        raise Fatal(f"unknown kind {unknown[0]!r}: {codec.root} has {known}")
    if mcap is not None:
        if capture is None:
            raise click.UsageError("--mcap writes a capture's datagrams: give --pcap CAPTURE")
        check_usage(data, raw, framed, capture, ports)
        with Capture(capture, frozenset(ports)) as packets:
            failed, summary = capture_to_mcap(packets, codec, mcap)
        click.echo(summary, err=True)
        sys.exit(1 if failed else 0)
    decoder = _Decoder(codec, frozenset(kinds), strict)
    decode_input(decoder, data, raw, framed, capture, ports, lambda: Deframer.for_codec(codec))
