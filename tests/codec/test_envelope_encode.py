"""Envelope.encode: the exact, stripped and padded forms, the longest payloads, encode errors.

Expected bytes are written out by hand from the protobuf wire format and cross-checked against
protobuf's own serialization of the envelope (the hard cases are in tests/datagrams.py).
"""

from typing import Any, cast

import pytest
from datagrams import (
    ENVELOPE_MEMBERS,
    HARD_CASES,
    MAX,
    MODES,
    TIMEOUT_WIDTH,
    Build,
    assert_all_forms,
    assert_decodes_to,
    descriptor,
    envelope_bytes,
    f32,
    fill_widest,
    h,
    member_of,
    new,
    payloads,
    random_payloads,
    varint_size,
    widest_driving_diagnostics,
    with_unknown_field,
)
from google.protobuf.message import DecodeError as ProtobufDecodeError
from hypothesis import given, settings
from hypothesis import strategies as st

import erc_codec
from erc_codec import Codec, EncodeError

# -- the three forms ---------------------------------------------------------------------------


def test_exact_is_protobufs_own_envelope_serialization(codec: Codec) -> None:
    payload = new(codec, "SensorBoardPHInfo", ph_value=7.25, voltage=-12.5, state=1, error_code=3)
    body = h("0d") + f32(7.25) + h("15") + f32(-12.5) + h("20 01 28 03")
    assert payload.SerializeToString() == body
    exact = h("0a") + bytes([len(body)]) + body
    assert codec.encode(payload, "exact") == exact
    assert new(codec, "PBEnvelope", ph_info=payload).SerializeToString() == exact
    assert codec.encode(payload, "strip") == exact  # ends in 03: nothing to strip
    assert codec.encode(payload, "pad") == exact + bytes(MAX - len(exact))


def test_default_mode_is_strip(codec: Codec) -> None:
    payload = new(codec, "ArmBoardMovementFeedback")
    assert codec.encode(payload) == codec.encode(payload, "strip") == h("22")


def test_mode_as_a_keyword_is_the_mode_as_in_0_1_0(codec: Codec) -> None:
    """``encode(message, mode="exact")`` was 0.1.0's spelling; no packaged metadata field is
    named ``mode``, so it is the mode still, beside metadata too."""
    go = codec.message_class("drive_motor")(distance_to_go=1.5)
    for mode in ("exact", "strip", "pad"):
        assert codec.encode(go, mode=mode) == codec.encode(go, mode)
        assert erc_codec.encode(go, mode=mode) == codec.encode(go, mode)
        timed = codec.encode(go, mode=mode, timeout=300)
        assert timed == codec.encode(go, mode, timeout=300)
    with pytest.raises(EncodeError, match="has no metadata field 'modes'"):
        codec.encode(go, modes="exact")
    with pytest.raises(TypeError, match="encode got the mode twice: 'pad' and mode='exact'"):
        codec.encode(go, "pad", mode="exact")


def test_a_whole_envelope_encodes_like_its_payload(codec: Codec) -> None:
    payload = new(codec, "BasestationObjectSelection", frame_id=300, index=2, class_id=0)
    envelope = new(codec, "PBEnvelope", object_selection=payload)
    exact = h("92 01 05 08 ac 02 10 02")
    for mode in MODES:
        assert codec.encode(envelope, mode) == codec.encode(payload, mode)
    assert codec.encode(envelope, "exact") == exact == envelope.SerializeToString()
    assert codec.encode(envelope, "pad") == exact + bytes(MAX - len(exact))


def test_a_whole_envelope_with_an_empty_payload(codec: Codec) -> None:
    envelope = new(codec, "PBEnvelope")
    envelope.arm_feedback.SetInParent()
    assert codec.encode(envelope, "exact") == h("22 00")
    assert codec.encode(envelope, "strip") == h("22")
    assert codec.encode(envelope, "pad") == h("22") + bytes(MAX - 1)


@pytest.mark.parametrize(
    ("build", "kind", "exact", "stripped"),
    [case[1:] for case in HARD_CASES],
    ids=[case[0] for case in HARD_CASES],
)
def test_hard_cases_encode_exactly(
    codec: Codec, build: Build, kind: str, exact: str, stripped: str
) -> None:
    payload = build(codec)
    assert member_of(codec, payload) == kind
    assert codec.encode(payload, "exact") == h(exact)
    assert envelope_bytes(codec, kind, payload) == h(exact)
    assert codec.encode(payload, "strip") == h(stripped)
    assert codec.encode(payload, "pad") == h(exact) + bytes(MAX - len(h(exact)))


# -- the longest payloads ----------------------------------------------------------------------


def motor_bytes(motor_id: int, rpm: float, voltage: float, angle: float) -> bytes:
    """A MotorInformation with state 3 (MOTOR_STATE_ERRORED), written out field by field."""
    return (
        h("08 03 10")
        + bytes(h("ff ff ff ff 0f") if motor_id == 2**32 - 1 else [motor_id])
        + h("1d")
        + f32(rpm)
        + h("25")
        + f32(voltage)
        + h("2d")
        + f32(angle)
    )


def test_the_biggest_payload_fills_the_envelope_exactly(codec: Codec) -> None:
    payload = widest_driving_diagnostics(codec)
    motor = motor_bytes(2**32 - 1, -1500.25, 24.5, 359.5)
    assert len(motor) == 23 == codec.max_size("MotorInformation")
    body = h("08 03") + b"".join(bytes([(n << 3) | 2, 23]) + motor for n in range(2, 12))
    assert len(body) == 252 == codec.max_size("DrivingBoardDiagnostics")
    exact = h("42 fc 01") + body  # member 8, two-byte length 252
    assert len(exact) == MAX - TIMEOUT_WIDTH == 255
    assert codec.encode(payload, "exact") == exact
    assert codec.encode(payload, "pad") == exact + bytes(TIMEOUT_WIDTH)
    assert codec.encode(payload, "strip") == exact  # ends in the float 359.5: 00 c0 b3 43
    assert assert_all_forms(codec, payload) == exact
    # With the widest timeout the metadata field allows, it fills the envelope exactly.
    widest = exact + h("f0 01 ff ff ff ff 0f")  # field 30, varint 2**32 - 1
    assert len(widest) == MAX == codec.max_size("PBEnvelope")
    for mode in MODES:
        assert codec.encode(payload, mode, timeout=2**32 - 1) == widest
    assert codec.decode(widest).timeout == 2**32 - 1


def test_the_biggest_payload_stripped_and_two_byte_length(codec: Codec) -> None:
    """A 255-byte datagram whose last float ends in zero: stripped to 254 bytes."""
    payload = widest_driving_diagnostics(codec, last_angle=1e-40)
    exact = codec.encode(payload, "exact")
    assert len(exact) == MAX - TIMEOUT_WIDTH
    assert exact[:3] == h("42 fc 01")
    assert exact[-5:] == h("2d c2 16 01 00")
    stripped = codec.encode(payload, "strip")
    assert stripped == exact[:-1]
    for data in (exact, stripped, exact[:-1] + b"\0"):
        assert_decodes_to(codec, data, "drive_diag", payload)


@pytest.mark.parametrize("kind", list(ENVELOPE_MEMBERS.values()))
def test_every_payload_at_its_widest_is_its_max_size(codec: Codec, kind: str) -> None:
    field = descriptor(codec.message_class("PBEnvelope")).fields_by_name[kind]
    assert field.message_type is not None
    name = field.message_type.full_name
    payload = fill_widest(codec.message_class(name)())
    body = payload.SerializeToString()
    assert len(body) == codec.max_size(name)
    exact = assert_all_forms(codec, payload)
    tag = varint_size(field.number << 3)
    assert len(exact) == tag + varint_size(len(body)) + len(body) <= MAX


def test_a_payload_of_128_bytes_or_more_in_all_three_forms(codec: Codec) -> None:
    payload = fill_widest(new(codec, "SensorBoardDiagnostics"))
    payload.gps_sensor_1.utc_timestamp = 0  # no longer the widest...
    payload.gps_sensor_1.error_code = 0
    payload.gps_sensor_1.state = 0
    payload.gps_sensor_1.fix_quality = 0
    payload.gps_sensor_1.satellites = 0
    payload.gps_sensor_1.vdop = 1e-40  # ...and now ends in 00
    body = payload.SerializeToString()
    assert len(body) >= 128
    assert body.endswith(h("3d c2 16 01 00"))
    exact = assert_all_forms(codec, payload)
    assert exact[:3] == h("5a") + bytes([len(body) & 0x7F | 0x80, len(body) >> 7])
    assert codec.encode(payload, "strip") == exact[:-1]


# -- random payloads ---------------------------------------------------------------------------


def test_random_payloads_round_trip_in_all_three_forms(codec: Codec) -> None:
    count = ends_in_zero = 0
    for kind, payload in random_payloads(codec, seed=20240607, per_member=40):
        exact = assert_all_forms(codec, payload)
        assert member_of(codec, payload) == kind
        count += 1
        ends_in_zero += exact.endswith(b"\0")
    assert count == 21 * 40
    assert ends_in_zero > 50  # the generator does reach the cases stripping changes


# -- encode errors -----------------------------------------------------------------------------


def test_encode_rejects_a_type_that_is_not_a_payload(codec: Codec) -> None:
    motor = new(codec, "MotorInformation", motor_id=1)
    with pytest.raises(EncodeError, match=r"MotorInformation is not a payload type of PBEnvelope"):
        codec.encode(motor)


def test_encode_rejects_an_envelope_without_payload(codec: Codec) -> None:
    with pytest.raises(EncodeError, match=r"PBEnvelope has no payload"):
        codec.encode(new(codec, "PBEnvelope"), "exact")


@pytest.mark.parametrize("mode", ["bogus", "", "STRIP", "padded"])
def test_encode_rejects_an_unknown_mode(codec: Codec, mode: str) -> None:
    payload = new(codec, "BasestationControlMode", mode=1)
    envelope = new(codec, "PBEnvelope", control_mode=payload)
    for message in (payload, envelope):
        with pytest.raises(EncodeError, match=rf"unknown mode {mode!r}"):
            codec.encode(message, cast(Any, mode))


def test_unknown_fields_that_still_fit_are_sent(codec: Codec) -> None:
    # body = 5 (distance_to_go) + 3 (tag, two-byte length) + 251 = 259: envelope 1 + 2 + 259 = 262
    payload = with_unknown_field(codec, "DrivingBoardMotorMessage", 251)
    assert len(payload.SerializeToString()) == 259
    exact = codec.encode(payload, "exact")
    assert len(exact) == MAX
    assert exact == envelope_bytes(codec, "drive_motor", payload)
    assert codec.decode(exact).message.SerializeToString() == payload.SerializeToString()


@pytest.mark.parametrize("mode", MODES)
def test_unknown_fields_past_the_envelope_size_are_refused(
    codec: Codec, mode: erc_codec.Mode
) -> None:
    payload = with_unknown_field(codec, "DrivingBoardMotorMessage", 252)
    assert len(payload.SerializeToString()) == 260  # envelope would be 263 bytes
    envelope = new(codec, "PBEnvelope", drive_motor=payload)
    for message in (payload, envelope):
        with pytest.raises(EncodeError, match=r"DrivingBoardMotorMessage|PBEnvelope") as caught:
            codec.encode(message, mode)
        assert "262" in str(caught.value)


def test_unknown_fields_on_a_two_byte_tag_member(codec: Codec) -> None:
    # Member 17 has a two-byte tag: 258 payload bytes fit (2 + 2 + 258), 259 do not.
    fits = with_unknown_field(codec, "BasestationDetectedObject", 250)
    assert len(fits.SerializeToString()) == 258
    assert len(codec.encode(fits, "exact")) == MAX
    too_long = with_unknown_field(codec, "BasestationDetectedObject", 251)
    with pytest.raises(EncodeError, match="262"):
        codec.encode(too_long)


# -- encode never sends what its own decode refuses ---------------------------------------------


@pytest.mark.parametrize("mode", MODES)
def test_an_envelope_with_a_group_at_the_top_is_refused(codec: Codec, mode: erc_codec.Mode) -> None:
    """Parsed from 22 00 2b 2c, an envelope keeps field 5's group, which protobuf serializes
    again and decode refuses (no proto3 envelope holds one): encode says so instead of sending
    22002b2c."""
    envelope = codec.message_class("PBEnvelope").FromString(h("22 00 2b 2c"))
    assert envelope.SerializeToString() == h("22 00 2b 2c")
    with pytest.raises(erc_codec.DecodeError):
        codec.decode(h("22 00 2b 2c"))
    with pytest.raises(EncodeError, match=r"PBEnvelope cannot be sent: .*wire type 3"):
        codec.encode(envelope, mode)


ENVELOPE_CLASS = Codec.default().message_class("PBEnvelope")
KIND_NAMES = sorted(Codec.default().kinds().values())


@given(data=st.data())
@settings(max_examples=300)
def test_whatever_encodes_decodes_back(data: st.DataObject) -> None:
    """A payload or an envelope parsed from bytes with fields this schema lacks (groups, varints
    in no shortest form, zeros), sent in any form: encode refuses it, or decode gives it back."""
    codec = Codec.default()
    kind = data.draw(st.sampled_from(KIND_NAMES))
    payload = data.draw(payloads(codec, kind))
    unknown = data.draw(st.sampled_from(UNKNOWN_TAILS))
    cls = codec.payload_class(kind)
    try:
        parsed = cls.FromString(payload.SerializeToString() + unknown)
    except ProtobufDecodeError:
        return
    envelope = ENVELOPE_CLASS(**{kind: parsed})
    try:
        whole = ENVELOPE_CLASS.FromString(envelope.SerializeToString() + unknown)
    except ProtobufDecodeError:
        whole = envelope
    mode = data.draw(st.sampled_from(MODES))
    for message, expected in ((parsed, parsed), (whole, getattr(whole, kind))):
        try:
            datagram = codec.encode(message, mode)
        except EncodeError:
            continue
        decoded = codec.decode(datagram)
        assert decoded.kind == kind
        assert decoded.message.SerializeToString() == expected.SerializeToString()


# Fields the packaged schema lacks (numbers 23, 30 and 2047; a group, 5), as a newer sender or a
# relay may write them: ending in zeros, in varints longer than they need, in a group.
UNKNOWN_TAILS = [
    h("b8 01 00"),
    h("b8 01 80 00"),
    h("b8 01 85 80 00"),
    h("f5 01 00 00 00 00"),
    h("f2 01 02 00 00"),
    h("f8 ff 00 00"),
    h("f8 80 00 01"),
    h("2b 2c"),
    h("2b 08 00 2c"),
    h("ba 01 00"),
]
