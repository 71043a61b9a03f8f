"""The public codec: PBEnvelope datagrams in exact, stripped and zero-padded form.

The helpers and the hard cases these tests share with other modules are in tests/datagrams.py.
"""

import math
import random
import struct
from collections.abc import Iterator
from pathlib import Path
from typing import Any, cast

import pytest
from conftest import PROTO
from datagrams import (
    ENVELOPE_MEMBERS,
    HARD_CASES,
    MAX,
    MODES,
    Build,
    assert_all_forms,
    assert_decodes_to,
    descriptor,
    envelope_bytes,
    f32,
    fill_random,
    fill_widest,
    h,
    member_of,
    members,
    new,
    random_payloads,
    valid_datagrams,
    varint_size,
    widest_driving_diagnostics,
    with_unknown_field,
)
from google.protobuf.descriptor import Descriptor
from google.protobuf.message import DecodeError as ProtobufDecodeError
from google.protobuf.message import Message

import erc_codec
from erc_codec import Codec, Decoded, DecodeError, EncodeError

# -- the codec's public surface ----------------------------------------------------------------


def test_kinds_are_the_envelope_members(codec: Codec) -> None:
    assert codec.kinds() == ENVELOPE_MEMBERS


def test_kinds_returns_a_copy(codec: Codec) -> None:
    codec.kinds().clear()
    assert codec.kinds() == ENVELOPE_MEMBERS


@pytest.mark.parametrize(
    ("name", "size"),
    [
        ("PBEnvelope", 255),
        ("DrivingBoardDiagnostics", 252),  # 2 + 10 * (1 + 1 + 23)
        ("MotorInformation", 23),  # 2 + 6 + 5 + 5 + 5
        ("SensorBoardGPSInfo", 71),  # 9 + 9 + 5 * 5 + 11 + 3 * 2 + 11
        ("SensorBoardDiagnostics", 159),
        ("ArmBoardMovementFeedback", 2),
        ("BasestationRoverLocalization", 56),  # 9 * 5 + 11
        ("DrivingBoardMotorPeriodicProgress", 5),
    ],
)
def test_max_size(codec: Codec, name: str, size: int) -> None:
    assert codec.max_size(name) == size


def test_message_class_is_the_envelope_member_class(codec: Codec) -> None:
    envelope = new(codec, "PBEnvelope")
    assert type(envelope.gps_info) is codec.message_class("SensorBoardGPSInfo")
    assert descriptor(codec.message_class("MotorInformation")).full_name == "MotorInformation"


def test_decoded_is_a_named_tuple(codec: Codec) -> None:
    payload = new(codec, "BasestationControlMode", mode=2)
    decoded = codec.decode(codec.encode(payload))
    kind, message = decoded
    assert kind == "control_mode"
    assert message == payload
    assert Decoded._fields == ("kind", "message")
    assert decoded._fields == ("kind", "message")
    assert isinstance(decoded, Decoded)
    assert issubclass(Decoded, tuple)
    assert decoded.kind == decoded[0] == "control_mode"
    assert decoded.message is decoded[1]
    assert decoded == ("control_mode", payload)


def test_errors_share_one_base_class() -> None:
    for error in (erc_codec.DecodeError, erc_codec.EncodeError, erc_codec.SchemaError):
        assert issubclass(error, erc_codec.CodecError)
    assert issubclass(erc_codec.CodecError, Exception)


# -- encoding: the three forms -----------------------------------------------------------------


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
    envelope.arm_movement_feedback.SetInParent()
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
        assert codec.decode(data) == ("driving_motor_periodic_progress", payload)


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
    assert len(exact) == MAX == codec.max_size("PBEnvelope")
    assert codec.encode(payload, "exact") == exact
    assert codec.encode(payload, "pad") == exact  # already as long as it gets
    assert codec.encode(payload, "strip") == exact  # ends in the float 359.5: 00 c0 b3 43
    assert assert_all_forms(codec, payload) == exact


def test_the_biggest_payload_stripped_and_two_byte_length(codec: Codec) -> None:
    """A 255-byte datagram whose last float ends in zero: stripped to 254 bytes."""
    payload = widest_driving_diagnostics(codec, last_angle=1e-40)
    exact = codec.encode(payload, "exact")
    assert len(exact) == MAX
    assert exact[:3] == h("42 fc 01")
    assert exact[-5:] == h("2d c2 16 01 00")
    stripped = codec.encode(payload, "strip")
    assert stripped == exact[:-1]
    for data in (exact, stripped, exact[:-1] + b"\0"):
        assert_decodes_to(codec, data, "driving_diagnostics", payload)


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


def _gps_fix_99(codec: Codec) -> Message:
    return cast(Message, new(codec, "SensorBoardGPSInfo", latitude=1.0, fix_quality=99))


def _nested_gps_fix_minus_one(codec: Codec) -> Message:
    message = new(codec, "SensorBoardDiagnostics", state=1)
    message.gps_sensor_1.fix_quality = -1
    return cast(Message, message)


def _nested_motor_state_7(codec: Codec) -> Message:
    message = new(codec, "DrivingBoardDiagnostics", state=1)
    message.front_left_motor.state = 2
    message.back_left_motor.state = 7
    return cast(Message, message)


def _top_level_state_1000(codec: Codec) -> Message:
    return cast(Message, new(codec, "ArmBoardDiagnostics", state=1000))


def _nested_sensor_state(codec: Codec) -> Message:
    message = new(codec, "SensorBoardDiagnostics")
    message.imu_sensor.error_code = 9
    return cast(Message, message)


ENUM_ERRORS: list[tuple[str, Build, str, str, str]] = [
    ("top level", _gps_fix_99, "gps_info", "SensorBoardGPSInfo.fix_quality", "= 99"),
    (
        "nested -1",
        _nested_gps_fix_minus_one,
        "sensor_diagnostics",
        "SensorBoardDiagnostics.gps_sensor_1.fix_quality",
        "= -1",
    ),
    (
        "nested motor",
        _nested_motor_state_7,
        "driving_diagnostics",
        "DrivingBoardDiagnostics.back_left_motor.state",
        "= 7",
    ),
    ("wide value", _top_level_state_1000, "arm_diagnostics", "ArmBoardDiagnostics.state", "= 1000"),
    (
        "nested imu",
        _nested_sensor_state,
        "sensor_diagnostics",
        "SensorBoardDiagnostics.imu_sensor.error_code",
        "= 9",
    ),
]
_ENUM_NAMES = {
    "top level": "GPSFixQuality",
    "nested -1": "GPSFixQuality",
    "nested motor": "MotorState",
    "wide value": "ArmBoardState",
    "nested imu": "IMUErrorCode",
}


@pytest.mark.parametrize(
    ("case", "build", "kind", "path", "value"),
    ENUM_ERRORS,
    ids=[case[0] for case in ENUM_ERRORS],
)
@pytest.mark.parametrize("mode", MODES)
def test_encode_rejects_undeclared_enum_values(
    codec: Codec, case: str, build: Build, kind: str, path: str, value: str, mode: erc_codec.Mode
) -> None:
    payload = build(codec)
    envelope = new(codec, "PBEnvelope")
    getattr(envelope, kind).CopyFrom(payload)
    for message in (payload, envelope):
        with pytest.raises(EncodeError) as caught:
            codec.encode(message, mode)
        text = str(caught.value)
        assert path in text
        assert value in text
        assert _ENUM_NAMES[case] in text


def test_an_enum_error_clears_once_the_value_is_declared(codec: Codec) -> None:
    message = new(codec, "DrivingBoardDiagnostics")
    message.back_left_motor.state = 7
    with pytest.raises(EncodeError, match=r"DrivingBoardDiagnostics\.back_left_motor\.state = 7"):
        codec.encode(message)
    message.back_left_motor.state = 3  # declared again: fine
    assert codec.decode(codec.encode(message)).message == message


def enum_paths(message: Descriptor, prefix: str = "") -> Iterator[tuple[str, list[int], str]]:
    """(dotted path, declared numbers, enum full name) of every enum field below ``message``."""
    for field in message.fields:
        if field.enum_type is not None:
            numbers = [value.number for value in field.enum_type.values]
            yield prefix + field.name, numbers, field.enum_type.full_name
        elif field.message_type is not None:
            yield from enum_paths(field.message_type, f"{prefix}{field.name}.")


def set_path(message: Any, path: str, value: int) -> None:
    *parents, name = path.split(".")
    for parent in parents:
        message = getattr(message, parent)
    setattr(message, name, value)


def _payload_enum_cases(codec: Codec) -> Iterator[tuple[str, str, str, list[int], str]]:
    for field in members(codec):
        assert field.message_type is not None
        for path, numbers, enum in enum_paths(field.message_type):
            yield field.name, field.message_type.full_name, path, numbers, enum


def test_every_enum_field_of_every_payload_is_checked(codec: Codec) -> None:
    """An undeclared value anywhere, whatever the rest of the payload holds, is refused."""
    rng = random.Random(99)
    cases = list(_payload_enum_cases(codec))
    assert len(cases) >= 40
    refused = 0
    for kind, name, path, numbers, enum in cases:
        undeclared = [max(numbers) + 1, 99, 127, 128, 1000, 2**31 - 1, -1, -(2**31)]
        for value in undeclared:
            assert value not in numbers
            for filler in ("empty", "widest", "random"):
                payload = codec.message_class(name)()
                if filler == "widest":
                    fill_widest(payload)
                elif filler == "random":
                    fill_random(rng, payload)
                set_path(payload, path, value)
                envelope = new(codec, "PBEnvelope")
                getattr(envelope, kind).CopyFrom(payload)
                for message in (payload, envelope):
                    mode = rng.choice(MODES)
                    with pytest.raises(EncodeError) as caught:
                        codec.encode(message, mode)
                    text = str(caught.value)
                    assert f"{name}.{path} = {value}" in text, (text, name, path, value)
                    assert enum in text, text
                    refused += 1
    assert refused == len(cases) * 8 * 3 * 2


def test_float_bytes_that_look_like_a_bad_enum_are_not_refused(codec: Codec) -> None:
    """Bytes of a float can spell an enum tag and an undeclared value: that is no error."""
    (lookalike,) = struct.unpack("<f", h("08 07 08 63"))  # "state = 7", "state = 99"
    (negative,) = struct.unpack("<f", h("08 ff 48 ff"))  # "state = -1...", "fix_quality = ..."
    message = new(codec, "DrivingBoardDiagnostics", state=2)
    for field in descriptor(message).fields[1:]:
        motor = getattr(message, field.name)
        motor.state = 1
        motor.rpm = lookalike
        motor.voltage = negative
        motor.encoder_angle = lookalike
    body = message.SerializeToString()
    assert h("08 07") in body
    assert h("08 ff") in body
    assert_all_forms(codec, message)
    sensors = new(codec, "SensorBoardDiagnostics", state=1, board_temperature=lookalike)
    sensors.gps_sensor_1.altitude = negative
    sensors.imu_sensor.accel_x = struct.unpack("<f", h("70 63 78 63"))[0]  # state, error_code
    sensors.imu_sensor.error_code = 8
    assert_all_forms(codec, sensors)


@pytest.mark.parametrize("mode", ["bogus", "", "STRIP", "padded"])
def test_encode_rejects_an_unknown_mode(codec: Codec, mode: str) -> None:
    payload = new(codec, "BasestationControlMode", mode=1)
    envelope = new(codec, "PBEnvelope", control_mode=payload)
    for message in (payload, envelope):
        with pytest.raises(EncodeError, match=rf"unknown mode {mode!r}"):
            codec.encode(message, cast(Any, mode))


def test_unknown_fields_that_still_fit_are_sent(codec: Codec) -> None:
    # body = 5 (distance_to_go) + 3 (tag, two-byte length) + 244 = 252: envelope 1 + 2 + 252 = 255
    payload = with_unknown_field(codec, "DrivingBoardMotorMessage", 244)
    assert len(payload.SerializeToString()) == 252
    exact = codec.encode(payload, "exact")
    assert len(exact) == MAX
    assert exact == envelope_bytes(codec, "driving_motor_message", payload)
    assert codec.decode(exact).message.SerializeToString() == payload.SerializeToString()


@pytest.mark.parametrize("mode", MODES)
def test_unknown_fields_past_the_envelope_size_are_refused(
    codec: Codec, mode: erc_codec.Mode
) -> None:
    payload = with_unknown_field(codec, "DrivingBoardMotorMessage", 245)
    assert len(payload.SerializeToString()) == 253  # envelope would be 256 bytes
    envelope = new(codec, "PBEnvelope", driving_motor_message=payload)
    for message in (payload, envelope):
        with pytest.raises(EncodeError, match=r"DrivingBoardMotorMessage|PBEnvelope") as caught:
            codec.encode(message, mode)
        assert "255" in str(caught.value)


def test_unknown_fields_on_a_two_byte_tag_member(codec: Codec) -> None:
    # Member 17 has a two-byte tag: 251 payload bytes fit (2 + 2 + 251), 252 do not.
    fits = with_unknown_field(codec, "BasestationDetectedObject", 243)
    assert len(fits.SerializeToString()) == 251
    assert len(codec.encode(fits, "exact")) == MAX
    too_long = with_unknown_field(codec, "BasestationDetectedObject", 244)
    with pytest.raises(EncodeError, match="255"):
        codec.encode(too_long)


# -- classes from elsewhere --------------------------------------------------------------------


@pytest.fixture(scope="module")
def other() -> Codec:
    """A second codec over the same tree: same full names, different classes."""
    return Codec.from_path(PROTO)


def test_a_second_codec_has_its_own_classes(codec: Codec, other: Codec) -> None:
    assert other is not codec
    assert other.message_class("SensorBoardGPSInfo") is not codec.message_class(
        "SensorBoardGPSInfo"
    )
    assert other.kinds() == codec.kinds()
    assert other.max_size("PBEnvelope") == MAX


@pytest.mark.parametrize(
    ("build", "kind", "exact", "stripped"),
    [case[1:] for case in HARD_CASES],
    ids=[case[0] for case in HARD_CASES],
)
def test_a_payload_of_another_class_with_the_same_name_encodes_identically(
    codec: Codec, other: Codec, build: Build, kind: str, exact: str, stripped: str
) -> None:
    foreign = build(other)
    native = build(codec)
    assert type(foreign) is not type(native)
    for mode in MODES:
        assert codec.encode(foreign, mode) == codec.encode(native, mode)
    assert codec.encode(foreign, "exact") == h(exact)
    assert codec.encode(foreign, "strip") == h(stripped)
    foreign_envelope = new(other, "PBEnvelope")
    getattr(foreign_envelope, kind).CopyFrom(foreign)
    assert codec.encode(foreign_envelope, "exact") == h(exact)


def test_foreign_widest_payload_and_errors(codec: Codec, other: Codec) -> None:
    foreign = widest_driving_diagnostics(other)
    assert codec.encode(foreign, "exact") == codec.encode(widest_driving_diagnostics(codec))
    foreign.back_left_motor.state = 7
    with pytest.raises(EncodeError, match=r"DrivingBoardDiagnostics\.back_left_motor\.state"):
        codec.encode(foreign)
    with pytest.raises(EncodeError, match=r"MotorInformation is not a payload type"):
        codec.encode(new(other, "MotorInformation"))
    with pytest.raises(EncodeError, match=r"unknown mode"):
        codec.encode(new(other, "BasestationControlMode"), cast(Any, "bogus"))
    too_long = with_unknown_field(other, "DrivingBoardMotorMessage", 245)
    with pytest.raises(EncodeError, match="255"):
        codec.encode(too_long)


def test_random_foreign_payloads_encode_identically(codec: Codec, other: Codec) -> None:
    natives = random_payloads(codec, seed=7, per_member=5)
    foreigns = random_payloads(other, seed=7, per_member=5)
    for (kind, native), (same, foreign) in zip(natives, foreigns, strict=True):
        assert kind == same
        for mode in MODES:
            assert codec.encode(foreign, mode) == codec.encode(native, mode)


# -- module-level functions --------------------------------------------------------------------


def test_module_level_functions_round_trip(codec: Codec) -> None:
    payload = new(codec, "SensorBoardGPSInfo", latitude=46.5, longitude=6.6, satellites=9)
    assert erc_codec.encode(payload) == codec.encode(payload, "strip")
    for mode in MODES:
        data = erc_codec.encode(payload, mode)
        assert data == codec.encode(payload, mode)
        kind, message = erc_codec.decode(data)
        assert kind == "gps_info"
        assert message == payload


def test_module_level_functions_use_the_default_codec(codec: Codec) -> None:
    assert Codec.default() is codec
    assert erc_codec.decode(h("22")) == (
        "arm_movement_feedback",
        new(codec, "ArmBoardMovementFeedback"),
    )
    with pytest.raises(DecodeError):
        erc_codec.decode(b"")
    with pytest.raises(EncodeError):
        erc_codec.encode(new(codec, "MotorInformation"))


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
    ("length of zeros only", h("22 05"), r"ArmBoardMovementFeedback|arm_movement_feedback"),
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


# -- decode never raises anything but DecodeError ----------------------------------------------


def decode_outcome(codec: Codec, data: bytes) -> Decoded | DecodeError:
    """Decode, turning a DecodeError into a value; any other exception propagates (and fails)."""
    try:
        return codec.decode(data)
    except DecodeError as error:
        return error


def test_random_bytes_raise_only_decode_error(codec: Codec) -> None:
    rng = random.Random(0xE2C)
    decoded = 0
    for index in range(4000):
        data = rng.randbytes(index % 301)
        if isinstance(decode_outcome(codec, data), Decoded):
            decoded += 1
    # Random bytes that start with a member tag do sometimes decode; most do not.
    assert decoded < 400


def test_random_bytes_behind_a_member_tag_raise_only_decode_error(codec: Codec) -> None:
    rng = random.Random(255)
    tags = [h("0a"), h("22"), h("42"), h("5a"), h("62"), h("82 01"), h("aa 01"), h("b2 01")]
    outcomes = {True: 0, False: 0}
    for _ in range(4000):
        length = rng.randrange(0, 260)
        prefix = rng.choice(tags) + bytes([min(length, 127)])
        data = (prefix + rng.randbytes(rng.randrange(0, 40)))[: rng.randrange(1, 60)]
        if rng.random() < 0.3:
            data += bytes(rng.randrange(0, 255))
        outcomes[isinstance(decode_outcome(codec, data), Decoded)] += 1
    assert outcomes[True] > 0
    assert outcomes[False] > 0


def test_truncations_and_bit_flips_raise_only_decode_error(codec: Codec) -> None:
    seen = 0
    for data in valid_datagrams(codec):
        for cut in range(len(data)):
            decode_outcome(codec, data[:cut])
            decode_outcome(codec, data[cut + 1 :])
            decode_outcome(codec, data[:cut] + data[cut + 1 :])
            seen += 3
        for bit in range(len(data) * 8):
            flipped = bytearray(data)
            flipped[bit // 8] ^= 1 << (bit % 8)
            decode_outcome(codec, bytes(flipped))
            seen += 1
    assert seen > 10_000


def test_cutting_only_trailing_zeros_never_changes_the_message(codec: Codec) -> None:
    for data in valid_datagrams(codec):
        expected = codec.decode(data)
        stripped = data.rstrip(b"\0")
        for length in range(len(stripped), len(data) + 1):
            assert codec.decode(data[:length]) == expected


# -- explicit presence and fixed-width integers (tests/schema_trees/presence) --------------------

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
