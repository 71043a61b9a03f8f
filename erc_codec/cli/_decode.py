"""The ``erc-codec`` command line: a thin shell over the codec."""

import importlib
import io
import ipaddress
import itertools
import json
import os
import re
import sys
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from types import ModuleType
from typing import Any, BinaryIO, TypeVar, cast

import click
from google.protobuf import json_format
from google.protobuf.descriptor import Descriptor
from google.protobuf.message import Message

from ._click import OneLineGroup
from ._codec import Codec, default_tree
from ._envelope import Mode
from ._errors import CodecError, DecodeError, EncodeError
from ._framing import Deframer, frame
from ._schema import descriptor_of, message_of

__all__ = ["main"]

_DIRECTION = re.compile(r"direction:\s*(.+)", re.IGNORECASE)
_Command = TypeVar("_Command", bound=Callable[..., Any])


@click.group(cls=OneLineGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="erc-codec")
def main() -> None:
    """Encode, decode and size the ERC rover's PBEnvelope datagrams."""


def _schema_options(command: _Command) -> _Command:
    """``--proto TREE`` and ``--root NAME``: the schema revision a command works with."""
    command = click.option(
        "--root",
        metavar="NAME",
        default="PBEnvelope",
        show_default=True,
        help="The envelope message.",
    )(command)
    return click.option(
        "--proto",
        "tree",
        type=click.Path(file_okay=False, path_type=Path),
        metavar="TREE",
        help="Proto tree to load (its import root). Default: the packaged rover schema.",
    )(command)


@main.command()
@_schema_options
@click.option(
    "--format",
    "output",
    type=click.Choice(["text", "json"]),
    default="text",
    show_default=True,
)
def sizes(tree: Path | None, root: str, output: str) -> None:
    """Print every message's nanopb maximum size and the envelope's members."""
    codec = _load(tree, root)
    members = []
    for number, kind in sorted(codec.kinds().items()):
        field = descriptor_of(codec.message_class(root)).fields_by_name[kind]
        payload = message_of(field).full_name
        note = _DIRECTION.search(codec._schema.comments.get(field.full_name, ""))
        members.append(
            {
                "number": number,
                "kind": kind,
                "type": payload,
                "max_size": codec.max_size(payload),
                "direction": note.group(1).strip() if note else None,
            }
        )
    messages = dict(sorted(codec.sizes().items()))
    if output == "json":
        document = {"root": root, "max_size": codec.max_size(root), "members": members}
        click.echo(json.dumps({**document, "messages": messages}, indent=2))
        return
    click.echo(f"{root} members")
    click.echo(f"  {'#':>3}  {'kind':<34}{'payload':<36}{'max':>5}  direction")
    for m in members:
        click.echo(
            f"  {m['number']:>3}  {m['kind']:<34}{m['type']:<36}{m['max_size']:>5}"
            f"  {m['direction'] or '-'}"
        )
    click.echo(f"{root}_size {codec.max_size(root)}")
    click.echo("")
    click.echo("nanopb maximum encoded size of every message")
    for name, size in messages.items():
        click.echo(f"  {name:<44}{'runtime' if size is None else size:>8}")


# -- decode and encode -------------------------------------------------------------------------

_NOT_HEX = re.compile(r"[^0-9a-fA-F \t\n\r\v\f:]")
_SEPARATORS = re.compile(r"[ \t\n\r\v\f:]+")
_HEX_TEXT = b"0123456789abcdefABCDEF \t\n\r\v\f:"  # what a line of hex text holds
_TEXT = bytes(range(0x20, 0x7F)) + b"\t\n\r\v\f"  # printable ASCII and whitespace
_CHUNK = 1 << 16

# Link types (tcpdump.org/linktypes.html) whose packets --pcap reads.
_ETHERNET, _LINUX_SLL, _LINUX_SLL2 = 1, 113, 276
_RAW_IP = {101, 228, 229}  # LINKTYPE_RAW, LINKTYPE_IPV4, LINKTYPE_IPV6
_LOOPBACK = {0, 108}  # LINKTYPE_NULL, LINKTYPE_LOOP: a 4-byte address family, then IP
_IPV6_FRAGMENT = 44


class _Fatal(click.ClickException):
    """The command could not run: one line on stderr, exit status 2."""

    exit_code = 2


def _one_line(text: str) -> str:
    return " ".join(text.split())


def _load(tree: Path | None, root: str) -> Codec:
    try:
        return Codec.from_path(tree or default_tree(), root)
    except CodecError as error:
        raise _Fatal(_one_line(str(error))) from None


def _unhex(text: str) -> bytes:
    """The bytes that hex text spells; spaces, tabs and colons between digits are allowed."""
    bad = _NOT_HEX.search(text)
    if bad:
        raise ValueError(f"{bad.group()!r} at column {bad.start() + 1} is not a hex digit")
    digits = _SEPARATORS.sub("", text)
    if len(digits) % 2:
        raise ValueError(f"odd number of hex digits ({len(digits)})")
    return bytes.fromhex(digits)


def _emit(record: dict[str, object]) -> None:
    click.echo(json.dumps(record))


def _plural(count: int, noun: str) -> str:
    return f"{count} {noun}{'' if count == 1 else 's'}"


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
            _emit(
                {
                    **(where or {}),
                    "error": _one_line(str(error)),
                    "reason": error.reason,
                    "length": len(data),
                }
            )
            return
        _emit({**(where or {}), "kind": kind, "length": len(data), "message": _to_dict(message)})

    def each(self, datagrams: Iterable[bytes]) -> None:
        """Decode every datagram in turn."""
        for data in datagrams:
            self.datagram(data)

    def not_hex(self, line: int, problem: str) -> None:
        """A line of hex text that spells no bytes: one error object, and on to the next."""
        self.bad_lines += 1
        _emit(
            {
                "error": f"line {line} is not hex: {problem}",
                "reason": "not_hex",
                "length": None,
                "line": line,
            }
        )


def _to_dict(message: Message) -> dict[str, Any]:
    document = json_format.MessageToDict(
        message, always_print_fields_with_no_presence=True, preserving_proto_field_name=True
    )
    return _in_field_order(document, descriptor_of(type(message)))


def _in_field_order(document: dict[str, Any], descriptor: Descriptor) -> dict[str, Any]:
    """``document`` with its keys in the order of the .proto, at every level.

    ``MessageToDict`` lists the fields that are set before the defaults it adds, so the same
    message would show its fields in a different order from one datagram to the next.
    """
    ordered: dict[str, Any] = {}
    for field in descriptor.fields:
        if field.name not in document:
            continue
        value = document[field.name]
        payload = field.message_type
        if payload is not None and not payload.GetOptions().map_entry:
            if isinstance(value, dict):
                value = _in_field_order(value, payload)
            elif isinstance(value, list):
                value = [_in_field_order(v, payload) if isinstance(v, dict) else v for v in value]
        ordered[field.name] = value
    return ordered


def _stdin() -> tuple[bool, Iterator[bytes]]:
    """Whether standard input is hex text, and its chunks (whatever has arrived: ``read1``).

    Hex text is text (printable ASCII and whitespace) whose first non-empty line spells at least
    one whole byte in hex digits, spaces and colons, judged on the first chunk: a raw datagram is
    almost never all that (a one-byte stripped datagram such as ``2`` or a newline is raw), and a
    stray line of text later on is one ``not_hex`` error instead of turning the whole input into
    one bogus datagram. Reading chunk by chunk decodes a pipe from a serial port or a
    log that is still being written as it comes.
    """
    if sys.stdin is None:
        raise _Fatal("standard input is closed: give the datagrams as arguments or a file")
    stream = cast(io.BufferedReader, sys.stdin.buffer)
    first = stream.read1(_CHUNK)
    rest = iter(lambda: stream.read1(_CHUNK), b"")
    lines = first.split(b"\n")
    line = next((line for line in lines if line.strip()), b"")
    digits = len(line.translate(None, _HEX_TEXT.removeprefix(b"0123456789abcdefABCDEF")))
    hex_text = (
        not first.translate(None, _TEXT)
        and not line.translate(None, _HEX_TEXT)
        and digits >= 2
        and digits % 2 == 0
    )
    return hex_text, itertools.chain([first], rest)


def _lines(chunks: Iterable[bytes]) -> Iterator[tuple[int, str]]:
    """Number and text (Latin-1, so every byte is one character) of each line of ``chunks``."""
    pending = b""
    number = 0
    for chunk in chunks:
        *lines, pending = (pending + chunk).split(b"\n")
        for line in lines:
            number += 1
            yield number, line.decode("latin-1")
    if pending:
        yield number + 1, pending.decode("latin-1")


def _hex_lines(decoder: _Decoder, chunks: Iterable[bytes]) -> Iterator[bytes]:
    """The bytes of each non-empty line of hex text; a line that is not hex is reported."""
    for number, line in _lines(chunks):
        if not line.strip():
            continue
        try:
            yield _unhex(line)
        except ValueError as error:
            decoder.not_hex(number, str(error))


def _deframe(decoder: _Decoder, chunks: Iterable[bytes], max_length: int) -> str:
    """Decode the payload of every frame in a serial byte stream; the summary line."""
    deframer = Deframer(max_length)
    for chunk in chunks:
        for payload in deframer.feed(chunk):
            decoder.datagram(payload)
    stats = deframer.stats()
    parts = [_plural(stats.frames, "frame"), f"{decoder.failed} undecodable"]
    discarded = stats.discarded_bytes
    if discarded:
        reasons = ", ".join(f"{reason} {count}" for reason, count in sorted(discarded.items()))
        parts.append(f"{_plural(sum(discarded.values()), 'byte')} discarded ({reasons})")
    if deframer.buffered():
        parts.append(f"{_plural(deframer.buffered(), 'byte')} left in an unfinished frame")
    if decoder.bad_lines:
        parts.append(f"{_plural(decoder.bad_lines, 'line')} not hex")
    return ", ".join(parts)


def _dpkt() -> ModuleType:
    try:
        return importlib.import_module("dpkt")
    except ImportError:
        raise _Fatal("--pcap needs the dpkt package: pip install 'erc-codec[pcap]'") from None


class _Capture:
    """A capture file that notes reads stopping short inside it: dpkt hands a pcap record cut
    off by the end of the file over as a shorter (or empty) packet, without a word, and skips a
    pcapng block cut short if it holds no packet. A short read that is not the last (the end of
    the file) is a cut, and so is one right before a packet comes out (``short``)."""

    def __init__(self, file: BinaryIO) -> None:
        self._file = file
        self.cut = False
        self.short = False

    def read(self, size: int = -1) -> bytes:
        self.cut = self.cut or self.short
        data = self._file.read(size)
        self.short = 0 <= len(data) < size
        return data

    def seek(self, offset: int, whence: int = 0) -> int:
        self.short = False  # dpkt rereads from the top when a capture is not pcap but pcapng
        return self._file.seek(offset, whence)

    def tell(self) -> int:
        return self._file.tell()

    def __enter__(self) -> "_Capture":
        return self

    def close(self) -> None:
        self._file.close()

    def __exit__(self, *exc: object) -> None:
        self.close()


def _open_capture(dpkt: ModuleType, path: Path) -> tuple[_Capture, Any]:
    """The open file and a dpkt reader of a pcap or pcapng capture, or a one-line exit 2."""
    try:
        file = _Capture(path.open("rb"))
    except OSError as error:
        raise _Fatal(f"cannot read {path}: {error.strerror or error}") from None
    try:
        reader = dpkt.pcap.UniversalReader(file)
        linktype = reader.datalink()
    except Exception:  # dpkt raises ValueError, its own errors or struct.error on a bad header
        file.close()
        raise _Fatal(f"{path} is not a pcap or pcapng capture") from None
    if linktype not in (_ETHERNET, _LINUX_SLL, _LINUX_SLL2, *_RAW_IP, *_LOOPBACK):
        file.close()
        raise _Fatal(
            f"{path}: link type {linktype} is not supported (Ethernet, Linux cooked (SLL, SLL2), "
            "raw IP and loopback are)"
        )
    return file, reader


def _udp(dpkt: ModuleType, linktype: int, packet: bytes) -> tuple[str, Any, Any]:
    """``("", ip, udp)`` for a whole UDP datagram, else ``(why it is skipped, None, None)``."""
    try:
        if linktype == _ETHERNET:
            ip = dpkt.ethernet.Ethernet(packet).data
        elif linktype == _LINUX_SLL:
            ip = dpkt.sll.SLL(packet).data
        elif linktype == _LINUX_SLL2:
            ip = dpkt.sll2.SLL2(packet).data
        else:
            raw = packet[4:] if linktype in _LOOPBACK else packet
            version = raw[0] >> 4 if raw else 0
            ip = dpkt.ip.IP(raw) if version == 4 else dpkt.ip6.IP6(raw) if version == 6 else None
    except Exception:  # dpkt raises assorted errors on a packet too short for its headers
        return "malformed", None, None
    if isinstance(ip, dpkt.ip.IP):
        if ip.mf or ip.offset:
            return "fragmented", None, None
    elif isinstance(ip, dpkt.ip6.IP6):
        fragment = ip.extension_hdrs.get(_IPV6_FRAGMENT)
        if fragment is not None and (fragment.frag_off or fragment.m_flag):
            return "fragmented", None, None
    else:
        return "not UDP", None, None
    udp = ip.data
    if not isinstance(udp, dpkt.udp.UDP):
        return "not UDP", None, None
    if udp.ulen < 8:
        return "malformed", None, None
    if len(udp.data) < udp.ulen - 8:
        return "cut short by the capture", None, None
    return "", ip, udp


def _endpoint(address: bytes, port: int) -> str:
    host = ipaddress.ip_address(address)
    return f"[{host}]:{port}" if host.version == 6 else f"{host}:{port}"


def _capture(decoder: _Decoder, dpkt: ModuleType, path: Path, file: _Capture, reader: Any) -> str:
    """Decode every UDP payload of a capture; the summary line.

    A capture damaged after its header (cut off while it was written) is decoded up to the
    damage, then the summary and the damage are reported and the command exits 2.
    """
    linktype = reader.datalink()
    skipped: dict[str, int] = {}
    packets = iter(reader)
    damage = ""
    while True:
        count = decoder.datagrams + sum(skipped.values())
        try:
            timestamp, packet = next(packets)
        except StopIteration:
            if file.cut:
                damage = f"{path} is cut off after packet {count}"
            break
        except Exception as error:  # dpkt raises its own errors, ValueError or struct.error
            damage = f"{path} is damaged after packet {count}: {type(error).__name__} {error}"
            break
        if file.cut or file.short:
            damage = f"{path} is cut off inside packet {count + 1}"
            break
        why, ip, udp = _udp(dpkt, linktype, packet)
        if why:
            skipped[why] = skipped.get(why, 0) + 1
            continue
        where: dict[str, object] = {
            "time": float(timestamp),
            "src": _endpoint(ip.src, udp.sport),
            "dst": _endpoint(ip.dst, udp.dport),
        }
        decoder.datagram(bytes(udp.data[: udp.ulen - 8]), where)
    reasons = ", ".join(f"{count} {why}" for why, count in sorted(skipped.items()))
    summary = (
        f"{_plural(decoder.datagrams, 'datagram')}, {decoder.failed} undecodable, "
        f"{_plural(sum(skipped.values()), 'packet')} skipped" + (f" ({reasons})" if reasons else "")
    )
    if damage:
        click.echo(summary, err=True)
        raise _Fatal(_one_line(damage))
    return summary


def _quietly(work: Callable[[], str | None]) -> str | None:
    """``work()``, except that a reader who went away (``| head``) ends the command quietly."""
    try:
        return work()
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        sys.exit(1)


@main.command()
@click.argument("data", nargs=-1, metavar="[HEX... | -]")
@click.option(
    "--pcap",
    "capture",
    type=click.Path(path_type=Path),
    metavar="FILE",
    help="Decode every UDP payload of a pcap or pcapng capture (needs the pcap extra: dpkt).",
)
@click.option(
    "--framed",
    is_flag=True,
    help="The input is a serial byte stream of Proton frames: decode each frame's payload.",
)
@_schema_options
def decode(
    data: tuple[str, ...], capture: Path | None, framed: bool, tree: Path | None, root: str
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
    if "-" in data and len(data) > 1:
        raise click.UsageError("'-' (standard input) cannot be combined with HEX")
    given = None
    if data and data != ("-",):
        try:
            given = _unhex(" ".join(data))
        except ValueError as error:
            raise click.BadParameter(str(error), param_hint="HEX") from None
    if capture is not None:
        dpkt = _dpkt()
        file, reader = _open_capture(dpkt, capture)
        with file:
            decoder = _Decoder(_load(tree, root))
            summary = _quietly(lambda: _capture(decoder, dpkt, capture, file, reader))
    else:
        codec = _load(tree, root)
        decoder = _Decoder(codec)
        if given is not None:
            hex_text, chunks = False, iter([given])
        else:
            hex_text, chunks = _stdin()
        if hex_text:
            chunks = _hex_lines(decoder, chunks)
        if framed:
            max_length = codec.max_size(codec.root)
            summary = _quietly(lambda: _deframe(decoder, chunks, max_length))
        elif hex_text:
            summary = _quietly(lambda: decoder.each(chunks))
        else:  # one datagram: HEX (even an empty one), or raw standard input unless empty
            whole = b"".join(chunks)
            datagrams = [whole] if whole or given is not None else []
            summary = _quietly(lambda: decoder.each(datagrams))
    if summary is not None:
        click.echo(summary, err=True)
    sys.exit(1 if decoder.failed or decoder.bad_lines else 0)


@main.command()
@click.argument("kind")
@click.argument("payload", metavar="JSON")
@click.option(
    "--mode",
    type=click.Choice(["strip", "exact", "pad"]),
    default="strip",
    show_default=True,
    help="strip trailing zeros (the fleet's UDP form), exact protobuf, or pad to the envelope's "
    "maximum size.",
)
@click.option(
    "--frame",
    "framed",
    is_flag=True,
    help="Wrap the datagram in a Proton serial frame (50 52, length, payload, CRC-16).",
)
@_schema_options
def encode(kind: str, payload: str, mode: str, framed: bool, tree: Path | None, root: str) -> None:
    """Encode one payload, given as protobuf JSON, and print the datagram in hex.

    KIND is the envelope member that carries it (erc-codec sizes lists them,
    e.g. gps_info). JSON is the payload in protobuf's JSON mapping: field names
    as in the .proto or in lowerCamelCase, enums by name or number, 64-bit
    integers as numbers or strings; fields left out are zero. '-' reads the
    JSON from standard input.

    \b
      erc-codec encode gps_info '{"latitude": 52.2389, "fix_quality": "DGPS_FIX"}'
      erc-codec encode gps_info '{"satellites": 9}' --frame | erc-codec decode --framed

    \b
    Exit status: 0 printed; 1 bad input: not JSON, not a payload of this kind
    (unknown field, wrong type) or a message a nanopb receiver would drop or
    misread (an undeclared enum value, a value over a nanopb limit); 2 usage
    error: unknown KIND or option, or a schema that does not load. An error
    about KIND, the JSON or the message is one line on stderr.
    """
    codec = _load(tree, root)
    if payload == "-" and sys.stdin is None:
        raise _Fatal("standard input is closed: give the JSON as an argument")
    envelope = envelope_from_json(codec, kind, sys.stdin.read() if payload == "-" else payload)
    try:
        datagram = codec.encode(envelope, cast(Mode, mode))
    except EncodeError as error:
        raise click.ClickException(_one_line(str(error))) from None
    click.echo((frame(datagram) if framed else datagram).hex())


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """A JSON object, refusing a key given twice (json.loads would keep the last silently)."""
    document: dict[str, Any] = {}
    for key, value in pairs:
        if key in document:
            raise ValueError(f"key {key!r} appears twice")
        document[key] = value
    return document


def envelope_from_json(codec: Codec, kind: str, text: str) -> Message:
    """An envelope carrying, as member ``kind``, the payload that protobuf JSON ``text`` spells.

    Unknown kinds are a usage error (exit 2), bad JSON a bad-input error (exit 1), one line each.
    """
    members = list(codec.kinds().values())
    if kind not in members:
        raise _Fatal(f"unknown kind {kind!r}: {codec.root} has {', '.join(members)}")
    envelope = codec.message_class(codec.root)()
    message = getattr(envelope, kind)
    try:
        document = json.loads(text, object_pairs_hook=_unique_keys)
    except (ValueError, RecursionError) as error:
        raise click.ClickException(f"JSON is not valid: {_one_line(str(error))}") from None
    if not isinstance(document, dict):
        raise click.ClickException(
            f"JSON must be an object: the fields of {message.DESCRIPTOR.full_name}"
        )
    try:
        json_format.ParseDict(document, message)
    except (json_format.ParseError, RecursionError) as error:
        raise click.ClickException(_one_line(str(error))) from None
    message.SetInParent()  # an all-default payload is still the one sent
    return envelope


from . import _cli_net  # noqa: E402, F401 - registers send and listen on main
