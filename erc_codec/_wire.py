"""The few protobuf wire-format primitives the codec needs: varints and tags.

Readers take a buffer and an offset and return ``(value, next_offset)``. A varint cut off by the end
of the buffer, or longer than ten bytes, raises ``WireError`` with the offset where it started; what
that means (corruption, or a stripped tail) is the caller's decision.
"""

__all__ = [
    "I32",
    "I64",
    "LEN",
    "VARINT",
    "WireError",
    "encode_varint",
    "read_varint",
    "varint_size",
]

VARINT, I64, LEN, SGROUP, EGROUP, I32 = 0, 1, 2, 3, 4, 5

_MAX_VARINT_BYTES = 10


class WireError(ValueError):
    """Bytes that are not a well-formed varint."""


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
