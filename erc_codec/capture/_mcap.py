"""Datagrams to an MCAP file and back, with the ``mcap`` and ``mcap-protobuf-support`` libraries
(the ``mcap`` extra).

What it guarantees:
- Every datagram written is in the file.
- A datagram that decodes is a message on its member's channel, ``/erc/<kind>``.
  - Its payload is re-encoded in the exact protobuf form, which every protobuf reader accepts.
  - Its schema is the one ``_recording`` builds.
- A datagram that does not decode is a ``DroppedDatagram`` on ``/erc-codec/drops``, with its
  bytes as received.
- Log time is the arrival (or capture) time, and publish time is the same.
  A ``PBEnvelope`` is one oneof and carries no time of its own.
  A payload's own times stay in the payload.
- A message's ``sequence`` is the datagram's number in the recording, so gaps and order show
  across channels.
- A metadata record ``erc-codec``, written first, says where the schema came from:
  - the tree and its git revision;
  - a digest of the envelope's descriptors;
  - ``<root>_size``.
- A metadata record ``erc-codec.summary``, written last, says what the file holds:
  - counts by kind and by reason, and senders;
  - ``unkept.<number>``, for the first ``MAX_UNKEPT_NUMBERS`` numbers: the datagrams whose
    envelope carried field ``number``, unknown to the schema, beside the payload.
    A payload channel cannot hold such a field.
  - ``unkept.unlisted``: the fields of the other numbers.
- Memory stays flat: the writer streams chunks, and what it keeps per datagram is counters.
- Chunks are zstd-compressed, with CRCs on chunks and on the data section.

The file must be seekable, because the library goes back to write its indexes.
"""

import os
import struct
import zlib
from collections.abc import Callable, Iterable, Iterator, Mapping
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, BinaryIO, Literal, NamedTuple

from google.protobuf.message import DecodeError as ProtobufDecodeError
from google.protobuf.message import Message

from erc_schema import CodecError, DecodeError, descriptor_of

from ..codec import Codec, UnkeptFields
from ._origin import erc_codec_version, schema_origin
from ._recording import (
    DROPS_TOPIC,
    drop_schema,
    dropped_datagram,
    file_descriptor_set,
    kind_of,
    member_topic,
    require,
)

if TYPE_CHECKING:
    from mcap.writer import Writer

__all__ = [
    "McapWriter",
    "Recorded",
    "RecordingStats",
    "holds_log_time",
    "read_mcap",
    "recorded_payloads",
    "unkept_summary",
]

Compression = Literal["zstd", "lz4", "none"]
_MAX_SENDERS = 256  # distinct (kind, sender) pairs named in the summary; the rest are counted
_MAX_LOG_TIME = (1 << 64) - 1  # MCAP's times are unsigned 64-bit nanoseconds: up to 2554 AD


class RecordingStats(NamedTuple):
    """What a writer has written (copies: changing them changes nothing)."""

    messages: dict[str, int]  # kind → messages
    drops: dict[str, int]  # reason → dropped datagrams
    # field number → datagrams whose envelope carried that field, unknown to the schema, beside
    # the payload: the payload is recorded on its channel, the field is not (``unkept``); the
    # first MAX_UNKEPT_NUMBERS numbers to arrive are listed
    unkept: Mapping[int, int] = MappingProxyType({})
    # fields of the numbers not listed in ``unkept``, once per datagram and number
    unkept_unlisted: int = 0


class Recorded(NamedTuple):
    """One message of a recording, as ``read_mcap`` yields it."""

    log_time: int  # nanoseconds since the Unix epoch: when the datagram arrived (was captured)
    kind: str | None  # the envelope member; None for a drop
    message: Message  # the payload, or for a drop its DroppedDatagram


def _mcap(module: str, what: str) -> Any:
    return require(module, "mcap", "mcap", what)


class McapWriter:
    """Writes datagrams (or decoded payloads, and drops) to an MCAP file.

    - ``output`` is a path or a seekable binary file.
    - ``source`` says in the file's metadata where the datagrams came from, such as
      ``"udp 127.0.0.1:5000"`` or ``"capture rover.pcapng"``.
    - Use it as a context manager, or call ``close()``.
      The file is complete (indexed, summarised) only then.
    """

    def __init__(
        self,
        output: str | os.PathLike[str] | BinaryIO,
        codec: Codec | None = None,
        *,
        source: str = "",
        chunk_size: int = 1 << 20,
        compression: Compression = "zstd",
    ) -> None:
        writer_module = _mcap("mcap.writer", "writing MCAP")
        well_known = _mcap("mcap.well_known", "writing MCAP")
        self._codec = codec or Codec.default()
        self._decode = self._codec.decode
        self._encoding = well_known.MessageEncoding.Protobuf
        self._schema_encoding = well_known.SchemaEncoding.Protobuf
        if isinstance(output, str | os.PathLike):
            self._file: BinaryIO = Path(output).open("wb")  # noqa: SIM115 (close() closes it)
            self._owned = True
        else:
            if not output.seekable():
                raise CodecError("an MCAP file must be written to a seekable file, not a pipe")
            self._file, self._owned = output, False
        self._writer: Writer = writer_module.Writer(
            self._file,
            chunk_size=chunk_size,
            compression=writer_module.CompressionType[compression.upper()],
            enable_crcs=True,
            enable_data_crcs=True,
        )
        self._writer.start(profile="", library=f"erc-codec {erc_codec_version()}")
        self._writer.add_metadata(
            "erc-codec", _texts({**schema_origin(self._codec), "source": source})
        )
        self._add = self._writer.add_message
        self._channels: dict[str, int] = {}  # kind → channel id
        self._serializers: dict[type[Message], Callable[[Message], bytes]] = {}
        self._schemas: dict[str, int] = {}  # payload full name → schema id
        self._drops_channel = 0
        self._messages: dict[str, int] = {}
        self._drops: dict[str, int] = {}
        self._unkept = UnkeptFields()
        self._senders: dict[tuple[str, str], int] = {}
        self._unlisted_senders = 0
        self._sequence = 0
        self._closed = False

    def __enter__(self) -> "McapWriter":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def write(
        self, data: bytes, log_time: int, source: str = "", destination: str = ""
    ) -> str | None:
        """Decode one datagram and write it as a message, or as a drop; its kind, or None. A
        ``log_time`` MCAP cannot hold (``holds_log_time``) is a ``CodecError``, nothing written."""
        if not holds_log_time(log_time):
            raise _outside(log_time)
        try:
            decoded = self._decode(data)
        except DecodeError as error:
            self.drop(data, log_time, error.reason, str(error), source, destination)
            return None
        if decoded.envelope_unknown_fields:  # a channel holds the payload alone: counted
            self.unkept(field.number for field in decoded.envelope_unknown_fields)
        kind, message = decoded.kind, decoded.message
        # The message's class's serializer, kept: looking it up on each instance costs upb about
        # half a small message's serialization (benchmarks/bench_record.py: a capture to MCAP >=
        # 0.7x the bare libraries); tests/capture/test_mcap.py (every kind in every form) holds the
        # bytes written equal to the payload's own SerializeToString.
        cls = type(message)
        serialize = self._serializers.get(cls)
        if serialize is None:
            serialize = self._serializers[cls] = cls.SerializeToString
        self._payload(kind, serialize(message), log_time, source)
        return kind

    def unkept(self, numbers: Iterable[int]) -> None:
        """Count a datagram whose envelope carried fields ``numbers`` beside its payload that
        the schema does not know: its payload is written (``message``), they cannot be, and
        the summary says so (``unkept.<number>``, or ``unkept.unlisted`` past the numbers
        listed)."""
        self._unkept.count(numbers)

    def message(self, kind: str, payload: Message | bytes, log_time: int, source: str = "") -> None:
        """Write the payload of a decoded datagram of member ``kind`` (the message, or its exact
        encoding) that arrived at ``log_time`` (nanoseconds since the epoch) from ``source``."""
        if not holds_log_time(log_time):
            raise _outside(log_time)
        data = payload if isinstance(payload, bytes) else payload.SerializeToString()
        self._payload(kind, data, log_time, source)

    def _payload(self, kind: str, data: bytes, log_time: int, source: str) -> None:
        """Write a payload's exact encoding on its member's channel, and count it."""
        channel = self._channels.get(kind)
        if channel is None:
            channel = self._channel(kind)
        self._sequence = sequence = (self._sequence + 1) & 0xFFFFFFFF  # MCAP's is a uint32
        self._add(channel, log_time, data, log_time, sequence)
        messages = self._messages
        messages[kind] = messages.get(kind, 0) + 1
        senders, key = self._senders, (kind, source)
        if key in senders:
            senders[key] += 1
        elif len(senders) < _MAX_SENDERS:
            senders[key] = 1
        else:
            self._unlisted_senders += 1

    def drop(
        self,
        data: bytes,
        log_time: int,
        reason: str,
        error: str = "",
        source: str = "",
        destination: str = "",
    ) -> None:
        """Write a datagram that did not decode, exactly as it arrived, with why."""
        if not holds_log_time(log_time):
            raise _outside(log_time)
        if not self._drops_channel:
            name, files = drop_schema()
            schema = self._writer.register_schema(name, self._schema_encoding, files)
            self._drops_channel = self._writer.register_channel(DROPS_TOPIC, self._encoding, schema)
        record = dropped_datagram()(
            reason=reason,
            error=" ".join(error.split()),
            length=len(data),
            data=data,
            source=source,
            destination=destination,
        )
        self._sequence = sequence = (self._sequence + 1) & 0xFFFFFFFF
        self._add(self._drops_channel, log_time, record.SerializeToString(), log_time, sequence)
        self._drops[reason] = self._drops.get(reason, 0) + 1

    def stats(self) -> RecordingStats:
        """Messages by kind and drops by reason, so far."""
        unkept = self._unkept
        return RecordingStats(
            dict(self._messages), dict(self._drops), dict(unkept.counts), unkept.unlisted
        )

    def close(self, summary: Mapping[str, str] | None = None) -> None:
        """Write the summary (what was written, who sent it, and ``summary``'s own entries, such
        as datagrams lost before they reached the writer), finish the file and close it."""
        if self._closed:
            return
        self._closed = True
        try:
            self._writer.add_metadata(
                "erc-codec.summary", _texts({**self._summary(), **(summary or {})})
            )
            self._writer.finish()  # type: ignore[no-untyped-call]  # mcap leaves it unannotated
        finally:
            if self._owned:
                self._file.close()

    def _channel(self, kind: str) -> int:
        descriptor = descriptor_of(self._codec.payload_class(kind))
        name = descriptor.full_name
        schema = self._schemas.get(name)
        if schema is None:
            schema = self._schemas[name] = self._writer.register_schema(
                name, self._schema_encoding, file_descriptor_set(descriptor)
            )
        channel: int = self._writer.register_channel(member_topic(kind), self._encoding, schema)
        self._channels[kind] = channel
        return channel

    def _summary(self) -> dict[str, str]:
        messages, drops = sum(self._messages.values()), sum(self._drops.values())
        summary = {
            "datagrams": str(messages + drops),
            "messages": str(messages),
            "drops": str(drops),
        }
        summary.update({f"messages.{k}": str(n) for k, n in sorted(self._messages.items())})
        summary.update({f"drops.{r}": str(n) for r, n in sorted(self._drops.items())})
        summary.update(unkept_summary(self._unkept.counts, self._unkept.unlisted))
        senders: dict[str, list[tuple[int, str]]] = {}
        for (kind, source), count in self._senders.items():
            senders.setdefault(kind, []).append((count, source or "unknown"))
        for kind, counts in sorted(senders.items()):
            listed = sorted(counts, key=lambda entry: (-entry[0], entry[1]))
            summary[f"senders.{kind}"] = ", ".join(f"{source} {n}" for n, source in listed)
        if self._unlisted_senders:
            summary["senders.unlisted_messages"] = str(self._unlisted_senders)
        return summary


def holds_log_time(log_time: int) -> bool:
    """Whether an MCAP file can hold ``log_time``, nanoseconds since the Unix epoch: from 1970
    to 2554 (its times are unsigned 64-bit)."""
    return 0 <= log_time <= _MAX_LOG_TIME


def _outside(log_time: int) -> CodecError:
    return CodecError(
        f"log time {log_time} ns is outside what MCAP holds: 0 to 2**64 - 1 ns since the epoch "
        "(1970 to 2554)"
    )


def unkept_summary(unkept: Mapping[int, int], unlisted: int) -> dict[str, str]:
    """A summary's entries for the fields beside the payloads that no channel holds:
    ``unkept.<number>`` for each number listed, ``unkept.unlisted`` for the fields of the others."""
    entries = {f"unkept.{number}": str(n) for number, n in sorted(unkept.items())}
    if unlisted:
        entries["unkept.unlisted"] = str(unlisted)
    return entries


def _texts(entries: Mapping[str, str]) -> dict[str, str]:
    """Metadata as UTF-8 can hold it: a file name that is not UTF-8 (its bytes held as
    surrogates, as Python reads such names) keeps those bytes backslash-escaped."""
    return {_text(key): _text(value) for key, value in entries.items()}


def _text(text: str) -> str:
    try:
        text.encode("utf-8")
        return text
    except UnicodeEncodeError:
        pass
    try:  # the name's own bytes: the file b"r\xff.pcap" is written r\xff.pcap
        return text.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")
    except UnicodeEncodeError:  # a surrogate that stands for no byte
        return text.encode("utf-8", "backslashreplace").decode("utf-8")


def read_mcap(path: str | os.PathLike[str]) -> Iterator[Recorded]:
    """Every message of an MCAP file that erc-codec wrote, as ``Recorded(log_time, kind, message)``.

    - Messages come in log-time order.
    - They are decoded with the schemas the file carries, as Foxglove decodes them.
      So an old recording reads right whatever the tree is now.
    - A drop comes as kind ``None`` with a ``DroppedDatagram`` (``reason``, ``error``,
      ``length``, ``data``, ``source``, ``destination``).
    - Only the ``/erc/<kind>`` and drops channels are read.
      A file may carry others, such as JSON statistics.
    - Chunk and summary CRCs are checked.
    - Each of these files is a ``CodecError`` naming it:
      - a damaged file;
      - one whose channel is not protobuf;
      - one whose schema does not load;
      - one whose message does not parse with its schema."""
    for message, kind, decoded in _decoded(path):
        yield Recorded(message.log_time, kind, decoded)


def recorded_payloads(path: str | os.PathLike[str]) -> Iterator[tuple[int, str | None, bytes]]:
    """``(log_time, kind, payload bytes)`` of every member message of an MCAP file, and
    ``(log_time, None, datagram as received)`` of every drop, in log-time order, the bytes as
    the file holds them; a file ``read_mcap`` refuses is refused here, with the same error."""
    parse_drop = dropped_datagram().FromString
    for message, kind, _ in _decoded(path):
        if kind is not None:
            yield message.log_time, kind, message.data
        else:
            try:
                drop: Any = parse_drop(message.data)
            except ProtobufDecodeError as error:
                raise CodecError(
                    f"{path} is not a readable MCAP recording: a drop does not parse: {error}"
                ) from None
            yield message.log_time, None, drop.data


def _decoded(path: str | os.PathLike[str]) -> Iterator[tuple[Any, str | None, Message]]:
    """``(message, kind, decoded)`` of every message ``_recorded`` reads, decoded with its
    channel's schema: a channel that is not protobuf, a schema that does not load and a message
    that does not parse are a ``CodecError`` naming the file."""
    factory = _mcap("mcap_protobuf.decoder", "reading MCAP").DecoderFactory()
    decoders: dict[int, Any] = {}
    for schema, channel, message, kind in _recorded(path):
        decode = decoders.get(channel.id)
        if decode is None:
            try:
                decode = decoders[channel.id] = factory.decoder_for(
                    channel.message_encoding, schema
                )
            except Exception as error:  # protobuf raises TypeError, KeyError... on a bad set
                raise CodecError(
                    f"{path} is not a readable MCAP recording: the schema of {channel.topic} "
                    f"does not load: {error}"
                ) from None
            if decode is None:
                raise CodecError(
                    f"{path} is not a readable MCAP recording: {channel.topic} is not protobuf"
                )
        try:
            decoded = decode(message.data)
        except ProtobufDecodeError as error:
            raise CodecError(
                f"{path} is not a readable MCAP recording: a message on {channel.topic} does "
                f"not parse: {error}"
            ) from None
        yield message, kind, decoded


def _recorded(path: str | os.PathLike[str]) -> Iterator[tuple[Any, Any, Any, str | None]]:
    """``(schema, channel, message, kind)`` of every message on a member's channel (kind None on
    the drops channel), in log-time order, every byte read checked by a CRC: the chunks', and
    the summary's (whose chunk indexes and channels the seeking reader trusts)."""
    reader_module = _mcap("mcap.reader", "reading MCAP")
    errors = _damage()
    try:
        with Path(path).open("rb") as file:
            reader = reader_module.SeekingReader(file, validate_crcs=True)
            summary = reader.get_summary()
            if summary is None or not summary.chunk_indexes:  # no index: read it all through
                file.seek(0)
                reader = reader_module.NonSeekingReader(file, validate_crcs=True)
            else:
                _check_summary(file)
            for schema, channel, message in reader.iter_messages():
                kind = kind_of(channel.topic)
                if kind is not None or channel.topic == DROPS_TOPIC:
                    yield schema, channel, message, kind
    except errors as error:
        why = str(error) or ("it ends early" if isinstance(error, EOFError) else repr(error))
        raise CodecError(f"{path} is not a readable MCAP recording: {why}") from None


_FOOTER = struct.Struct("<BQQQI8s")  # opcode, length, summary start and offset start, CRC, magic


def _check_summary(file: BinaryIO) -> None:
    """The summary section's CRC (the footer's), which the mcap reader does not check: it covers
    everything from the summary's start to the footer's CRC field."""
    end = file.seek(0, os.SEEK_END)
    file.seek(end - _FOOTER.size)
    _, _, start, _, expected, _ = _FOOTER.unpack(file.read(_FOOTER.size))
    if not expected:
        return
    if not 0 < start <= end - _FOOTER.size:
        raise ValueError(f"the footer's summary start {start} is outside the file")
    file.seek(start)
    remaining, crc = end - 12 - start, 0  # 12: the CRC and the magic after it
    while remaining:
        block = file.read(min(remaining, 1 << 20))
        if not block:
            break
        crc, remaining = zlib.crc32(block, crc), remaining - len(block)
    if crc != expected:
        raise ValueError(f"the summary's CRC is {crc:#010x}, the footer says {expected:#010x}")


def _damage() -> tuple[type[Exception], ...]:
    """What the readers raise on a damaged file: their own errors, a CRC that does not match
    (a ValueError), records cut short, chunks that do not decompress, payloads that do not
    parse."""
    zstd: Any = _mcap("zstandard", "reading MCAP")
    mcap_error = _mcap("mcap.exceptions", "reading MCAP").McapError
    # A flipped length or offset seeks before the file's start (OSError), allocates what it says
    # (MemoryError), or names a channel or schema that is not there (KeyError).
    return (
        mcap_error,
        ValueError,
        struct.error,
        EOFError,
        zstd.ZstdError,
        ProtobufDecodeError,
        OSError,
        MemoryError,
        KeyError,
    )
