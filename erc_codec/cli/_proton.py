"""``erc-codec proton decode`` and ``erc-codec proton listen``: Proton bundles, named by their
configuration, as JSON lines.

Both read Proton messages as ``erc_codec.proton.BundleCodec`` does (``--protocol`` 2.0 or 1.0) and
print one JSON object per message: the bundle's name and id and its signals by name, valued as
protobuf's JSON mapping values them (64-bit integers as strings, bytes as base64, a ``float`` in
the fewest digits that read back as the same 32-bit float, NaN and the infinities as "NaN",
"Infinity", "-Infinity"; a 1.0 list type as a list of those), and the fields the message carried
that Proton does not define, if any. A message that does not decode is an ``error`` object with
its reason, and the rest go on.
"""

import base64
import contextlib
import json
import math
import signal
import struct
from collections.abc import Callable
from pathlib import Path
from typing import Any, cast

import click

from erc_schema import CodecError, DecodeError

from ..proton import BundleCodec, Value, load_config, split_udp_header
from ..runtime import Deframer
from ._reading import Printer, decode_input, input_options
from ._shared import FINITE, Fatal, emit, one_line, parse_address, resolve, shown

__all__ = ["proton"]

_MAX_FRAME = 0xFFFF
_FLOAT32 = struct.Struct("<f")


@click.group()
def proton() -> None:
    """Proton bundles (Clearpath's MCU <-> PC protocol), by a configuration's names."""


_CONFIG = click.option(
    "--config",
    "config_path",
    required=True,
    type=click.Path(dir_okay=False, path_type=Path),
    metavar="FILE",
    help="The Proton configuration (YAML, as Proton's generator reads it).",
)
_PROTOCOL = click.option(
    "--protocol",
    type=click.Choice(["2.0", "1.0"]),
    default="2.0",
    show_default=True,
    help=(
        "Proton's protocol version: 2.0 (signal ids) or 1.0 (the rover's first design, with "
        "list types)."
    ),
)
_SCRATCH = click.option(
    "--scratch-buffer-size",
    "scratch",
    type=click.IntRange(1, 0xFFFF),
    default=512,
    show_default=True,
    metavar="BYTES",
    help="2.0: the PROTON_SCRATCH_BUFFER_SIZE the peers' C core is built with; a string or "
    "bytes capacity it cannot decode makes the configuration one that does not load.",
)


def _codec(path: Path, protocol: str, scratch: int) -> BundleCodec:
    """The codec ``--config`` and ``--protocol`` name (one that does not load: exit 2)."""
    try:
        return BundleCodec(load_config(path), "1.0" if protocol == "1.0" else "2.0", scratch)
    except ModuleNotFoundError as error:  # the library's words: which extra brings it
        raise Fatal(str(error)) from None
    except CodecError as error:
        raise Fatal(one_line(str(error))) from None


def json_value(type_name: str, value: Value) -> Any:
    """A signal's value as protobuf's JSON mapping writes a field of its type."""
    if isinstance(value, list):
        element = type_name.removeprefix("list_")
        return [json_value(element, item) for item in value]
    if isinstance(value, bytes):
        return base64.b64encode(value).decode("ascii")
    if isinstance(value, float) and not math.isfinite(value):
        return "NaN" if math.isnan(value) else "Infinity" if value > 0 else "-Infinity"
    if type_name == "float":
        return _shortest_float32(cast(float, value))
    if type_name in ("int64", "uint64"):
        return str(value)
    return value


def _shortest_float32(value: float) -> float:
    """The float with the fewest significant digits (6 at least) that is the same 32-bit float:
    what protobuf's JSON mapping prints for a ``float`` (``type_checkers.ToShortestFloat``), so a
    C ``float`` 0.1 prints as 0.1, not as the double it widens to (0.10000000149011612)."""
    for digits in range(6, 10):  # 9 significant digits tell every 32-bit float apart
        shortest = float(f"{value:.{digits}g}")
        if _FLOAT32.unpack(_FLOAT32.pack(shortest))[0] == value:
            return shortest
    return value


class _Printer(Printer):
    """Decodes messages and prints one JSON line for each, counting the failures."""

    def __init__(self, codec: BundleCodec) -> None:
        super().__init__()
        self.codec = codec
        self.bundles: dict[str, int] = {}
        self.errors: dict[str, int] = {}

    def payload(self, data: bytes) -> None:
        """A serial frame's payload: a message, without the UDP header a datagram may have."""
        self.datagram(data, udp=False)

    def datagram(
        self, data: bytes, where: dict[str, object] | None = None, udp: bool = True
    ) -> None:
        """Print one message (a datagram's, with its optional UDP header when ``udp``)."""
        self.datagrams += 1
        header, message = split_udp_header(data) if udp else (None, data)
        record: dict[str, object] = dict(where or {})
        if header is not None:
            record["node_id"] = header.node_id
        try:
            bundle = self.codec.decode(message)
        except DecodeError as error:
            self.failed += 1
            self.errors[error.reason] = self.errors.get(error.reason, 0) + 1
            error_line = {"error": one_line(str(error)), "reason": error.reason}
            emit({**record, **error_line, "length": len(data)})
            return
        self.bundles[bundle.name] = self.bundles.get(bundle.name, 0) + 1
        signals = {
            name: json_value(self.codec.config.signal(name).type, value)
            for name, value in bundle.signals.items()
        }
        record |= {"bundle": bundle.name, "id": bundle.id, "length": len(data), "signals": signals}
        if bundle.unknown_fields:
            record["unknown_fields"] = [field._asdict() for field in bundle.unknown_fields]
        emit(record)


@proton.command()
@click.argument("data", nargs=-1, metavar="[HEX... | -]")
@_CONFIG
@_PROTOCOL
@_SCRATCH
@input_options
def decode(
    data: tuple[str, ...],
    config_path: Path,
    protocol: str,
    scratch: int,
    capture: Path | None,
    ports: tuple[int, ...],
    framed: bool,
    raw: bool,
) -> None:
    """Decode Proton messages to JSON: one object per message, one per line, on stdout.

    \b
    Input, as for erc-codec decode, one of:
      HEX...      one message in hex (spaces and colons may separate digits)
      - or none   standard input: hex text, one message per non-empty line;
                  with --raw, raw bytes: one message
      --pcap FILE every UDP payload of a pcap or pcapng capture (--port:
                  only from or to these ports)
    With --framed, HEX or standard input (hex lines, or --raw bytes) is a
    serial stream of Proton frames.
    A datagram's 4-byte Proton 2.0 UDP header, when it has one, is read and
    its node id shown ("node_id").

    \b
    Output, one line per message:
      {"bundle": "status", "id": 256, "length": 31, "signals": {...}}
      {"error": "...", "reason": "unknown_bundle", "length": 5}
    (reasons: empty, corrupt, unknown_bundle, unsupported_operation; not_hex,
    with "line", for a line of standard input that is not hex, line_too_long
    for one longer than 262144 characters). A message
    with fields Proton does not define decodes without them, listed in
    "unknown_fields". With --pcap every object starts with "time", "src" and
    "dst"; --pcap and --framed end with a summary line on stderr (--framed:
    bytes discarded between frames, and a frame the stream cut off).

    \b
    Exit status: 0 every message decoded (rejected frames, discarded bytes and
    a cut-off last frame show in the summary only, as for erc-codec decode
    --framed); 1 at least one did not, a line was not hex or too long, or
    there was nothing to decode; 2 usage error, a configuration
    that does not load (one line naming its file, line and key), unreadable
    or damaged capture, or --pcap without dpkt.
    """
    printer = _Printer(_codec(config_path, protocol, scratch))
    decode_input(printer, data, raw, framed, capture, ports, lambda: Deframer(_MAX_FRAME))


@proton.command()
@click.argument("address", metavar="[HOST:]PORT")
@_CONFIG
@_PROTOCOL
@_SCRATCH
@click.option("--count", type=click.IntRange(min=1), help="Stop after this many datagrams.")
@click.option("--seconds", type=FINITE, help="Stop after this long.")
def listen(
    address: str,
    config_path: Path,
    protocol: str,
    scratch: int,
    count: int | None,
    seconds: float | None,
) -> None:
    """Print the Proton datagrams arriving on [HOST:]PORT (host 127.0.0.1 unless given).

    One JSON line per datagram, as decode prints them, each with "from"
    (address:port). Port 0 takes any free port; the address actually bound is
    the first line on stderr. It stops after --count datagrams, --seconds,
    Ctrl-C or SIGTERM, and prints its counters on stderr. Exit status 0; 1
    when standard output goes away (| head); 2 for a usage error, a
    configuration that does not load, an address it cannot bind or output it
    cannot write.
    """
    import asyncio

    host, port = parse_address(address, default_host="127.0.0.1")
    printer = _Printer(_codec(config_path, protocol, scratch))
    _, local = resolve(host, port)
    with contextlib.suppress(KeyboardInterrupt):  # Ctrl-C ends it as --count would
        asyncio.run(_listen(printer, local, count, seconds))
    counters = {
        "received": printer.datagrams,
        "bundles": printer.bundles,
        "undecodable": printer.errors,
    }
    click.echo(f"counters: {json.dumps(counters)}", err=True)


async def _listen(
    printer: _Printer, local: tuple[Any, ...], count: int | None, seconds: float | None
) -> None:
    """Print what arrives until --count, --seconds, Ctrl-C or SIGTERM; output that cannot be
    written (a reader gone away, a full disk) ends it, raised here for the command group to
    report."""
    import asyncio

    loop = asyncio.get_running_loop()
    finished = loop.create_future()

    def stop() -> None:  # Ctrl-C or SIGTERM: as --count, the counters then printed
        if not finished.done():
            finished.set_result(None)

    for number in (signal.SIGINT, signal.SIGTERM):
        with contextlib.suppress(NotImplementedError, RuntimeError):  # not on every system
            loop.add_signal_handler(number, stop)

    def heard(data: bytes, sender: Any) -> None:
        if finished.done():
            return  # already read when --count was reached, or output failed
        try:
            printer.datagram(data, {"from": shown(sender)})
        except OSError as error:  # stdout: a broken pipe, a full disk
            finished.set_exception(error)
            return
        if count is not None and printer.datagrams >= count:
            finished.set_result(None)

    try:
        transport, _ = await loop.create_datagram_endpoint(
            lambda: cast("asyncio.DatagramProtocol", _Datagrams(heard)), local_addr=local
        )
    except OSError as error:
        raise Fatal(f"cannot listen on {shown(local)}: {error}") from None
    click.echo(f"listening on {shown(transport.get_extra_info('sockname'))}", err=True)
    try:
        await asyncio.wait([finished], timeout=seconds)
    finally:
        transport.close()
    if finished.done():
        finished.result()  # raises what stopped the output


class _Datagrams:
    """asyncio's datagram protocol, each datagram to ``heard(data, sender)``."""

    def __init__(self, heard: Callable[[bytes, Any], None]) -> None:
        self.heard = heard

    def connection_made(self, transport: object) -> None:
        """The socket is bound."""

    def connection_lost(self, exc: Exception | None) -> None:
        """The socket is closed."""

    def datagram_received(self, data: bytes, addr: Any) -> None:
        self.heard(data, addr)

    def error_received(self, exc: Exception) -> None:
        """An ICMP error for a send: a listener sends nothing."""
