"""The fixed-size contract on encode: what a nanopb receiver would drop or misread is refused."""

import random
import struct
from collections.abc import Iterator
from pathlib import Path
from typing import Any, cast

import pytest
from datagrams import (
    MODES,
    Build,
    assert_all_forms,
    descriptor,
    fill_random,
    fill_widest,
    h,
    members,
    new,
)
from google.protobuf.descriptor import Descriptor, FieldDescriptor
from google.protobuf.message import Message
from hypothesis import given, settings
from hypothesis import strategies as st

import erc_codec
from erc_codec import Codec, EncodeError, strategies
from erc_codec.schema import descriptor_of, enum_of, message_of

CODEC = erc_codec.Codec.default()
LIMITS = erc_codec.Codec.from_path(Path(__file__).parent / "contract_tree", root="LimitsEnvelope")
ENVELOPE = descriptor_of(CODEC.message_class("PBEnvelope"))


def enum_paths(descriptor: Descriptor, prefix: str = "") -> list[tuple[str, FieldDescriptor]]:
    """Dotted paths of every singular enum field, at any depth."""
    found = []
    for field in descriptor.fields:
        if field.type == FieldDescriptor.TYPE_ENUM and not field.is_repeated:
            found.append((prefix + field.name, field))
        elif field.type == FieldDescriptor.TYPE_MESSAGE and not field.is_repeated:
            found += enum_paths(message_of(field), f"{prefix}{field.name}.")
    return found


CASES = [
    (message_of(member).full_name, path, field)
    for member in ENVELOPE.fields
    for path, field in enum_paths(message_of(member))
]


def set_path(message: Message, path: str, value: int) -> None:
    *parents, name = path.split(".")
    for parent in parents:
        message = getattr(message, parent)
    setattr(message, name, value)


@pytest.mark.parametrize(("payload", "path", "field"), CASES, ids=[f"{c[0]}.{c[1]}" for c in CASES])
@given(data=st.data())
@settings(max_examples=20)
def test_an_undeclared_enum_value_anywhere_is_refused(
    payload: str, path: str, field: FieldDescriptor, data: st.DataObject
) -> None:
    message = data.draw(strategies.messages(CODEC, payload))
    declared = {value.number for value in enum_of(field).values}
    value = data.draw(st.integers(-(2**31), 2**31 - 1).filter(lambda v: v not in declared))
    set_path(message, path, value)
    with pytest.raises(erc_codec.EncodeError, match=rf"{payload}\.{path} = {value} is not"):
        CODEC.encode(message)


def test_the_big_payloads_are_screened_and_still_exact() -> None:
    # The driving board's diagnostics hold ten motors; the last one's state is checked too.
    diagnostics = CODEC.message_class("DrivingBoardDiagnostics")()
    diagnostics.steering_back_right_motor.state = 4  # type: ignore[attr-defined]
    with pytest.raises(erc_codec.EncodeError, match=r"steering_back_right_motor\.state = 4"):
        CODEC.encode(diagnostics)


def record(**values: Any) -> Message:
    return LIMITS.message_class("LimitsRecord")(**values)


@pytest.mark.parametrize(
    ("values", "complaint"),
    [
        ({"name": "ninechars"}, r"LimitsRecord.name is 9 bytes long, more than the 8 allowed"),
        ({"name": "éééé€"}, r"LimitsRecord.name is 11 bytes long"),
        ({"blob": b"12345"}, r"LimitsRecord.blob is 5 bytes long, more than the 4 allowed"),
        ({"counts": [1, 2, 3, 4]}, r"LimitsRecord.counts holds 4 items, more than its max_count 3"),
        ({"colours": [1, 7]}, r"LimitsRecord.colours\[1\] = 7 is not a declared value"),
        ({"points": [{"x": 200}]}, r"LimitsPoint.x = 200 does not fit nanopb int_size"),
        ({"points": [{"colour": 2}]}, r"LimitsPoint.colour = 2 is not a declared value"),
        ({"palette": {1: 1, 2: 1, 3: 1}}, r"LimitsRecord.palette holds 3 items"),
        ({"palette": {1: 5}}, r"LimitsRecord.palette\[0\] = 5 is not a declared value"),
        ({"small": 65536}, r"LimitsRecord.small = 65536 does not fit nanopb int_size \(0..65535\)"),
        ({"colour": 299}, r"LimitsRecord.colour = 299 is not a declared value of LimitsColour"),
        ({"origin": {"colour": 2}}, r"LimitsRecord.origin.colour = 2 is not a declared value"),
        ({"origin": {"x": 128}}, r"LimitsPoint.x = 128 does not fit nanopb int_size"),
        ({"places": {1: {}, 2: {}, 3: {}}}, r"LimitsRecord.places holds 3 items"),
        ({"places": {7: {"x": -129}}}, r"LimitsPoint.x = -129 does not fit nanopb int_size"),
    ],
)
def test_nanopb_limits_are_enforced(values: dict[str, Any], complaint: str) -> None:
    with pytest.raises(erc_codec.EncodeError, match=complaint):
        LIMITS.encode(record(**values))


def test_values_at_the_limits_are_sent() -> None:
    widest = record(
        name="€€ab",  # 8 bytes
        blob=b"1234",
        counts=[1, 2, 3],
        colours=[1, 300],
        points=[{"x": -128, "colour": 300}, {"x": 127}],
        palette={1: 300, 2: 0},
        small=65535,
        colour=300,
        origin={"x": 127, "colour": 1},
        places={1: {"x": -128, "colour": 300}, 2: {}},
    )
    assert LIMITS.decode(LIMITS.encode(widest)).message == widest


@given(strategies.messages(LIMITS, "LimitsRecord"))
def test_strategies_respect_every_limit(message: Message) -> None:
    assert LIMITS.decode(LIMITS.encode(message)).message == message


# -- undeclared enum values, payload by payload ------------------------------------------------


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


def _payload_enum_cases(codec: Codec) -> Iterator[tuple[str, str, str, list[int], str]]:
    """(member, payload type, dotted path, declared numbers, enum full name) of every enum field
    of every payload."""
    for member in members(codec):
        payload = message_of(member)
        for path, field in enum_paths(payload):
            numbers = [value.number for value in enum_of(field).values]
            yield member.name, payload.full_name, path, numbers, enum_of(field).full_name


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
