"""Envelope.decode: every form restored to the message sent, and every other datagram refused.

Stripped datagrams get back the zeros their last field needs, padded ones lose their padding,
explicitly present zeros survive both; anything else is a DecodeError saying what and where.
"""

import contextlib
import math
from pathlib import Path
from typing import Any, cast

import pytest
from datagrams import (
    HARD_CASES,
    MAX,
    MODES,
    Build,
    assert_decodes_to,
    h,
    hostile_datagrams,
    new,
    payloads,
    valid_datagrams,
)
from google.protobuf.message import DecodeError as ProtobufDecodeError
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import erc_codec
from erc_codec import Codec, DecodeError

# -- restoring the stripped and padded forms ---------------------------------------------------


@pytest.mark.parametrize(
    ("build", "kind", "exact", "stripped"),
    [case[1:] for case in HARD_CASES],
    ids=[case[0] for case in HARD_CASES],
)
def test_hard_cases_decode_in_all_three_forms(
    codec: Codec, build: Build, kind: str, exact: str, stripped: str
) -> None:
    payload = build(codec)
    padded = h(exact) + bytes(MAX - len(h(exact)))
    for data in (h(exact), h(stripped), padded):
        assert_decodes_to(codec, data, kind, payload)


@pytest.mark.parametrize(
    ("build", "kind", "exact", "stripped"),
    [case[1:] for case in HARD_CASES],
    ids=[case[0] for case in HARD_CASES],
)
def test_hard_cases_partly_padded_forms_decode(
    codec: Codec, build: Build, kind: str, exact: str, stripped: str
) -> None:
    """Every length between the stripped and the padded form is the same datagram."""
    payload = build(codec)
    padded = h(exact) + bytes(MAX - len(h(exact)))
    for length in range(len(h(stripped)), MAX + 1):
        assert_decodes_to(codec, padded[:length], kind, payload)


def test_naive_receivers_fail_where_the_codec_does_not(codec: Codec) -> None:
    """Why the codec exists: plain protobuf rejects the stripped and the padded forms."""
    envelope = codec.message_class("PBEnvelope")
    payload = new(codec, "DrivingBoardMotorPeriodicProgress", distance_left=1e-40)
    stripped, padded = codec.encode(payload, "strip"), codec.encode(payload, "pad")
    with pytest.raises(ProtobufDecodeError):
        envelope.FromString(stripped)
    with pytest.raises(ProtobufDecodeError):
        envelope.FromString(padded)
    for data in (stripped, padded):
        assert codec.decode(data) == ("drive_progress", payload)


def test_negative_zero_survives_every_form(codec: Codec) -> None:
    payload = new(codec, "DrivingBoardMotorMessage", distance_to_go=-0.0, turning_radius=-0.0)
    for mode in MODES:
        message: Any = codec.decode(codec.encode(payload, mode)).message
        assert math.copysign(1.0, message.distance_to_go) == -1.0
        assert math.copysign(1.0, message.turning_radius) == -1.0
        assert message.SerializeToString() == payload.SerializeToString()
    gps = new(codec, "SensorBoardGPSInfo", latitude=-0.0, longitude=-0.0, altitude=-0.0)
    for mode in MODES:
        decoded: Any = codec.decode(codec.encode(gps, mode)).message
        assert math.copysign(1.0, decoded.latitude) == -1.0
        assert math.copysign(1.0, decoded.altitude) == -1.0
        assert decoded.SerializeToString() == gps.SerializeToString()


def test_denormal_float_survives_stripping(codec: Codec) -> None:
    payload = new(codec, "DrivingBoardMotorPeriodicProgress", distance_left=1e-40)
    stored = payload.distance_left  # float32 rounding of 1e-40
    assert stored != 0.0
    message: Any = codec.decode(codec.encode(payload, "strip")).message
    assert message.distance_left == stored


# -- decode errors -----------------------------------------------------------------------------


DECODE_ERRORS: list[tuple[str, bytes, str]] = [
    ("empty", b"", r"empty"),
    ("one zero", b"\0", r"no payload"),
    ("all zero", bytes(MAX), r"no payload"),
    ("too long: zeros", bytes(MAX + 1), r"256 bytes.*255"),
    ("too long: padded", h("22") + bytes(MAX), r"256 bytes.*255"),
    ("too long: 300", h("22 00") + bytes(298), r"300 bytes.*255"),
    ("unknown member 22", h("b2 01 00"), r"\b22\b"),
    ("unknown member 22 stripped", h("b2 01"), r"\b22\b"),
    ("unknown member 22 padded", h("b2 01") + bytes(100), r"\b22\b"),
    ("unknown member 22 varint", h("b0 01 05"), r"\b22\b"),
    ("unknown member 100", h("a2 06 03 08 01 10"), r"\b100\b"),
    ("unknown member 100 padded", h("a2 06 00") + bytes(252), r"\b100\b"),
    ("unknown member 2047", h("fa 7f 00"), r"\b2047\b"),
    ("payload cut inside a submessage", h("5a 07 12 06 0d 01"), r"SensorBoardDiagnostics"),
    ("submessage longer than its payload", h("5a 03 12 05 0d"), r"SensorBoardDiagnostics"),
    ("payload varint cut off", h("5a 02 08 81"), r"SensorBoardDiagnostics"),
    ("length of zeros only", h("22 05"), r"ArmBoardMovementFeedback|arm_feedback"),
    ("payload longer than the envelope", h("82 01 ff 01"), r"255"),
    ("payload length 1000", h("0a e8 07 01"), r"255"),
    ("garbage after zero padding", h("22 00 00 01"), r"offset 2.*offset 3"),
    ("garbage far after zero padding", h("22 00") + bytes(200) + h("07"), r"offset 202"),
    ("zero inside padding of exact payload", h("0a 05 0d 00 00 80 3f 00 00 01"), r"offset 9"),
    ("group start at top level", h("23"), r"wire type 3"),
    ("group end at top level", h("24"), r"wire type 4"),
    ("group pair at top level", h("0b 0c"), r"wire type 3"),
    ("wire type 6", h("26 00"), r"wire type 6"),
    ("wire type 7", h("27"), r"wire type 7"),
    ("group start with two-byte tag", h("83 01"), r"wire type 3"),
    ("two-byte tag cut off", h("82"), r"offset 0"),
    ("two-byte tag cut off, member 21", h("aa"), r"offset 0"),
    ("length varint cut off", h("0a 85"), r"offset 1"),
    ("length varint cut off, two-byte tag", h("aa 01 80"), r"offset 2"),
    ("field number 0", h("02 00"), r"field number 0"),
    ("non-canonical field number 0", h("80 00 01"), r"field number 0"),
    ("eleven-byte tag", h("ff") * 10 + h("01"), r"offset 0"),
]


@pytest.mark.parametrize(
    ("data", "pattern"),
    [case[1:] for case in DECODE_ERRORS],
    ids=[case[0] for case in DECODE_ERRORS],
)
def test_decode_errors(codec: Codec, data: bytes, pattern: str) -> None:
    with pytest.raises(DecodeError, match=pattern) as caught:
        codec.decode(data)
    assert isinstance(caught.value, erc_codec.CodecError)
    assert str(caught.value)


@pytest.mark.parametrize(
    "data",
    [h("20 01"), h("25 01 00 00 00"), h("21") + bytes(8), h("90 01 05")],
    ids=["member 4 as varint", "member 4 as fixed32", "member 4 as fixed64", "member 18 varint"],
)
def test_a_member_number_with_the_wrong_wire_type(codec: Codec, data: bytes) -> None:
    """A known member sent with a wire type other than LEN is corrupt, not a newer schema's."""
    with pytest.raises(DecodeError) as caught:
        codec.decode(data)
    text = str(caught.value)
    number = "18" if data[0] == 0x90 else "4"
    assert number in text
    assert "not a member" not in text, text


def test_a_datagram_whose_restored_form_exceeds_the_envelope_is_refused(codec: Codec) -> None:
    """255 bytes ending in a tag whose value was "stripped": restored, it would be 256 bytes.

    A receiver padding to PBEnvelope_size (255) cannot hold the last field's length byte, and no
    sender can have produced it: encode refuses anything longer than 255.
    """
    filler = h("b2 01 f7 01") + b"\x01" * 247  # unknown member 22, 247 bytes
    ends_in_len_tag = h("22 00") + filler + h("b2 01")
    assert len(ends_in_len_tag) == MAX
    ends_in_i32_tag = h("22 00") + filler + h("b5 01")
    with pytest.raises(DecodeError, match="255"):
        codec.decode(ends_in_i32_tag)  # restored to 259 bytes
    with pytest.raises(DecodeError, match="255"):
        codec.decode(ends_in_len_tag)  # restored to 256 bytes


def test_truncations_that_restore_to_a_parseable_form_decode(codec: Codec) -> None:
    """Restoring zeros is all a receiver can do: a cut that leaves a parseable form decodes."""
    tiny = new(codec, "SensorBoardPHInfo", ph_value=1e-45)
    assert codec.encode(tiny, "exact") == h("0a 05 0d 01 00 00 00")
    assert codec.decode(h("0a 05 0d 01")) == ("ph_info", tiny)  # its stripped form
    # Partly stripped, restoring an explicit 0.0 that protobuf accepts: the value is 0.0.
    kind, message = codec.decode(h("0a 05 0d 00 00"))
    assert kind == "ph_info"
    assert cast(Any, message).ph_value == 0.0


def test_only_the_padded_forms_may_have_zeros_after_the_payload(codec: Codec) -> None:
    payload = new(codec, "BasestationControlMode", mode=2)
    exact = codec.encode(payload, "exact")
    assert exact == h("82 01 02 08 02")
    for extra in range(MAX - len(exact) + 1):
        assert codec.decode(exact + bytes(extra)).message == payload
    with pytest.raises(DecodeError, match="256"):
        codec.decode(exact + bytes(MAX - len(exact) + 1))


# -- trailing zeros ----------------------------------------------------------------------------


def test_cutting_only_trailing_zeros_never_changes_the_message(codec: Codec) -> None:
    for data in valid_datagrams(codec):
        expected = codec.decode(data)
        stripped = data.rstrip(b"\0")
        for length in range(len(stripped), len(data) + 1):
            assert codec.decode(data[:length]) == expected


# -- decode is peek and one parse --------------------------------------------------------------

# Envelope.decode repeats Envelope.peek's arithmetic inline, for the decode target of
# benchmarks/bench_codec.py; these hold the copy to the original.
CODEC = Codec.default()
KINDS = sorted(CODEC.kinds().values())


def assert_decode_is_peek_and_a_parse(data: bytes) -> None:
    """Where ``peek`` locates a payload, ``decode`` gives that payload parsed by its class, or a
    DecodeError exactly where that parse fails; elsewhere it decodes or raises DecodeError."""
    found = CODEC.peek(data)
    if found is None:
        with contextlib.suppress(DecodeError):
            CODEC.decode(data)
        return
    kind, payload = found
    try:
        expected = CODEC.payload_class(kind).FromString(payload)
    except ProtobufDecodeError:
        with pytest.raises(DecodeError, match=rf"its {kind} payload of {len(payload)} bytes"):
            CODEC.decode(data)
        return
    decoded = CODEC.decode(data)
    # (kind, expected), compared as bytes: == cannot tell -0.0 from 0.0, nor NaN from itself
    assert decoded.kind == kind
    assert type(decoded.message) is type(expected)
    assert decoded.message.SerializeToString() == expected.SerializeToString()


@pytest.mark.parametrize("kind", KINDS)
@given(data=st.data())
@settings(max_examples=50)
def test_decode_is_peek_and_a_parse_on_every_form(kind: str, data: st.DataObject) -> None:
    """Every form of every payload type: exact, stripped, padded and every length between."""
    message = data.draw(payloads(CODEC, kind))
    exact = CODEC.encode(message, "exact")
    stripped = exact.rstrip(b"\0")
    datagram = (stripped + bytes(MAX))[: data.draw(st.integers(len(stripped), MAX))]
    # Every datagram a sender writes has the usual shape: peek finds its exact payload.
    assert CODEC.peek(datagram) == (kind, message.SerializeToString())
    assert_decode_is_peek_and_a_parse(datagram)


@given(hostile_datagrams(CODEC))
@settings(max_examples=500, suppress_health_check=[HealthCheck.too_slow])
def test_decode_is_peek_and_a_parse_on_hostile_bytes(data: bytes) -> None:
    assert_decode_is_peek_and_a_parse(data)


# -- explicit presence and fixed-width integers (tests/schema_trees/presence) ------------------


PRESENCE_TREE = Path(__file__).resolve().parent / "schema_trees" / "presence"


@pytest.fixture(scope="module")
def presence() -> Codec:
    return Codec.from_path(PRESENCE_TREE, root="Env")


PRESENCE_CASES: list[tuple[str, str, dict[str, Any], str, str]] = [
    ("optional zero", "Counter", {"count": 0}, "0a 02 10 00", "0a 02 10"),
    ("optional float zero", "Counter", {"level": 0.0}, "0a 05 2d 00 00 00 00", "0a 05 2d"),
    ("optional zeros last", "Counter", {"id": 1, "count": 0, "level": 0.0},
     "0a 09 08 01 10 00 2d 00 00 00 00", "0a 09 08 01 10 00 2d"),
    ("fixed32 small", "Counter", {"stamp": 5}, "0a 05 1d 05 00 00 00", "0a 05 1d 05"),
    ("sfixed64 small", "Counter", {"offset": 1}, "0a 09 21 01 00 00 00 00 00 00 00", "0a 09 21 01"),
    ("sfixed64 -1", "Counter", {"offset": -1}, "0a 09 21" + " ff" * 8, "0a 09 21" + " ff" * 8),
    ("oneof bool false", "Choice", {"flag": False}, "12 02 10 00", "12 02 10"),
    ("oneof uint32 zero", "Choice", {"number": 0}, "12 02 08 00", "12 02 08"),
    ("all default", "Counter", {}, "0a 00", "0a"),
]  # fmt: skip


@pytest.mark.parametrize(
    ("name", "fields", "exact", "stripped"),
    [case[1:] for case in PRESENCE_CASES],
    ids=[case[0] for case in PRESENCE_CASES],
)
def test_explicitly_present_zeros_survive_stripping(
    presence: Codec, name: str, fields: dict[str, Any], exact: str, stripped: str
) -> None:
    assert presence.max_size("Env") == 33
    payload = new(presence, name, **fields)
    kind = name.lower()
    assert presence.encode(payload, "exact") == h(exact)
    assert new(presence, "Env", **{kind: payload}).SerializeToString() == h(exact)
    assert presence.encode(payload, "strip") == h(stripped)
    padded = presence.encode(payload, "pad")
    assert padded == h(exact) + bytes(33 - len(h(exact)))
    for data in (h(exact), h(stripped), padded):
        decoded = presence.decode(data)
        assert decoded.kind == kind
        assert decoded.message == payload
        assert decoded.message.ListFields() == payload.ListFields()
        for field in fields:
            if field in ("count", "level"):
                assert decoded.message.HasField(field)
        if name == "Choice":
            assert decoded.message.WhichOneof("value") == next(iter(fields))
