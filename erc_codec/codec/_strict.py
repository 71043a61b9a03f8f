"""What nanopb's decoder refuses in a message protobuf's runtime parsed, for ``strict`` decodes.

protobuf parses some messages a nanopb receiver built from the same schema refuses ("missing
required field", "string overflow", "bytes overflow", "array overflow", "incorrect fixed length
bytes size", "wrong size for fixed count field", "integer too large", "varint overflow", "wrong
wire type"). ``refusal`` names the first such field by its path, or returns ``None``. It is the
decode side of the fixed-size contract, a plain walk (strict decoding is asked for, not the fast
path): undeclared enum values and strings holding a NUL, which nanopb's decoder takes, are not
refused here. Fields are read as nanopb's generator types them (``Sizes.field_type``,
``repeated``, ``required``: ``type_override`` and ``label_override`` included).

Two walks: one over the parsed message (lengths, counts, fixed sizes), and one over the bytes,
for what the parse no longer shows. protobuf keeps the low 32 bits of a varint it reads into a
32-bit field, where nanopb 0.4.x (``pb_dec_varint``, 0.4.7 and 0.4.9.1 alike) refuses:
- any varint longer than ten bytes, or whose tenth byte is more than 1: "varint overflow";
- an unsigned field (uint32, uint64, an enum without negative values) whose 64-bit value does
  not fit its C type (32 bits, its ``int_size``; an enum's C type): "integer too large", so a
  negative int32 sign-extended on the wire is refused by a uint32 field;
- a sint32/sint64 whose zigzag-decoded 64-bit value does not fit its C type: likewise;
- an int32/int64 (an enum with negative values) narrower than 64 bits: its low 32 bits, read as
  an int32 (sign extension or not), must fit the C type; only an ``int_size`` narrower than 32
  bits refuses anything;
- a bool, read by ``pb_decode_varint32``: a value above 32 bits that is not a 32-bit value
  sign-extended to 64: "varint overflow".
The bytes walk also counts what the parse merges: a field nanopb holds as an array that
protobuf holds once (``label_override``) arrives as often as the sender wrote it ("array
overflow"); it sees which required fields arrived at all (a proto3 zero a sender did write
counts); a string or bytes value whose ``max_size`` leaves no room for any (a string's 0)
arrived at all ("string overflow", an empty one too); a packed array for a field nanopb holds
single is "wrong wire type"; and a group nanopb does not read (a field it leaves out,
``FT_IGNORE``, ``discard_deprecated``, or does not know) is "invalid wire_type":
``pb_skip_field`` cannot skip groups.
"""

from collections.abc import Iterator
from typing import Any

from google.protobuf.descriptor import Descriptor, FieldDescriptor
from google.protobuf.message import Message

from erc_schema import (
    I32,
    I64,
    LEN,
    SGROUP,
    VARINT,
    Sizes,
    WireError,
    descriptor_of,
    message_of,
    next_field,
)

__all__ = ["refusal"]

_T = FieldDescriptor
_FIXED_WIRE = {
    **dict.fromkeys((_T.TYPE_FIXED32, _T.TYPE_SFIXED32, _T.TYPE_FLOAT), I32),
    **dict.fromkeys((_T.TYPE_FIXED64, _T.TYPE_SFIXED64, _T.TYPE_DOUBLE), I64),
}
_LENGTH_DELIMITED = {_T.TYPE_STRING, _T.TYPE_BYTES, _T.TYPE_MESSAGE}


def refusal(sizes: Sizes, root: Descriptor, message: Message, data: bytes) -> str | None:
    """Why nanopb's decoder would refuse ``message``, naming the field; ``None`` if it takes it.

    ``data`` is the exact encoding of the datagram ``message`` was parsed from, a ``root``: the
    message itself, or the envelope that carries it (whose payload fields are then named from
    the payload's type, as the rest of a strict decode's errors name them)."""
    return _wire_refusal(sizes, root, data, message) or _parsed_refusal(sizes, message)


def _parsed_refusal(sizes: Sizes, message: Message) -> str | None:
    pending: list[tuple[Message, str]] = [(message, descriptor_of(type(message)).full_name)]
    while pending:
        current, path = pending.pop()
        for field in descriptor_of(type(current)).fields:
            if sizes.ignored(field):
                continue
            here = f"{path}.{field.name}"
            value = getattr(current, field.name)
            if field.is_repeated:
                why = _count(sizes, field, here, len(value)) or _keys(sizes, field, here, value)
                if why is not None:
                    return why
                items = value.values() if hasattr(value, "values") else value
                numbered = [(f"{here}[{j}]", item) for j, item in enumerate(items)]
            elif field.has_presence and not current.HasField(field.name):
                continue
            else:
                numbered = [(here, value)]
            for at, item in numbered:
                if isinstance(item, Message):
                    pending.append((item, at))
                else:
                    why = _value(sizes, field, at, item)
                    if why is not None:
                        return why
    return None


def _count(sizes: Sizes, field: FieldDescriptor, path: str, count: int) -> str | None:
    if not sizes.repeated(field):
        return None  # nanopb keeps the last of several: the bytes walk sees what it refuses
    limit = sizes.max_count(field)
    if limit is None:
        return None
    if count > limit:
        return f"{path} holds {count} items, more than its max_count {limit} (array overflow)"
    if count and count != limit and sizes.options(field).fixed_count:
        return f"{path} holds {count} items; fixed_count needs exactly {limit}"
    return None


def _keys(sizes: Sizes, field: FieldDescriptor, path: str, value: Any) -> str | None:
    """Why nanopb's decoder refuses a key of the map ``value`` (a key is a nanopb field too:
    "string overflow"); ``None`` for any other repeated field."""
    if not hasattr(value, "values"):
        return None
    key = message_of(field).fields_by_name["key"]
    return next(
        (why for name in value if (why := _value(sizes, key, f"{path} key {name!r}", name))),
        None,
    )


def _value(sizes: Sizes, field: FieldDescriptor, path: str, value: Any) -> str | None:
    if field.message_type is not None:  # a map entry's scalar value
        field = field.message_type.fields_by_name["value"]
    if field.type in (_T.TYPE_STRING, _T.TYPE_BYTES):
        length = len(value.encode("utf-8")) if isinstance(value, str) else len(value)
        limit = sizes.max_bytes(field)
        if limit is not None and limit < 0:
            return None  # no room for any value: the bytes walk refuses one that arrived
        if limit is not None and length > limit:
            return f"{path} is {length} bytes long, more than the {limit} allowed (overflow)"
        fixed = sizes.field_type(field) == _T.TYPE_BYTES and sizes.options(field).fixed_length
        if fixed and length not in (0, limit):  # nanopb reads an empty value as zeros
            return f"{path} is {length} bytes long; fixed_length needs exactly {limit}"
    return None  # an integer: the bytes walk reads it as nanopb does


# -- the bytes walk ------------------------------------------------------------------------------


def _wire_refusal(sizes: Sizes, root: Descriptor, data: bytes, message: Message) -> str | None:
    """What nanopb refuses in the bytes of ``root`` (see the module's docstring)."""
    payload = descriptor_of(type(message))
    # Messages still to walk: (type, start, end, path, whether its fields are an envelope's).
    pending: list[tuple[Descriptor, int, int, str, bool]] = [
        (root, 0, len(data), root.full_name, root is not payload)
    ]
    try:
        while pending:
            descriptor, start, end, path, envelope = pending.pop()
            why = _walk(sizes, descriptor, data, start, end, path, envelope, pending)
            if why is not None:
                return why
    except WireError:
        return None  # not well-formed: protobuf's parse, which took it, is not ours to judge
    return None


def _walk(
    sizes: Sizes,
    descriptor: Descriptor,
    data: bytes,
    start: int,
    end: int,
    path: str,
    envelope: bool,
    pending: list[tuple[Descriptor, int, int, str, bool]],
) -> str | None:
    """Walk one message's fields in ``data[start:end]``, queueing its submessages."""
    seen: dict[int, int] = {}  # field number -> items arrived
    pos = start
    while pos < end:
        span = next_field(data, pos)
        pos = span.end
        field = descriptor.fields_by_number.get(span.number)
        if field is None or sizes.ignored(field):
            if span.wire_type == SGROUP:  # pb_skip_field skips anything but a group
                at = f"{path} field {span.number}" if field is None else _path(field, path, False)
                return (
                    f"{at} arrived as a group (wire type 3), which nanopb leaves out but cannot "
                    "skip (invalid wire_type)"
                )
            continue  # nanopb skips what it does not know
        here = _path(field, path, envelope)
        kind = sizes.field_type(field)
        index = seen.get(span.number, 0)
        at = f"{here}[{index}]" if sizes.repeated(field) else here
        if kind in _LENGTH_DELIMITED:
            if span.wire_type != LEN:
                return f"{at} arrived with wire type {span.wire_type} (nanopb: wrong wire type)"
            seen[span.number] = index + 1
            limit = sizes.max_bytes(field) if kind != _T.TYPE_MESSAGE else None
            if limit is not None and limit < 0:
                room = (
                    "string overflow"  # char a[0]: not even the NUL fits
                    if kind == _T.TYPE_STRING and limit == -1
                    else "its C array has a negative size, which compiles nowhere"
                )
                return f"{at} arrived, but its max_size leaves no room for any value ({room})"
            if kind == _T.TYPE_MESSAGE and field.message_type is not None:
                inner = f"{field.message_type.full_name}" if envelope else at
                pending.append((field.message_type, span.value, span.end, inner, False))
            continue
        items = list(_items(field, kind, span, data, sizes.repeated(field)))
        if items and items[0] is None:
            return f"{at} arrived with wire type {span.wire_type} (nanopb: wrong wire type)"
        for offset, item in enumerate(items):
            assert item is not None
            why = _integer(sizes, field, kind, data, item)
            if why is not None:
                where = f"{here}[{index + offset}]" if sizes.repeated(field) else here
                return f"{where} = {why}"
        seen[span.number] = index + len(items)
    return _arrivals(sizes, descriptor, seen, path, envelope)


def _arrivals(
    sizes: Sizes, descriptor: Descriptor, seen: dict[int, int], path: str, envelope: bool
) -> str | None:
    """What nanopb refuses in how often each field of a walked message arrived."""
    for field in descriptor.fields:
        if sizes.ignored(field):
            continue
        arrived = seen.get(field.number, 0)
        here = _path(field, path, envelope)
        if sizes.required(field) and not arrived and not sizes.repeated(field):
            return f"{here} is required but missing (nanopb: missing required field)"
        count = sizes.max_count(field) if sizes.repeated(field) else None
        if count is None or field.is_repeated:
            continue  # a field protobuf repeats too: the parsed walk counts its items
        if arrived > count:
            return (
                f"{here} arrived {arrived} times, more than its max_count {count} (array overflow)"
            )
        if arrived and arrived != count and sizes.options(field).fixed_count:
            return f"{here} arrived {arrived} times; fixed_count needs exactly {count}"
    return None


def _path(field: FieldDescriptor, path: str, envelope: bool) -> str:
    """A field's path; an envelope's payload member is named by its type, as decode names it."""
    if envelope and field.message_type is not None:
        return field.message_type.full_name
    return f"{path}.{field.name}"


def _items(
    field: FieldDescriptor, kind: int, span: Any, data: bytes, repeated: bool
) -> Iterator[int | None]:
    """Where each value of one occurrence starts: one, or a packed array's each; ``None`` first
    when nanopb refuses the occurrence's wire type."""
    wire = _FIXED_WIRE.get(kind, VARINT)
    if span.wire_type == wire:
        yield span.value
        return
    if span.wire_type != LEN or not repeated:
        yield None
        return
    pos = span.value
    while pos < span.end:
        yield pos
        pos = _varint_end(data, pos) if wire == VARINT else pos + (4 if wire == I32 else 8)


def _varint_end(data: bytes, pos: int) -> int:
    while data[pos] & 0x80:
        pos += 1
    return pos + 1


def _integer(sizes: Sizes, field: FieldDescriptor, kind: int, data: bytes, pos: int) -> str | None:
    """What nanopb's decoder says of the varint at ``pos`` read into ``field``, if it refuses."""
    if kind in _FIXED_WIRE:
        return None
    raw, length = _raw_varint(data, pos)
    if length > 10 or (length == 10 and data[pos + 9] > 1):
        return f"a varint of {length} bytes ({data[pos : pos + length].hex()}) (varint overflow)"
    if kind == _T.TYPE_BOOL:
        return None if _fits_varint32(data, pos, length) else f"{raw} (varint overflow)"
    stored = sizes.c_integer(field)
    if stored is None:
        return None
    family, bits = stored
    raw &= 2**64 - 1
    if family == "unsigned":
        fits = raw < 2**bits
        value = raw
    elif family == "zigzag":
        value = (raw >> 1) ^ -(raw & 1)
        fits = -(2 ** (bits - 1)) <= value < 2 ** (bits - 1)
    else:
        value = raw - 2**64 if raw >= 2**63 else raw
        if bits < 64:
            low = raw & 0xFFFFFFFF
            value = low - 2**32 if low >= 2**31 else low
        fits = -(2 ** (bits - 1)) <= value < 2 ** (bits - 1)
    if fits:
        return None
    c_type = f"{'u' if family == 'unsigned' else ''}int{bits}_t"
    return f"{value} does not fit nanopb's {c_type} (integer too large)"


def _raw_varint(data: bytes, pos: int) -> tuple[int, int]:
    """A varint's value (every bit, not cut to 64) and its length in bytes."""
    value = shift = length = 0
    while True:
        byte = data[pos + length]
        value |= (byte & 0x7F) << shift
        shift += 7
        length += 1
        if byte < 0x80:
            return value, length


def _fits_varint32(data: bytes, pos: int, length: int) -> bool:
    """Whether ``pb_decode_varint32`` takes the varint: at most 32 bits, or a 32-bit value with
    bit 31 set sign-extended (its fifth byte ``0x78`` bits set, then ``ff`` bytes and ``01``)."""
    if length >= 5:
        fifth = data[pos + 4]
        if fifth & 0x70 and fifth & 0x78 != 0x78:
            return False
    negative = length >= 5 and bool(data[pos + 4] & 0x08)
    for index in range(5, length):
        byte = data[pos + index]
        extension = 0xFF if index < 9 else 0x01
        if byte & 0x7F and not (negative and byte == extension):
            return False
    return True
