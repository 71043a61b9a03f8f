"""PBEnvelope wrap/unwrap in three transmission forms: exact, stripped and zero-padded.

What this module guarantees:
- ``encode`` produces exactly the bytes protobuf (and nanopb) would for the envelope, then strips
  or pads trailing zeros; it never lets through what a fixed-size receiver would drop.
- ``decode`` accepts the exact, the stripped and the zero-padded form of an envelope and returns the
  same message for all three. A stripped form loses only zeros that belonged to the value of the
  last top-level field, so restoring them takes one walk over the top-level fields (one, in an
  envelope): bytes past the end count as zeros for as long as that field needs, and a zero byte
  where a tag is expected ends the message, provided nothing but zeros follows it.
- Every failure is a ``DecodeError``/``EncodeError`` saying what and where (offset, field path).

Both directions run per datagram, so the common case is the protobuf call plus a few byte
operations. Encoding looks the payload class up in a dict and prepends a precomputed tag-and-length
header to the payload's own serialization. Decoding reads that header itself (``peek``: tag → kind,
length → where the payload ends), so protobuf parses only the payload bytes: a stripped datagram
gets its missing zeros appended and a padded one is cut, by arithmetic, before the one parse.
Datagrams of any other shape (several top-level fields, unknown members, corruption) take the
general path: the repair walk over the whole envelope, then the envelope parse.
"""

from collections.abc import Callable
from typing import Literal, NamedTuple

from google.protobuf.descriptor import Descriptor
from google.protobuf.message import DecodeError as ProtobufDecodeError
from google.protobuf.message import EncodeError as ProtobufEncodeError
from google.protobuf.message import Message

from ._contract import Contract
from ._errors import DecodeError, EncodeError, SchemaError
from .schema import (
    EGROUP,
    LEN,
    SGROUP,
    WireError,
    descriptor_of,
    encode_varint,
    message_of,
    next_field,
    read_varint,
    varint_size,
)

__all__ = ["Decoded", "Envelope", "Mode"]

Mode = Literal["strip", "exact", "pad"]
_Member = tuple[
    list[bytes],
    Callable[[bytes], object] | None,
    Callable[[Message], None] | None,
    Callable[[Message], bytes],
]


class Decoded(NamedTuple):
    """A decoded datagram: the oneof member name (``kind``) and the payload message."""

    kind: str
    message: Message


# Builds a Decoded without NamedTuple's Python-level __new__, for the decode target of
# benchmarks/bench_codec.py (decode <= 1.25x the bare runtime); tests/test_codec.py holds it
# equal to Decoded(kind, message).
_decoded = tuple.__new__


def _member_class(envelope: type[Message], member: str) -> type[Message]:
    """The class of an envelope member's payload, as the envelope's own pool builds it."""
    return type(getattr(envelope(), member))


class Envelope:
    """Encoder and decoder for one envelope message type, with every lookup precomputed."""

    def __init__(
        self,
        envelope: type[Message],
        max_size: int,
        contract: Callable[[Descriptor], Contract | None],
        refusal: Callable[[Message], str | None] | None = None,
    ) -> None:
        descriptor = descriptor_of(envelope)
        self._refusal = refusal  # what nanopb's decoder refuses, for strict decodes
        oneofs = descriptor.oneofs
        if len(oneofs) != 1 or len(oneofs[0].fields) != len(descriptor.fields):
            raise SchemaError(
                f"{descriptor.full_name} must consist of exactly one oneof, "
                "whose members are the payload types"
            )
        self._name = descriptor.full_name
        self._class = envelope
        self._from_string = envelope.FromString
        self._oneof = descriptor.oneofs[0].name
        self._max_size = max_size
        self._kinds = {field.number: field.name for field in descriptor.fields}
        self._contracts: dict[str, Contract | None] = {}
        # Payload class → (tag-and-length header for each payload length that fits, contract
        # screen and check, serializer); None marks a type two members share, which cannot be
        # wrapped without naming the member. The serializer is the class's own method: looking
        # it up on each instance costs more in upb than serializing a small message does.
        self._members: dict[type[Message], _Member | None] = {}
        # First tag byte (or first | second << 8 for two-byte tags) → (kind, the payload class's
        # parser, offset of the length prefix).
        self._tags: dict[int, tuple[str, Callable[[bytes], Message], int]] = {}
        self._payloads: dict[str, type[Message]] = {}  # kind → payload class
        for field in descriptor.fields:
            payload = field.message_type
            if payload is None:
                raise SchemaError(f"{field.full_name} must be a message, not a scalar")
            rules = self._contracts[field.name] = contract(payload)
            tag = encode_varint(field.number << 3 | LEN)
            headers = [
                tag + encode_varint(length)
                for length in range(max_size)
                if len(tag) + varint_size(length) + length <= max_size
            ]
            cls = _member_class(envelope, field.name)
            screen, check = rules or (None, None)
            self._members[cls] = (
                None if cls in self._members else (headers, screen, check, cls.SerializeToString)
            )
            self._payloads[field.name] = cls
            if len(tag) <= 2:
                self._tags[int.from_bytes(tag, "little")] = (field.name, cls.FromString, len(tag))
        self._by_name = {cls.DESCRIPTOR.full_name: member for cls, member in self._members.items()}

    def kinds(self) -> dict[int, str]:
        """The envelope's payload members: field number → member name (a decoded ``kind``)."""
        return dict(self._kinds)

    def payload_class(self, kind: str) -> type[Message]:
        """The message class member ``kind`` carries."""
        try:
            return self._payloads[kind]
        except KeyError:
            raise SchemaError(f"{kind!r} is not a payload kind of {self._name}") from None

    # -- encoding ------------------------------------------------------------------------------

    def encode(self, message: Message, mode: Mode = "strip") -> bytes:
        """The datagram carrying ``message`` (a payload, or a whole envelope) in ``mode``."""
        member = self._members.get(type(message))
        if member is None:
            data = self._encode_other(message)
        else:
            headers, screen, check, serialize = member
            try:
                body = serialize(message)
            except ProtobufEncodeError:  # an unset proto2 required field: the check names it
                if check is not None:
                    check(message)
                raise EncodeError(
                    f"{message.DESCRIPTOR.full_name}: unset required fields"
                ) from None
            if check is not None and (screen is None or screen(body)):
                check(message)
            try:
                header = headers[len(body)]
            except IndexError:
                raise self._too_long(message, headers, body) from None
            if mode == "strip":  # a body is empty or ends in a field, never in its tag
                return header + body.rstrip(b"\0") if body else header.rstrip(b"\0")
            data = header + body
        if mode == "strip":
            return data.rstrip(b"\0")
        if mode == "exact":
            return data
        if mode == "pad":
            return data + bytes(self._max_size - len(data))
        raise EncodeError(f"unknown mode {mode!r}: use 'strip', 'exact' or 'pad'")

    def _encode_other(self, message: Message) -> bytes:
        """An envelope, a payload of a class built elsewhere (generated code), or an error."""
        name = message.DESCRIPTOR.full_name
        if name == self._name:
            kind = message.WhichOneof(self._oneof)
            if kind is None:
                raise EncodeError(f"{self._name} has no payload set")
            rules = self._contracts[kind]
            if rules is not None:
                rules.check(getattr(message, kind))
            data = message.SerializeToString()
            if len(data) > self._max_size:
                raise self._too_long(message, [b""], data)
            return data
        member = self._by_name.get(name, ())
        if not member:
            raise EncodeError(
                f"{name} is twice a payload type of {self._name}: build the envelope yourself "
                "to choose the member"
                if member is None
                else f"{name} is not a payload type of {self._name}"
            )
        headers, _, check, _ = member
        if check is not None:
            check(message)
        body = message.SerializeToString()
        if len(body) >= len(headers):
            raise self._too_long(message, headers, body)
        return headers[len(body)] + body

    def _too_long(self, message: Message, headers: list[bytes], body: bytes) -> EncodeError:
        """The error for a ``body`` too long to fit, ``headers`` being its member's (or ``[b""]``
        for a whole envelope)."""
        tag = max(len(headers[0]) - 1, 0)
        length = tag + (varint_size(len(body)) if tag else 0) + len(body)
        return EncodeError(
            f"{message.DESCRIPTOR.full_name}: the datagram would be {length} bytes, more than the "
            f"{self._max_size} a fixed-size receiver accepts (unknown fields from a newer sender?)"
        )

    # -- decoding ------------------------------------------------------------------------------

    def peek(self, data: bytes) -> tuple[str, bytes] | None:
        """The kind and exact payload bytes of a datagram in its usual shape (one member, with
        a tag of at most two bytes and a length of at most two, sent exact, stripped or
        zero-padded), found by arithmetic on its header, without parsing the payload; ``None``
        for any other datagram, which only the general decoder can judge."""
        size = len(data)
        if not 0 < size <= self._max_size:
            return None
        first = data[0]
        if first < 0x80:
            member = self._tags.get(first)
        else:
            member = self._tags.get(first | data[1] << 8) if size > 1 else None
        if member is None:
            return None
        kind, _, start = member
        if start == size:  # stripped: the length was a single zero byte
            return kind, b""
        length = data[start]
        if length < 0x80:
            start += 1
        elif start + 1 < size and data[start + 1] < 0x80:  # two-byte length (≤ 16383)
            length += (data[start + 1] << 7) - 0x80
            start += 2
        else:
            return None
        end = start + length
        if end == size:  # exact
            return kind, data[start:]
        if end < size:  # zero-padded, unless something other than zeros follows
            return (kind, data[start:end]) if data.count(0, end) == size - end else None
        if end <= self._max_size:  # stripped: the payload's last bytes were zeros
            return kind, data[start:] + bytes(end - size)
        return None

    def decode(self, data: bytes, strict: bool = False) -> Decoded:  # noqa: C901 - see below
        """The payload of a datagram in exact, stripped or zero-padded form; with ``strict``, a
        ``DecodeError`` too for what nanopb's decoder refuses (a missing required field, a
        string, bytes or array over its limit, a fixed-length field of the wrong size)."""
        if strict:
            return self._strict(data)
        # peek's arithmetic, written out here once more: the call to peek would cost a tenth of
        # a decode, and the decode target of benchmarks/bench_codec.py (exact datagrams in at
        # most 1.25x the bare runtime's time) has no tenth to spare. tests/test_envelope_decode.py
        # holds decode equal to peek and a parse, on every form and on hostile bytes.
        size = len(data)
        if not 0 < size <= self._max_size:
            return self._decode_envelope(data)  # raises the right error
        first = data[0]
        if first < 0x80:
            member = self._tags.get(first)
        else:
            member = self._tags.get(first | data[1] << 8) if size > 1 else None
        if member is None:
            return self._decode_envelope(data)
        kind, parse, start = member
        if start == size:  # stripped: the length was a single zero byte
            end = size
        else:
            length = data[start]
            if length < 0x80:
                start += 1
            elif start + 1 < size and data[start + 1] < 0x80:  # two-byte length (≤ 16383)
                length += (data[start + 1] << 7) - 0x80
                start += 2
            else:
                return self._decode_envelope(data)
            end = start + length
        if end == size:  # exact
            payload = data[start:]
        elif end < size:  # zero-padded, unless something other than zeros follows
            if data.count(0, end) != size - end:
                return self._decode_envelope(data)
            payload = data[start:end]
        elif end <= self._max_size:  # stripped: the payload's last bytes were zeros
            payload = data[start:] + bytes(end - size)
        else:
            return self._decode_envelope(data)
        try:
            return _decoded(Decoded, (kind, parse(payload)))
        except ProtobufDecodeError as error:
            raise DecodeError(
                f"datagram of {size} bytes: its {kind} payload of {len(payload)} bytes is "
                f"not a valid {self._payload_name(kind)}: {error}"
            ) from None

    def _strict(self, data: bytes) -> Decoded:
        decoded = self.decode(data)
        why = self._refusal(decoded.message) if self._refusal is not None else None
        if why is not None:
            raise DecodeError(f"nanopb's decoder refuses the {decoded.kind} payload: {why}")
        return decoded

    def _payload_name(self, kind: str) -> str:
        return message_of(descriptor_of(self._class).fields_by_name[kind]).full_name

    def _decode_envelope(self, data: bytes) -> Decoded:
        """The general path: restore the whole envelope, parse it, find the payload."""
        envelope = self._parse_restored(data)
        kind = envelope.WhichOneof(self._oneof)
        if kind is None:
            raise self._no_payload(data)
        return _decoded(Decoded, (kind, getattr(envelope, kind)))

    def _parse_restored(self, data: bytes) -> Message:
        if not data:
            raise DecodeError("empty datagram", "empty")
        if len(data) > self._max_size:
            raise DecodeError(
                f"datagram of {len(data)} bytes is longer than the envelope's maximum of "
                f"{self._max_size}: a fixed-size receiver drops it",
                "too_long",
            )
        data = bytes(data)
        exact = self._restore(data)
        try:
            return self._from_string(exact)
        except ProtobufDecodeError as error:
            form = "" if exact == data else " (after restoring its trailing zeros)"
            raise DecodeError(
                f"datagram of {len(data)} bytes is not a valid {self._name}{form}: {error}"
            ) from None

    def _restore(self, data: bytes) -> bytes:
        """The exact encoding of a datagram sent exact, stripped or zero-padded."""
        pos, end = 0, len(data)
        try:
            while pos < end:
                if data[pos] == 0:
                    return self._unpad(data, pos)
                field = next_field(data, pos, zeros_past_end=True)
                if field.wire_type in (SGROUP, EGROUP):
                    raise DecodeError(
                        f"field {field.number} uses wire type {field.wire_type} (a group), "
                        "which a proto3 envelope never contains"
                    )
                pos = field.end
        except WireError as error:
            raise DecodeError(f"truncated or corrupt datagram: {error}") from None
        if pos > self._max_size:
            raise DecodeError(
                f"restoring its stripped zeros makes the datagram {pos} bytes long, more than "
                f"the envelope's maximum of {self._max_size}"
            )
        return data + bytes(pos - end)

    def _unpad(self, data: bytes, pos: int) -> bytes:
        """Cut zero padding that starts at ``pos``; anything non-zero after it is corruption."""
        stray = len(data.rstrip(b"\0"))
        if stray > pos:
            first = next(i for i in range(pos, stray) if data[i])
            raise DecodeError(
                f"zero byte at offset {pos} ends the message, "
                f"but a non-zero byte follows at offset {first}"
            )
        return data[:pos]

    def _no_payload(self, data: bytes) -> DecodeError:
        exact = self._restore(bytes(data))
        if not exact:
            return DecodeError("datagram holds no payload (only zero bytes)", "no_payload")
        key, _ = read_varint(exact, 0)
        number, wire_type = key >> 3, key & 7
        if number in self._kinds:
            return DecodeError(
                f"payload number {number} ({self._kinds[number]}) arrived with wire type "
                f"{wire_type}, not 2 (length-delimited)"
            )
        return DecodeError(
            f"payload number {number} is not a member of {self._name} in this schema "
            "(sent by a newer schema?)",
            "unknown_member",
        )
