"""Protobuf's wire format, as far as erc-codec reads it itself: varints, tags and field boundaries.

Readers take a buffer and an offset and return where things end. A varint cut off by the end of the
buffer or longer than ten bytes, a field whose value does not fit, a group that is never closed:
each is a ``WireError`` naming the offset. What a short buffer means (corruption, or a stripped
tail) is the caller's decision: ``next_field(..., zeros_past_end=True)`` reads the bytes past the
end as the zeros a sender stripped, and reports where the field would end.
"""

from typing import NamedTuple

__all__ = [
    "EGROUP",
    "I32",
    "I64",
    "LEN",
    "MAX_FIELD_NUMBER",
    "SGROUP",
    "VARINT",
    "WIRE_TYPE_NAMES",
    "FieldSpan",
    "WireError",
    "encode_varint",
    "next_field",
    "read_varint",
    "varint_size",
]

# The wire types, named as protobuf's encoding documentation names them.
VARINT, I64, LEN, SGROUP, EGROUP, I32 = 0, 1, 2, 3, 4, 5
WIRE_TYPE_NAMES = {
    VARINT: "VARINT",
    I64: "I64",
    LEN: "LEN",
    SGROUP: "SGROUP",
    EGROUP: "EGROUP",
    I32: "I32",
}
_FIXED = {I64: 8, I32: 4}
_MAX_VARINT_BYTES = 10
MAX_FIELD_NUMBER = 2**29 - 1  # protobuf's largest field number: a tag's number has 29 bits


class WireError(ValueError):
    """Bytes that are not well-formed protobuf where they were read."""


class FieldSpan(NamedTuple):
    """One field on the wire: its tag's number and wire type, where its value starts and ends."""

    number: int
    wire_type: int
    value: int  # offset of its value (of a LEN field's content, after the length prefix)
    end: int  # offset after the value (past the data's end when zeros were stripped off it)


def varint_size(value: int) -> int:
    """Bytes a varint takes on the wire; negative values are sign-extended to 64 bits (10 bytes)."""
    if value < 0:
        return _MAX_VARINT_BYTES
    return max(1, (value.bit_length() + 6) // 7)


def encode_varint(value: int) -> bytes:
    """The varint encoding of ``value`` (negative values as their 64-bit two's complement)."""
    if value < 0:
        value += 1 << 64
    out = bytearray()
    while value > 0x7F:
        out.append((value & 0x7F) | 0x80)
        value >>= 7
    out.append(value)
    return bytes(out)


def read_varint(data: bytes, pos: int) -> tuple[int, int]:
    """Read the varint starting at ``pos``; return its value and the offset after it."""
    start = pos
    value = shift = 0
    end = len(data)
    while pos < end and pos - start < _MAX_VARINT_BYTES:
        byte = data[pos]
        pos += 1
        value |= (byte & 0x7F) << shift
        if byte < 0x80:
            return value, pos
        shift += 7
    if pos - start >= _MAX_VARINT_BYTES:
        raise WireError(f"varint at offset {start} is longer than {_MAX_VARINT_BYTES} bytes")
    raise WireError(f"varint at offset {start} is cut off by the end of the data")


def next_field(data: bytes, pos: int, zeros_past_end: bool = False) -> FieldSpan:
    """The field whose tag starts at ``pos``, its value skipped (a group up to its end tag).

    With ``zeros_past_end`` the data is read as if the zeros stripped off its end were still
    there: a varint or a length that is missing entirely reads as 0, and a value that runs past
    the end is taken whole (``end`` then lies past ``len(data)``). A varint cut in the middle is
    an error either way: a stripped tail holds zeros only, and no canonical varint ends in one.
    """
    key, value = read_varint(data, pos)
    number, wire_type = _number(key, pos), key & 7
    if wire_type == LEN:
        if value >= len(data) and zeros_past_end:
            return FieldSpan(number, LEN, value + 1, value + 1)  # a zero length was stripped
        length, value = read_varint(data, value)
        end = _within(data, value + length, number, value, zeros_past_end)
        return FieldSpan(number, LEN, value, end)
    return FieldSpan(
        number, wire_type, value, _skip(data, value, number, wire_type, zeros_past_end)
    )


def _number(key: int, pos: int) -> int:
    """The field number of tag ``key`` read at ``pos``, if protobuf allows it (1..2**29-1)."""
    number = key >> 3
    if not 0 < number <= MAX_FIELD_NUMBER:
        raise WireError(
            f"field number {number} in the tag at offset {pos} is outside 1..{MAX_FIELD_NUMBER}"
        )
    return number


def _within(data: bytes, end: int, number: int, pos: int, zeros_past_end: bool) -> int:
    """``end``, the end of a value starting at ``pos``, unless it runs past the data's end."""
    if end > len(data) and not zeros_past_end:
        raise WireError(
            f"the value of field {number} at offset {pos} needs {end - len(data)} more bytes "
            "than the data holds"
        )
    return end


def _skip(data: bytes, pos: int, number: int, wire_type: int, zeros_past_end: bool) -> int:
    """The offset after the value of field ``number`` that starts at ``pos``."""
    if wire_type == VARINT:
        if pos >= len(data) and zeros_past_end:
            return pos + 1  # a zero value was stripped
        return read_varint(data, pos)[1]
    if wire_type == LEN:
        length, pos = read_varint(data, pos)
        return _within(data, pos + length, number, pos, zeros_past_end)
    if wire_type in _FIXED:
        return _within(data, pos + _FIXED[wire_type], number, pos, zeros_past_end)
    if wire_type == SGROUP:
        return _skip_group(data, pos, number)
    if wire_type == EGROUP:
        raise WireError(f"field {number}'s end-group tag (wire type 4) closes no group")
    raise WireError(
        f"field {number}'s wire type {wire_type} before offset {pos} is not defined in protobuf"
    )


def _skip_group(data: bytes, pos: int, number: int) -> int:
    """The offset after the end-group tag closing group ``number``, whose fields start at ``pos``.

    Nested groups are followed with a stack, not recursion: hostile data may nest them deeply."""
    open_groups = [number]
    while open_groups:
        if pos >= len(data):
            raise WireError(
                f"field {open_groups[-1]}'s group (wire type 3) is not closed before the end "
                "of the data"
            )
        key, after = read_varint(data, pos)
        inner, wire_type = _number(key, pos), key & 7
        if wire_type == EGROUP:
            expected = open_groups.pop()
            if inner != expected:
                raise WireError(
                    f"end-group tag at offset {pos} is field {inner}'s, "
                    f"but field {expected}'s group is open"
                )
            pos = after
        elif wire_type == SGROUP:
            open_groups.append(inner)
            pos = after
        else:
            pos = _skip(data, after, inner, wire_type, False)
    return pos
