"""Strict decode of the rover's envelope reads the bytes as nanopb's decoder does.

A payload field and an envelope metadata field each carry a uint32 value above 32 bits:
protobuf's parse keeps the low 32 bits, nanopb's decoder (tests/interop/filter.c, the rover's
own generated code) refuses the datagram "integer too large", and so does strict decode, naming
the payload's field by the payload's type as every strict error does, and the metadata field by
the envelope's.
"""

import pytest
from test_interop import Peer, nanopb  # noqa: F401  (nanopb: the session's C peer, a fixture)

import erc_codec
from erc_schema import encode_varint

CODEC = erc_codec.Codec.default()
TOO_LARGE = encode_varint(2**32 + 5)


def _member(number: int, body: bytes) -> bytes:
    return encode_varint(number << 3 | 2) + encode_varint(len(body)) + body


@pytest.mark.parametrize(
    ("data", "path"),
    [
        (_member(7, b"\x08" + TOO_LARGE), "ArmBoardObstructions.obstruction_count"),
        (_member(7, b"\x08\x01") + b"\xf0\x01" + TOO_LARGE, "PBEnvelope.timeout"),
    ],
    ids=["payload", "metadata"],
)
@pytest.mark.interop
def test_a_uint32_above_32_bits_is_refused_as_nanopb_refuses_it(
    nanopb: Peer,  # noqa: F811
    data: bytes,
    path: str,
) -> None:
    decoded = CODEC.decode(data)  # protobuf keeps the low 32 bits
    assert decoded.kind == "arm_obstructions"
    (answer,) = nanopb.ask([f"D {data.hex()}"])
    assert not answer.ok
    assert answer.error == "integer too large"
    with pytest.raises(erc_codec.DecodeError) as raised:
        CODEC.decode(data, strict=True)
    assert f"{path} = 4294967301 does not fit nanopb's uint32_t (integer too large)" in str(
        raised.value
    )
    # in each form: stripped and padded datagrams are read as their exact bytes
    with pytest.raises(erc_codec.DecodeError, match="integer too large"):
        CODEC.decode(data + bytes(CODEC.max_size("PBEnvelope") - len(data)), strict=True)


def test_what_nanopb_takes_strict_decode_takes() -> None:
    """Padded varints (trailing 0x80 bytes, up to ten bytes) and a uint32's largest value."""
    for varint in (b"\x85\x80\x80\x80\x00", encode_varint(2**32 - 1)):
        data = _member(7, b"\x08" + varint)
        assert CODEC.decode(data, strict=True) == CODEC.decode(data)
