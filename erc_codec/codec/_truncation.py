"""Telling a stripped datagram from a cut one: which restored zeros a sender could have written.

A stripped datagram lost the zeros at the end of its encoding, and they all belong to the last field
at every level of nesting (protobuf writes a message's fields in number order): the last top-level
field, and when that is a submessage, its last field, and so on down. Restoring them is right only
when some encoder could have written the result, and two results no encoder writes:

- a field with implicit presence holding its default (0, 0.0, false, the first enum value, an
  empty string or bytes value, an empty packed list): Google's and nanopb's proto3 encoders leave
  those out, so restoring one turns a cut-off ``fix_quality = DGPS_FIX`` into ``NO_FIX``;
- a varint ending in a restored zero after a continuation byte (``a0`` + ``00``): every encoder
  writes varints in their shortest form, so the byte that made it ``a0 01`` was cut off.

What this module guarantees: ``cut_field(table, data, pos, end)`` finds the first case, exactly
when the deepest last field of ``data[pos:end]`` holds such a default (read as protobuf's parser
stores it: a 32-bit field keeps the low 32 bits of its varint); ``varint_cut`` the second, for
any byte of ``data``; ``cut_reason`` asks both of a restored datagram and says which field, by
its full path from the payload type (``LimitsRecord.places[key=7].x``), holds what no encoder
sends. ``table`` is ``presence_table`` of the type the bytes encode. Both walks judge only fields
the schema declares, as protobuf re-serializes only those: a field it does not know
travels as it came, and what some relay passes on is no proof of a cut. Everything genuinely
ambiguous passes: a present empty submessage (an all-default payload is one), a field with
explicit presence (oneof members, proto3 ``optional``, proto2 fields: their zero is sent), a
fixed-width value whose high bytes are zero but not all of them, a string or bytes value ending
in zeros, an item of a repeated field or a map entry's key or value (their zeros are sent too).

Both walks are linear in the bytes and run only where zeros were restored and protobuf's own
re-serialization differs from the restored bytes (see ``Envelope``): what protobuf or nanopb
wrote never gets here.
"""

from typing import Any

from google.protobuf.descriptor import Descriptor, FieldDescriptor
from google.protobuf.message import Message
from google.protobuf.message_factory import GetMessageClass

from erc_schema import (
    I32,
    I64,
    LEN,
    VARINT,
    FieldSpan,
    WireError,
    enum_of,
    message_of,
    next_field,
    read_varint,
)

from ._fieldpaths import entry_path

__all__ = ["Chain", "Table", "cut_field", "cut_reason", "presence_table", "varint_cut"]

_T = FieldDescriptor
# What a table entry asks of a field's last value: a varint whose bits under the mask are all
# zero, a fixed-width value of zero bytes only, an empty length-delimited value; a submessage to
# walk into; nothing (a field whose zero is sent, known so that its varints are judged).
_VARINT, _FIXED, _EMPTY, _NESTED, _SENT = range(5)
_MASK_32, _MASK_64 = 2**32 - 1, 2**64 - 1
_WIRE_TYPES = {
    **dict.fromkeys((_T.TYPE_FLOAT, _T.TYPE_FIXED32, _T.TYPE_SFIXED32), I32),
    **dict.fromkeys((_T.TYPE_DOUBLE, _T.TYPE_FIXED64, _T.TYPE_SFIXED64), I64),
    **dict.fromkeys((_T.TYPE_STRING, _T.TYPE_BYTES), LEN),
}
_WIDE = {_T.TYPE_INT64, _T.TYPE_UINT64, _T.TYPE_SINT64, _T.TYPE_BOOL}  # bool: any bit set

# tag key (number << 3 | wire type) → (what to ask, mask or inner table, the field)
Table = dict[int, tuple[int, Any, FieldDescriptor]]
# the fields from the walked type down to the one cut: (field, start, end of its value)
Chain = list[tuple[FieldDescriptor, int, int]]


def presence_table(descriptor: Descriptor, memo: dict[str, Table] | None = None) -> Table:
    """What the walks need to know of ``descriptor``'s fields, looked up by tag key: every
    form each field may arrive in (a repeated scalar packed or not)."""
    memo = {} if memo is None else memo
    name = descriptor.full_name
    if name in memo:
        return memo[name]
    table: Table = {}
    memo[name] = table  # stored first: a type may contain itself
    entry = descriptor.GetOptions().map_entry  # a map entry's key and value are sent when zero
    for field in descriptor.fields:
        key = field.number << 3
        wire = _WIRE_TYPES.get(field.type, VARINT)
        if field.type == _T.TYPE_MESSAGE:
            table[key | LEN] = (_NESTED, presence_table(message_of(field), memo), field)
        elif field.type == _T.TYPE_GROUP:
            continue  # proto2 only, explicitly present, and no varint of its own
        elif field.is_repeated:
            table[key | wire] = (_SENT, None, field)
            if wire != LEN:
                table[key | LEN] = (_EMPTY, None, field)  # packed: never an empty list
        elif field.has_presence or entry:
            table[key | wire] = (_SENT, None, field)
        elif wire == VARINT:
            table[key] = (_VARINT, _MASK_64 if field.type in _WIDE else _MASK_32, field)
        else:
            table[key | wire] = (_FIXED if wire != LEN else _EMPTY, None, field)
    return table


def cut_reason(
    table: Table,
    data: bytes,
    message: Message,
    boundary: int,
    canonical: bool,
    inside: bool = False,
) -> str:
    """Why restoring ``data``'s zeros from ``boundary`` on (``message`` being their parse, an
    envelope when ``inside``: the path starts at its member's type) made a cut datagram, or
    ``""``. ``canonical``: protobuf serializes ``message`` back to ``data`` exactly, which it
    does for no restored default and no varint ending in ``80 00`` of a field it knows."""
    if canonical:
        return ""
    last = boundary - 1  # the last byte that arrived
    if last >= 0 and data[last] & 0x80:
        chain = varint_cut(table, data, 0, len(data), last)
        if chain is not None:
            message, chain = _inside(message, chain) if inside else (message, chain)
            where = f"in {_field_path(message, chain, data)} " if chain else ""
            return (
                f"its last byte {where}continues a varint that only a restored zero would end "
                f"({data[last]:#04x} 0x00, which no encoder writes)"
            )
    chain = cut_field(table, data, 0, len(data))
    if chain is None:
        return ""
    if inside:
        message, chain = _inside(message, chain)
    return (
        f"restoring its stripped zeros would make {_describe_cut(message, chain, data)}, a default "
        "no proto3 encoder sends for a field without presence"
    )


def _inside(envelope: Message, chain: Chain) -> tuple[Message, Chain]:
    """The payload and the rest of a chain that starts at the envelope's member; the envelope
    and the whole chain when it starts at a metadata field (``timeout``), named from there."""
    (member, _, _), *rest = chain
    if member.message_type is None:
        return envelope, chain
    return getattr(envelope, member.name), rest


def cut_field(table: Table, data: bytes, pos: int, end: int) -> Chain | None:
    """The chain of last fields down to the deepest one in ``data[pos:end]``, if that one holds
    a default no encoder writes; ``None`` if it holds a value some encoder could have sent.

    ``data[pos:end]`` must be bytes protobuf parsed as the type of ``table``.
    """
    chain: Chain = []
    while True:
        last = _field_at(data, pos, end, end - 1)
        entry = None if last is None else table.get(last.number << 3 | last.wire_type)
        if last is None or entry is None or entry[0] == _SENT:
            return None  # empty, unknown to this schema, or a field whose zero is sent
        ask, detail, field = entry
        start, stop = last.value, last.end
        chain.append((field, start, stop))
        if ask == _NESTED:
            if start == stop:
                return None  # a present empty submessage
            table, pos, end = detail, start, stop
        elif ask == _VARINT:
            return chain if (read_varint(data, start)[0] & detail) == 0 else None
        elif ask == _FIXED:
            return chain if data.count(0, start, stop) == stop - start else None
        else:
            return chain if start == stop else None


def varint_cut(table: Table, data: bytes, pos: int, end: int, last: int) -> Chain | None:
    """The chain of fields down to the one in ``data[pos:end]`` whose varint (a tag, a length,
    a varint value, an item of a packed varint list) holds byte ``last``, at whatever depth of
    known submessages it lies; ``None`` if that byte is in no varint of a known field.

    When that byte has its continuation bit set and the zeros after it were restored, the first
    of them ends the varint: ``80 00`` is no encoder's encoding of anything, so a receiver that
    sees it has a cut datagram, whatever the field.
    """
    chain: Chain = []
    while True:
        field = _field_at(data, pos, end, last)
        entry = None if field is None else table.get(field.number << 3 | field.wire_type)
        if field is None or entry is None:
            return None  # unknown to this schema: it travels as it came
        ask, detail, known = entry
        chain.append((known, field.value, field.end))
        if last < field.value or field.wire_type == VARINT:
            return chain  # in a tag, a length prefix or a varint value
        if ask != _NESTED:  # fixed-width, text, bytes, or a packed list: of varints, or not
            packed_varints = ask == _EMPTY and known.is_repeated and known.type not in _WIRE_TYPES
            return chain if packed_varints else None
        table, pos, end = detail, field.value, field.end


def _field_at(data: bytes, pos: int, end: int, offset: int) -> FieldSpan | None:
    """The field of ``data[pos:end]`` holding byte ``offset``; ``None`` if there is none, or
    the bytes are not fields (where protobuf parsed them, they are)."""
    try:
        while pos < end:
            field = next_field(data, pos)
            if offset < field.end:
                return field
            pos = field.end
    except WireError:
        pass
    return None


def _describe_cut(message: Message, chain: Chain, data: bytes) -> str:
    """``path = value`` of the field ``cut_field`` found, read from ``message`` (what ``data``,
    the walked bytes, parsed to): see ``_field_path``; the value as the JSON mapping writes it."""
    path = _field_path(message, chain, data)
    field = chain[-1][0]
    if field.is_repeated:
        return f"{path} = [] (an empty packed list)"
    return f"{path} = {_default_text(field)}"


def _field_path(message: Message, chain: Chain, data: bytes) -> str:
    """The full path of the last field of ``chain`` (from ``cut_field`` or ``varint_cut``) from
    ``message``'s type, ``message`` being what ``data``, the walked bytes, parsed to: items by
    index (the last one, as the chain follows last fields), map entries by key."""
    path = message.DESCRIPTOR.full_name
    current: Any = message
    steps = iter(chain)
    for field, start, stop in steps:
        value = getattr(current, field.name)
        if field.type == _T.TYPE_MESSAGE and message_of(field).GetOptions().map_entry:
            entry: Any = GetMessageClass(message_of(field)).FromString(data[start:stop])
            key = entry.key
            path = entry_path(f"{path}.{field.name}", key)
            current = value[key]
            next(steps, None)  # the entry's key or value field: the walk goes on inside it
        elif field.type == _T.TYPE_MESSAGE:
            path += f".{field.name}[{len(value) - 1}]" if field.is_repeated else f".{field.name}"
            current = value[-1] if field.is_repeated else value
        else:
            path += f".{field.name}"
    return path


def _default_text(field: FieldDescriptor) -> str:
    if field.type == _T.TYPE_ENUM:
        zero = enum_of(field).values_by_number.get(0)
        return "0" if zero is None else zero.name
    if field.type in (_T.TYPE_STRING, _T.TYPE_BYTES):
        return '""'
    if field.type == _T.TYPE_BOOL:
        return "false"
    return "0.0" if field.cpp_type in (_T.CPPTYPE_FLOAT, _T.CPPTYPE_DOUBLE) else "0"
