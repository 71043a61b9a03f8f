"""erc_schema's wire primitives: varints and ``next_field``, against hand-written bytes."""

import pytest

from erc_schema import (
    I32,
    I64,
    LEN,
    MAX_FIELD_NUMBER,
    SGROUP,
    VARINT,
    FieldSpan,
    WireError,
    encode_varint,
    next_field,
    read_varint,
    varint_size,
)

# value -> its varint encoding, written out by hand from the protobuf encoding rules.
VARINTS: list[tuple[int, str]] = [
    (0, "00"),
    (1, "01"),
    (127, "7f"),
    (128, "80 01"),
    (150, "96 01"),
    (300, "ac 02"),
    (16383, "ff 7f"),
    (16384, "80 80 01"),
    (2**32 - 1, "ff ff ff ff 0f"),
    (2**35 - 1, "ff ff ff ff 7f"),
    (2**35, "80 80 80 80 80 01"),
    (2**63 - 1, "ff ff ff ff ff ff ff ff 7f"),
    (2**63, "80 80 80 80 80 80 80 80 80 01"),
    (2**64 - 1, "ff ff ff ff ff ff ff ff ff 01"),
]

# Negative values go on the wire as their 64-bit two's complement: always ten bytes.
NEGATIVES: list[tuple[int, str]] = [
    (-1, "ff ff ff ff ff ff ff ff ff 01"),
    (-2, "fe ff ff ff ff ff ff ff ff 01"),
    (-128, "80 ff ff ff ff ff ff ff ff 01"),
    (-(2**31), "80 80 80 80 f8 ff ff ff ff 01"),
    (-(2**63), "80 80 80 80 80 80 80 80 80 01"),
]


@pytest.mark.parametrize(("value", "wire"), VARINTS)
def test_encode_varint_matches_hand_encoding(value: int, wire: str) -> None:
    assert encode_varint(value) == bytes.fromhex(wire)


@pytest.mark.parametrize(("value", "wire"), VARINTS)
def test_varint_size_is_encoded_length(value: int, wire: str) -> None:
    assert varint_size(value) == len(bytes.fromhex(wire))


@pytest.mark.parametrize(("value", "wire"), VARINTS)
def test_read_varint_returns_value_and_next_offset(value: int, wire: str) -> None:
    data = bytes.fromhex(wire)
    assert read_varint(data, 0) == (value, len(data))


@pytest.mark.parametrize(("value", "wire"), VARINTS)
def test_read_varint_at_an_offset_stops_after_the_varint(value: int, wire: str) -> None:
    data = b"\x0a\x0b\x0c" + bytes.fromhex(wire) + b"\x55\x00\x80"
    assert read_varint(data, 3) == (value, 3 + len(bytes.fromhex(wire)))


@pytest.mark.parametrize(("value", "wire"), NEGATIVES)
def test_negative_values_are_ten_byte_twos_complement(value: int, wire: str) -> None:
    data = bytes.fromhex(wire)
    assert len(data) == 10
    assert encode_varint(value) == data
    assert varint_size(value) == 10
    # Reading gives the unsigned 64-bit value; reinterpreting it as signed restores the input.
    unsigned, end = read_varint(data, 0)
    assert end == 10
    assert unsigned == value + 2**64
    assert unsigned - 2**64 == value


def test_two_to_the_63_and_its_negation_share_one_encoding() -> None:
    assert encode_varint(2**63) == encode_varint(-(2**63))


def test_varint_size_agrees_with_encoding_around_every_seven_bit_boundary() -> None:
    values = {0, 1}
    for bits in range(7, 64, 7):
        values.update({2**bits - 1, 2**bits, 2**bits + 1})
    values.update({2**64 - 1, -1, -(2**63), -300})
    for value in sorted(values):
        encoded = encode_varint(value)
        assert varint_size(value) == len(encoded), value
        assert encoded[-1] < 0x80, value  # only the last byte lacks the continuation bit
        assert all(byte >= 0x80 for byte in encoded[:-1]), value
        assert read_varint(encoded, 0) == (value % 2**64, len(encoded)), value


def test_varint_boundaries_of_varint_size() -> None:
    assert [varint_size(v) for v in (0, 1, 127, 128, 300, 16383, 16384)] == [1, 1, 1, 2, 2, 2, 3]
    assert varint_size(2**32 - 1) == 5
    assert varint_size(2**63) == 10
    assert varint_size(2**64 - 1) == 10
    assert varint_size(-1) == 10


def test_read_varint_accepts_a_non_canonical_zero_continuation() -> None:
    # 0x80 0x00 is a two-byte spelling of 0: a reader takes it, a writer never produces it.
    assert read_varint(b"\x80\x00", 0) == (0, 2)


def test_wire_error_is_a_value_error() -> None:
    assert issubclass(WireError, ValueError)


@pytest.mark.parametrize(
    ("data", "pos"),
    [
        (b"", 0),
        (b"\x80", 0),
        (b"\xff\xff\xff", 0),
        (b"\x01\x02\x80", 2),
        (b"\x08\x96", 1),
        (b"\x00" * 5 + b"\xac", 5),
        (b"\xff" * 9, 0),  # nine continuation bytes, then nothing
    ],
)
def test_read_varint_cut_off_names_the_offset(data: bytes, pos: int) -> None:
    with pytest.raises(WireError, match=rf"\boffset {pos}\b.*cut off") as caught:
        read_varint(data, pos)
    assert str(pos) in str(caught.value)


@pytest.mark.parametrize("pos", [0, 1, 7])
def test_read_varint_longer_than_ten_bytes_names_the_offset(pos: int) -> None:
    data = bytes(pos) + b"\xff" * 10 + b"\x01"
    with pytest.raises(WireError, match=rf"\boffset {pos}\b.*longer than 10 bytes"):
        read_varint(data, pos)


def test_read_varint_eleven_continuation_bytes_is_too_long_not_cut_off() -> None:
    with pytest.raises(WireError, match="longer than 10 bytes"):
        read_varint(b"\x80" * 11, 0)


def test_ten_byte_varint_is_the_longest_accepted() -> None:
    assert read_varint(b"\x80" * 9 + b"\x01", 0) == (2**63, 10)


# -- next_field: the one tag walker ---------------------------------------------------------------


def h(text: str) -> bytes:
    return bytes.fromhex(text)


@pytest.mark.parametrize(
    ("data", "span"),
    [
        (h("08 96 01"), FieldSpan(1, VARINT, 1, 3)),
        (h("12 03 61 62 63"), FieldSpan(2, LEN, 2, 5)),
        (h("1d 00 00 80 3f"), FieldSpan(3, I32, 1, 5)),
        (h("21 01 02 03 04 05 06 07 08"), FieldSpan(4, I64, 1, 9)),
        (h("80 01 00"), FieldSpan(16, VARINT, 2, 3)),
        # a group, skipped up to its own end tag, nested groups and fields inside it too
        (h("0b 10 01 1b 20 02 1c 0c"), FieldSpan(1, SGROUP, 1, 8)),
    ],
    ids=["varint", "len", "i32", "i64", "two-byte-tag", "group"],
)
def test_next_field_spans_one_field(data: bytes, span: FieldSpan) -> None:
    assert next_field(data + b"\x08\x01", 0) == span  # what follows is not read


@pytest.mark.parametrize(
    ("data", "span"),
    [
        (h("08"), FieldSpan(1, VARINT, 1, 2)),  # the zero value was stripped
        (h("12"), FieldSpan(2, LEN, 2, 2)),  # the zero length was stripped
        (h("12 05 61 62"), FieldSpan(2, LEN, 2, 7)),  # three zero bytes of the value
        (h("1d 01"), FieldSpan(3, I32, 1, 5)),
    ],
)
def test_next_field_reads_zeros_past_the_end(data: bytes, span: FieldSpan) -> None:
    assert next_field(data, 0, zeros_past_end=True) == span
    with pytest.raises(WireError):
        next_field(data, 0)  # without the flag, the same bytes are cut off


def test_next_field_at_an_offset() -> None:
    assert next_field(h("08 01 10 02"), 2) == FieldSpan(2, VARINT, 3, 4)


@pytest.mark.parametrize(
    ("data", "pattern"),
    [
        (h("00"), r"field number 0 in the tag at offset 0"),
        (h("80 00 01"), r"field number 0 in the tag at offset 0"),
        # 2**29 (the first number past protobuf's largest) with wire type 0
        (encode_varint(2**29 << 3) + b"\x00", r"field number 536870912 .* outside 1\.\.536870911"),
        (encode_varint(2**32 << 3) + b"\x00", r"field number 4294967296 .* outside"),
        (h("0e 00"), r"field 1's wire type 6 before offset 1 is not defined"),
        (h("17"), r"field 2's wire type 7 before offset 1 is not defined"),
        (h("0c"), r"field 1's end-group tag \(wire type 4\) closes no group"),
        (h("0b 08 01"), r"field 1's group \(wire type 3\) is not closed"),
        (h("0b 14"), r"end-group tag at offset 1 is field 2's, but field 1's group is open"),
        (h("0b 00 0c"), r"field number 0 in the tag at offset 1"),
        (h("0b 0f 0c"), r"field 1's wire type 7 before offset 2"),
        (h("12 05 61"), r"the value of field 2 at offset 2 needs 4 more bytes"),
        (h("08 80"), r"varint at offset 1 is cut off"),
    ],
)
def test_next_field_refuses_malformed_tags_and_values(data: bytes, pattern: str) -> None:
    with pytest.raises(WireError, match=pattern):
        next_field(data, 0)


def test_the_largest_field_number_is_accepted() -> None:
    data = encode_varint(MAX_FIELD_NUMBER << 3) + b"\x01"
    assert next_field(data, 0) == FieldSpan(MAX_FIELD_NUMBER, VARINT, 5, 6)


def test_a_cut_varint_is_an_error_even_with_zeros_past_the_end() -> None:
    """A stripped tail holds zeros only, and no canonical varint ends in a continuation byte."""
    with pytest.raises(WireError, match="cut off"):
        next_field(h("08 80"), 0, zeros_past_end=True)


def test_deeply_nested_groups_are_walked_without_recursion() -> None:
    depth = 100_000
    data = b"\x0b" * depth + b"\x0c" * depth
    assert next_field(data, 0).end == len(data)
