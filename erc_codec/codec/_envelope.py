"""PBEnvelope wrap/unwrap in three transmission forms: exact, stripped and zero-padded.

What this module guarantees:
- ``encode`` produces exactly the bytes protobuf (and nanopb) would for the envelope, then strips
  or pads trailing zeros.
- ``encode`` never lets through what a fixed-size receiver would drop.
- ``encode`` never produces a datagram ``decode`` refuses.
- ``decode`` accepts the exact, the stripped and the zero-padded form of an envelope, and returns
  the same message for all three.
- ``decode`` takes any bytes-like object; a ``str`` is a ``TypeError``.
- ``decode`` restores only zeros some encoder could have written. A restoration that gives a field
  without presence its default is a datagram cut short, reason ``truncated`` (see
  ``_truncation``).
- Fields the schema does not know are kept and listed: the payload's, and those beside it on the
  envelope (``Decoded.envelope_unknown_fields``, whose path is the envelope's name).
  ``reencode`` sends both on.
- Every failure is a ``DecodeError`` or ``EncodeError`` saying what and where (offset, field
  path).

Restoring a stripped form: it loses only zeros of the value of the last top-level field. So
restoring them takes one walk over the top-level fields (one, in an envelope):
- bytes past the end count as zeros for as long as that field needs;
- a zero byte where a tag is expected ends the message, provided nothing but zeros follows it.

Both directions run per datagram, so the common case is the protobuf call plus a few byte
operations.

Encoding looks the payload class up in a dict. It prepends a precomputed tag-and-length header to
the payload's own serialization. In the default form (stripped, no metadata), one function
compiled per payload class does all of it, with the contract's check inline
(``_contract.sender``).

Decoding reads that header itself (``peek``: tag → kind, length → where the payload ends), so
protobuf parses only the payload bytes:
- a stripped datagram gets its missing zeros appended, by arithmetic, before the one parse;
- a padded datagram is cut, by arithmetic, before the one parse;
- only a datagram whose zeros were restored has its parse serialized again;
- only when that serialization differs from the restored bytes is the payload walked for a cut
  field.

Datagrams of any other shape (several top-level fields, unknown members, corruption) take the
general path. It is the repair walk over the whole envelope, then the envelope parse, as
``_forms`` does them for any root. Only the general path can meet unknown fields beside the
payload. The fast path takes only a datagram that is one member field and nothing else, so the
usual datagram pays nothing for them.

Metadata is the fields an envelope declares beside its oneof (the rover's ``timeout``):
- they are encoded on request (``encode(message, timeout=300)``);
- they are returned on ``Decoded.metadata``;
- a datagram carrying one has a last field that is not the payload, so it takes the general path;
- that path's walk treats every top-level field alike, so stripping, padding and restoring need
  nothing new;
- a datagram without metadata (the usual one) decodes as it would with no metadata declared.
"""

from collections.abc import Callable, Mapping, Sequence
from types import MappingProxyType
from typing import Any, NamedTuple, cast

from google.protobuf.descriptor import Descriptor, FieldDescriptor, OneofDescriptor
from google.protobuf.message import DecodeError as ProtobufDecodeError
from google.protobuf.message import EncodeError as ProtobufEncodeError
from google.protobuf.message import Message

from erc_schema import (
    LEN,
    DecodeError,
    EncodeError,
    SchemaError,
    UnreadableKind,
    WireError,
    descriptor_of,
    encode_varint,
    message_of,
    next_field,
    varint_size,
)

from ._contract import Contract, sender
from ._foreign import Foreign
from ._forms import Forms, Mode, as_bytes, cut_short, in_form, strict_error
from ._truncation import Table, cut_reason, presence_table
from ._unknown import UnknownField, own_unknown_fields, unknown_fields

__all__ = ["Decoded", "Envelope", "Mode", "is_envelope"]

_Tag = tuple[str, Callable[[bytes], Message], int]
_Member = tuple[
    list[bytes],
    Callable[[bytes], object] | None,
    Callable[[Message], None] | None,
    Callable[[Message], bytes],
]


_NO_METADATA: Mapping[str, object] = MappingProxyType({})
# Why a message (through the given fields of it, or all) cannot be encoded or decoded as nanopb
# does, or None: ``_sendable.unsendable``.
Unsendable = Callable[[Descriptor, Sequence[FieldDescriptor] | None], str | None]


class _Payload(NamedTuple):
    kind: str
    message: Message


class Decoded(_Payload):
    """A decoded datagram: the oneof member name (``kind``) and the payload message.

    It unpacks as ``kind, message = codec.decode(data)``. It also carries the envelope's metadata
    and the fields the envelope itself carried that the schema does not know.

    - ``metadata`` maps each field outside the envelope's oneof that the datagram carried to its
      value. A field holding 0 is never sent, so a missing one is 0. It is an attribute, not a
      third item, so two-name unpacking keeps working. Equality compares kind and message only.
    - ``timeout`` is the rover envelope's ``timeout`` in milliseconds; 0 means not sent, or not
      declared.
    - ``envelope_unknown_fields`` are the unknown fields beside the payload, on the envelope
      itself; their ``path`` is the envelope's name, ``codec.root``. They are a cheap test:
      ``()`` for a datagram of this schema.
    - ``envelope`` is the envelope message where decode parsed the whole envelope, which it does
      for a datagram carrying more than its payload (metadata, unknown fields beside it). It is
      ``None`` where decode parsed the payload alone.

    ``codec.reencode(decoded)`` sends on all of it.
    """

    metadata: Mapping[str, object] = _NO_METADATA
    envelope_unknown_fields: tuple[UnknownField, ...] = ()
    envelope: Message | None = None

    @property
    def timeout(self) -> int:
        """The sender's advertised timeout in milliseconds; 0 when it sent none."""
        value = self.metadata.get("timeout", 0)
        return value if isinstance(value, int) else 0

    @property
    def unknown_fields(self) -> tuple[UnknownField, ...]:
        """The fields the datagram carried that this schema does not know (none, normally):
        the envelope's own first (``envelope_unknown_fields``), then the payload's."""
        return self.envelope_unknown_fields + unknown_fields(self.message)

    def to_dict(self) -> dict[str, Any]:
        """The datagram as ``erc-codec decode`` prints it, without its ``length``.

        - ``kind``.
        - ``message``, in protobuf's JSON mapping (``Codec.to_dict``).
        - ``metadata``, if the datagram carried any: the envelope's fields beside its payload
          (``timeout`` ...), in the same mapping.
        - ``unknown_fields``, if the datagram carried any: ``path``, ``number`` and ``wire_type``
          each.
        """
        from ._json import to_dict

        record: dict[str, Any] = {"kind": self.kind, "message": to_dict(self.message)}
        if self.metadata and self.envelope is not None:
            whole = to_dict(self.envelope)
            record["metadata"] = {name: whole[name] for name in self.metadata}
        unknown = self.unknown_fields
        if unknown:
            record["unknown_fields"] = [field._asdict() for field in unknown]
        return record

    def to_json(self) -> str:
        """``to_dict()`` as one line of JSON text."""
        import json

        return json.dumps(self.to_dict())

    def __repr__(self) -> str:
        shown = super().__repr__()
        return f"{shown[:-1]}, metadata={dict(self.metadata)!r})" if self.metadata else shown


# Builds a Decoded without NamedTuple's Python-level __new__, for the decode target of
# benchmarks/bench_codec.py (decode <= 1.25x the bare runtime); tests/codec/test_codec.py holds it
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
        refusal: Callable[[Message, bytes], str | None] | None = None,
        unsendable: Unsendable | None = None,
    ) -> None:
        """``unsendable`` says which members (or the envelope itself) cannot be encoded or
        decoded as nanopb does.

        Those members are left out of every table. Encoding or decoding them is a
        ``SchemaError`` saying why. Every other member works.
        """
        descriptor = descriptor_of(envelope)
        self._refusal = refusal  # what nanopb's decoder refuses, for strict decodes
        oneofs = [oneof for oneof in descriptor.oneofs if not _synthetic(oneof)]
        if len(oneofs) != 1:
            raise SchemaError(
                f"{descriptor.full_name} must have exactly one oneof, whose members are the "
                "payload types (and may have metadata fields beside it)"
            )
        members = oneofs[0].fields
        # Metadata: every field outside the oneof, a singular scalar, enum or string.
        self._metadata = {
            field.name: field
            for field in descriptor.fields
            if field.containing_oneof is not oneofs[0]
        }
        for field in self._metadata.values():
            if field.message_type is not None or field.is_repeated:
                raise SchemaError(
                    f"{field.full_name}: beside its one oneof, an envelope may only have metadata "
                    "fields, each a single scalar (a number, bool, enum or string)"
                )
        self._name = descriptor.full_name
        # Why nothing of the envelope can be sent (itself, or a metadata field, is the trouble);
        # kind -> why it cannot be sent or received; payload full name -> why.
        self._whole, self._blocked, self._blocked_types = _blocked(
            descriptor, members, list(self._metadata.values()), unsendable
        )
        self._class = envelope
        self._from_string = envelope.FromString
        self._oneof = descriptor.oneofs[0].name
        self._max_size = max_size
        self._kinds = {field.number: field.name for field in members}
        self._contracts: dict[str, Contract | None] = {}
        # Payload class → (tag-and-length header for each payload length that fits, contract
        # screen and check, serializer); None marks a type two members share, which cannot be
        # wrapped without naming the member. The serializer is the class's own method: looking
        # it up on each instance costs more in upb than serializing a small message does.
        self._members: dict[type[Message], _Member | None] = {}
        # Payload class → its stripped datagram in one function (``_contract.sender``), for the
        # classes ``_members`` has a member of.
        self._senders: dict[type[Message], Callable[[Message], bytes]] = {}
        # First tag byte (or first | second << 8 for two-byte tags) → (kind, the payload class's
        # parser, offset of the length prefix). ``_first`` holds the one-byte tags' again, by
        # index: a list lookup spares decode a method call (see decode).
        self._tags: dict[int, _Tag] = {}
        self._first: list[_Tag | None] = [None] * 256
        self._payloads: dict[str, type[Message]] = {}  # kind → payload class
        # What judging restored zeros takes: the envelope's forms (general path: restoring,
        # parsing and the cut check, shared with plain roots), and per kind the payload's
        # serializer and presence table (fast path), all tables built once.
        tables: dict[str, Table] = {}
        self._forms = Forms(
            envelope, max_size, "the envelope's", groups=False, inside=True, tables=tables
        )
        self._restoring: dict[str, tuple[Callable[[Message], bytes], Table]] = {}
        for field in members:
            payload = field.message_type
            if payload is None:
                raise SchemaError(f"{field.full_name} must be a message, not a scalar")
            if field.name in self._blocked:
                continue  # in no table: encode and decode find it blocked on the general path
            rules = self._contracts[field.name] = contract(payload)
            tag = encode_varint(field.number << 3 | LEN)
            headers = [
                tag + encode_varint(length)
                for length in range(max_size)
                if len(tag) + varint_size(length) + length <= max_size
            ]
            cls = _member_class(envelope, field.name)
            screen, check = (rules.screen, rules.check) if rules else (None, None)
            shared = cls in self._members
            self._members[cls] = None if shared else (headers, screen, check, cls.SerializeToString)
            if shared:
                self._senders.pop(cls, None)
            else:
                self._senders[cls] = sender(rules, cls.SerializeToString, headers)
            self._payloads[field.name] = cls
            # Partial: a proto2 payload missing a required field decodes (protobuf parses it), and
            # the comparison with its restored bytes must not raise where the parse did not.
            self._restoring[field.name] = (
                cls.SerializePartialToString,
                presence_table(payload, tables),
            )
            if len(tag) <= 2:
                self._tags[int.from_bytes(tag, "little")] = (field.name, cls.FromString, len(tag))
            if len(tag) == 1:
                self._first[tag[0]] = self._tags[tag[0]]
        self._by_name = {cls.DESCRIPTOR.full_name: member for cls, member in self._members.items()}
        for name in self._by_name:
            self._blocked_types.pop(name, None)  # also another, unblocked member's type
        # The verdicts on classes built elsewhere that encode is given.
        self._foreign = Foreign([envelope, *self._members])

    def kinds(self) -> dict[int, str]:
        """The envelope's payload members: field number → member name (a decoded ``kind``)."""
        return dict(self._kinds)

    def metadata_fields(self) -> dict[int, str]:
        """The envelope's metadata fields (those beside its oneof): field number → name."""
        return {field.number: name for name, field in self._metadata.items()}

    def _root_class(self) -> type[Message]:
        """The envelope's class; ``SchemaError`` where none of it can be sent."""
        if self._whole is not None:
            raise SchemaError(self._whole)
        return self._class

    def payload_class(self, kind: str) -> type[Message]:
        """The message class member ``kind`` carries."""
        try:
            return self._payloads[kind]
        except KeyError:
            why = self._blocked.get(kind)
            if why is not None:
                raise SchemaError(why) from None
            raise SchemaError(f"{kind!r} is not a payload kind of {self._name}") from None

    # -- encoding ------------------------------------------------------------------------------

    def encode(self, message: Message, mode: Mode = "strip", /, **metadata: object) -> bytes:
        """The datagram carrying ``message`` (a payload, or a whole envelope) in ``mode``.

        Each keyword names an envelope metadata field and sets it to its value (``timeout=300``).
        ``mode=`` as a keyword is the mode, as in 0.1.0, unless the envelope has a metadata field
        so named.
        """
        if metadata and "mode" in metadata and "mode" not in self._metadata:
            if mode != "strip":
                raise TypeError(
                    f"encode got the mode twice: {mode!r} and mode={metadata['mode']!r}"
                )
            mode = cast(Mode, metadata.pop("mode"))
        if mode == "strip" and not metadata:
            # The usual call in one compiled function per payload class (bench_codec's encode
            # target; tests/codec/test_contract.py holds it to the plain path below).
            try:
                return self._senders[type(message)](message)
            except (KeyError, IndexError, ProtobufEncodeError):
                pass  # no payload class, too long, a required field unset: the plain path's
        return self._encode(message, mode, metadata)

    def _encode(self, message: Message, mode: Mode, metadata: Mapping[str, object]) -> bytes:
        """``encode`` the plain way: every form, metadata, and the errors in its own words."""
        if metadata:
            exact = self._with_metadata(self.encode(message, "exact"), metadata)
            return in_form(exact, mode, self._max_size)
        member = self._members.get(type(message))
        if member is None:
            return self._encode_other(message, mode)
        headers, screen, check, serialize = member
        try:
            body = serialize(message)
        except ProtobufEncodeError:  # an unset proto2 required field: the check names it
            # No check, or one that passes: nanopb does not require it (label_override), and
            # the contract, which asks nanopb's field model, has a check wherever it requires one.
            if check is not None:
                check(message)
            body = message.SerializePartialToString()
        if check is not None and (screen is None or screen(body)):
            check(message)
        try:
            header = headers[len(body)]
        except IndexError:
            raise self._too_long(message, headers, body) from None
        return in_form(header + body, mode, self._max_size)

    def reencode(self, decoded: Decoded, mode: Mode = "strip") -> bytes:
        """The datagram ``decoded`` (what ``decode`` returned) came from, in ``mode``.

        It carries the payload, the metadata and the fields the schema does not know, those
        beside the payload included. Each is as protobuf kept it, byte for byte: what a relay
        sends on. A payload changed since the decode is sent as it is now.
        """
        if not isinstance(decoded, Decoded):
            raise TypeError(
                f"reencode takes what decode returned (a Decoded), not {type(decoded).__name__}"
            )
        if decoded.envelope is None:
            return self.encode(decoded.message, mode, **decoded.metadata)
        return self.encode(decoded.envelope, mode)

    def _encode_other(self, message: Message, mode: Mode) -> bytes:
        """An envelope, a payload of a class built elsewhere (generated code of the same
        schema), or an error: a class of another schema is refused, not encoded by its name."""
        if not isinstance(message, Message):
            raise TypeError(
                f"encode takes a protobuf message (a payload of {self._name}, or one), not "
                f"{type(message).__name__}"
            )
        name = message.DESCRIPTOR.full_name
        refused = self._foreign.refusal(type(message))
        if refused is not None:
            raise refused
        if self._whole is not None:
            raise SchemaError(self._whole)
        if name == self._name:
            return self._encode_envelope(message, mode)
        member = self._by_name.get(name, ())
        if not member and name in self._blocked_types:
            raise SchemaError(self._blocked_types[name])
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
        body = message.SerializePartialToString()  # required fields: the check's, as nanopb's
        if len(body) >= len(headers):
            raise self._too_long(message, headers, body)
        return in_form(headers[len(body)] + body, mode, self._max_size)

    def _encode_envelope(self, message: Message, mode: Mode) -> bytes:
        """A whole envelope (of this schema's class or an equal one), checked and in ``mode``."""
        kind = message.WhichOneof(self._oneof)
        if kind is None:
            raise EncodeError(f"{self._name} has no payload set")
        if kind in self._blocked:
            raise SchemaError(self._blocked[kind])
        rules = self._contracts[kind]
        if rules is not None:
            rules.check(getattr(message, kind))
        data = message.SerializePartialToString()  # required fields: the check's, as nanopb's
        if len(data) > self._max_size:
            raise self._too_long(message, [b""], data)
        datagram = in_form(data, mode, self._max_size)
        # An envelope parsed from bytes keeps the fields this schema does not know, and some
        # (a group at the top level) are what decode refuses: never send those.
        try:
            self.decode(datagram)
        except DecodeError as error:
            raise EncodeError(
                f"{self._name} cannot be sent: its own decoder would refuse the datagram "
                f"({error}; unknown fields from a newer sender?)"
            ) from None
        return datagram

    def _with_metadata(self, exact: bytes, metadata: Mapping[str, object]) -> bytes:
        """The exact datagram ``exact`` with ``metadata`` set: protobuf writes every field in
        number order, metadata before or after the payload alike."""
        envelope = self._from_string(exact)
        for name, value in metadata.items():
            if name not in self._metadata:
                declared = ", ".join(self._metadata) or "none"
                raise EncodeError(
                    f"{self._name} has no metadata field {name!r} (its metadata fields: {declared})"
                )
            try:
                setattr(envelope, name, value)
            except (TypeError, ValueError) as error:
                raise EncodeError(f"{self._name}.{name} cannot be {value!r}: {error}") from None
        data = envelope.SerializePartialToString()  # the payload is checked: encode did
        if len(data) > self._max_size:
            raise self._too_long(envelope, [b""], data)
        return data

    def _too_long(self, message: Message, headers: list[bytes], body: bytes) -> EncodeError:
        """The error for a ``body`` too long to fit, ``headers`` being its member's (or ``[b""]``
        for a whole envelope)."""
        tag = max(len(headers[0]) - 1, 0)
        length = tag + (varint_size(len(body)) if tag else 0) + len(body)
        return self._forms.oversize(message.DESCRIPTOR.full_name, length)

    # -- decoding ------------------------------------------------------------------------------

    def peek(self, data: bytes) -> tuple[str, bytes] | None:
        """The kind and exact payload bytes of a datagram in its usual shape, found by arithmetic
        on its header.

        The usual shape is one member, with a tag of at most two bytes and a length of at most
        two, sent exact, stripped or zero-padded. Any other datagram is ``None``: only the general
        decoder can judge it. A cut datagram (see ``decode``) is ``None`` too. Only a datagram
        whose zeros were restored has its payload parsed, to tell stripped from cut.
        """
        if type(data) is not bytes:
            data = as_bytes(data)
        size = len(data)
        if not 0 < size <= self._max_size:
            return None
        first = data[0]
        member = self._first[first]
        if member is None:
            member = self._tags.get(first | data[1] << 8) if first >= 0x80 and size > 1 else None
            if member is None:
                return None
        kind, parse, start = member
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
            payload = data[start:] + bytes(end - size)
            try:
                message = parse(payload)
            except ProtobufDecodeError:
                return kind, payload  # not a payload at all: its parse says what is wrong
            cut = self._restored_cut(kind, payload, message, size - start)
            return None if cut else (kind, payload)
        return None

    def decode(self, data: bytes, strict: bool = False) -> Decoded:  # noqa: C901
        """The payload of a datagram in exact, stripped or zero-padded form.

        ``data`` is bytes or any bytes-like object (``bytearray``, ``memoryview``).

        Restored zeros that give a field without presence its default are a datagram cut short:
        no proto3 encoder sends that. It is a ``DecodeError`` with reason ``"truncated"``.

        Fields the schema does not know are kept (``Decoded.unknown_fields``).

        With ``strict``, decoding refuses more:
        - fields the schema does not know are a ``DecodeError`` with reason ``"unknown_fields"``;
        - what nanopb's decoder refuses is a ``DecodeError`` too (reason ``"corrupt"``): a missing
          required field, a string, bytes or array over its limit, a fixed-length field of the
          wrong size.
        """
        if strict:
            return self._decode_strict(data)
        # peek's arithmetic, written out here once more: the call to peek would cost a tenth of a
        # decode, and the decode target of benchmarks/bench_codec.py (exact datagrams in at most
        # 1.25x the bare runtime's time) has no tenth to spare. tests/codec/test_envelope_decode.py
        # holds decode equal to peek and a parse, on every form and on hostile bytes.
        if type(data) is not bytes:
            data = as_bytes(data)
        size = len(data)
        if not 0 < size <= self._max_size:
            return self._decode_envelope(data)  # raises the right error
        first = data[0]
        member = self._first[first]
        if member is None:
            member = self._tags.get(first | data[1] << 8) if first >= 0x80 and size > 1 else None
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
            return self._decode_stripped(data, kind, parse, start, end)
        else:
            return self._decode_envelope(data)
        try:
            return _decoded(Decoded, (kind, parse(payload)))
        except ProtobufDecodeError as error:
            raise self._invalid(data, kind, payload, error) from None

    def _decode_strict(self, data: bytes) -> Decoded:
        if type(data) is not bytes:
            data = as_bytes(data)
        decoded = self.decode(data)
        error = strict_error(
            len(data),
            decoded.message,
            self._forms.restore(data),  # what nanopb reads: the exact bytes, the envelope's
            f"{decoded.kind} payload",
            self._refusal,
            decoded.envelope_unknown_fields,
        )
        if error is not None:
            raise error
        return decoded

    def _decode_stripped(
        self, data: bytes, kind: str, parse: Callable[[bytes], Message], start: int, end: int
    ) -> Decoded:
        """The payload at ``data[start:end]``, whose zeros past the end are restored, unless
        restoring them makes what no encoder sends."""
        payload = data[start:] + bytes(end - len(data))
        try:
            message = parse(payload)
        except ProtobufDecodeError as error:
            raise self._invalid(data, kind, payload, error) from None
        cut = self._restored_cut(kind, payload, message, len(data) - start)
        if cut:
            raise cut_short(data, cut)
        return _decoded(Decoded, (kind, message))

    def _restored_cut(self, kind: str, payload: bytes, message: Message, boundary: int) -> str:
        """What a restoration of ``payload``'s zeros from offset ``boundary`` on makes that no
        encoder sends (see ``_truncation``), or ``""`` when it is a stripped payload.

        Protobuf serializes no field without presence at its default, nor a varint that ends
        in ``80 00``, so a payload that serializes back to itself has neither, and most are
        spared the walk.
        """
        serialize, table = self._restoring[kind]
        return cut_reason(table, payload, message, boundary, serialize(message) == payload)

    def _invalid(
        self, data: bytes, kind: str, payload: bytes, error: ProtobufDecodeError
    ) -> DecodeError:
        name = message_of(descriptor_of(self._class).fields_by_name[kind]).full_name
        return DecodeError(
            f"datagram of {len(data)} bytes: its {kind} payload of {len(payload)} bytes is "
            f"not a valid {name}: {error}"
        )

    def _decode_envelope(self, data: bytes) -> Decoded:
        """The general path: restore the whole envelope, parse it, find the payload."""
        if self._whole is not None:
            raise UnreadableKind(self._whole)
        try:
            envelope = self._parse_restored(data)
        except DecodeError:
            blocked = self._blocked_first(data)  # protobuf's group for a DELIMITED member, say
            if blocked is not None:
                raise UnreadableKind(self._blocked[blocked], blocked) from None
            raise
        kind = envelope.WhichOneof(self._oneof)
        if kind is None:
            raise self._no_payload(data)
        if kind in self._blocked:
            raise UnreadableKind(self._blocked[kind], kind)
        decoded = _decoded(Decoded, (kind, getattr(envelope, kind)))
        decoded.envelope = envelope
        outside = own_unknown_fields(envelope, self._name)
        if outside:
            decoded.envelope_unknown_fields = outside
        if self._metadata:
            carried = {
                field.name: value
                for field, value in envelope.ListFields()
                if field.name in self._metadata
            }
            if carried:
                decoded.metadata = MappingProxyType(carried)
        return decoded

    def _blocked_first(self, data: bytes) -> str | None:
        """The member the datagram's first field is, if it is blocked (cannot be received)."""
        if not self._blocked or not data or not data[0]:
            return None
        try:
            number = next_field(data, 0, zeros_past_end=True).number
        except WireError:
            return None
        kind = self._kinds.get(number, "")
        return kind if kind in self._blocked else None

    def _parse_restored(self, data: bytes) -> Message:
        if not data:
            raise DecodeError("empty datagram", "empty")
        return self._forms.parse(data)

    def _no_payload(self, data: bytes) -> DecodeError:
        exact = self._forms.restore(data)
        if not exact:
            return DecodeError("datagram holds no payload (only zero bytes)", "no_payload")
        number, wire_type, _, _ = next_field(exact, 0)  # it parsed: its first field is whole
        if number in self.metadata_fields():
            return DecodeError(
                f"datagram holds metadata ({self.metadata_fields()[number]}) but no payload",
                "no_payload",
            )
        if self._kinds.get(number) in self._blocked:  # nanopb's bytes for a DELIMITED member
            return UnreadableKind(self._blocked[self._kinds[number]], self._kinds[number])
        if number in self._kinds:
            return DecodeError(
                f"payload number {number} ({self._kinds[number]}) arrived with wire type "
                f"{wire_type}, not {LEN} (length-delimited)"
            )
        return DecodeError(
            f"payload number {number} is not a member of {self._name} in this schema "
            "(sent by a newer schema?)",
            "unknown_member",
        )


def _blocked(
    envelope: Descriptor,
    members: Sequence[FieldDescriptor],
    metadata: Sequence[FieldDescriptor],
    unsendable: Unsendable | None,
) -> tuple[str | None, dict[str, str], dict[str, str]]:
    """Why nothing of ``envelope`` can be sent (``None``: something can), why each blocked
    member cannot (by kind, the first reason under every kind), and the same by payload type."""
    whole = None if unsendable is None else unsendable(envelope, metadata)
    kinds: dict[str, str] = {}
    types: dict[str, str] = {}
    for field in members:
        why = whole or (None if unsendable is None else unsendable(envelope, [field]))
        if why is not None:
            kinds[field.name] = why
            if field.message_type is not None:
                types.setdefault(field.message_type.full_name, why)
    return whole, kinds, types


def is_envelope(descriptor: Descriptor) -> bool:
    """Whether a message is an envelope: one oneof (protoc's own for a proto3 ``optional`` aside)
    whose members are messages, and beside it only metadata: single scalars, enums or strings."""
    oneofs = [oneof for oneof in descriptor.oneofs if not _synthetic(oneof)]
    if len(oneofs) != 1 or not oneofs[0].fields:
        return False
    return all(
        field.message_type is not None
        if field.containing_oneof is oneofs[0]
        else field.message_type is None and not field.is_repeated
        for field in descriptor.fields
    )


def _synthetic(oneof: OneofDescriptor) -> bool:
    """Whether ``oneof`` is the one protoc makes for a proto3 ``optional`` field."""
    fields = oneof.fields
    return len(fields) == 1 and oneof.name == f"_{fields[0].name}" and fields[0].has_presence
