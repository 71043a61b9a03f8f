"""What the codec's test modules share: datagrams written out by hand and payloads at the edges.

Imported as conftest is (``from datagrams import h, new``); it holds no tests. Expected bytes are
written out by hand from the protobuf wire format and cross-checked against protobuf's own
serialization of the envelope. The packaged schema's PBEnvelope has 21 members; members 1..15 have
one-byte tags (``number << 3 | 2``), members 16..21 two-byte tags.

The one generator of hostile datagrams is here too (``hostile_datagrams``): the fuzzer of
test_properties.py runs on it, and so do the tests holding a speed trick of the decoding side to
its plain version.
"""

import functools
import math
import random
import struct
from collections.abc import Callable, Iterable, Iterator
from typing import Any, cast

from google.protobuf.descriptor import Descriptor, FieldDescriptor
from google.protobuf.message import Message
from hypothesis import strategies as st

import erc_codec
from erc_codec import Codec, Decoded, strategies
from erc_schema import LEN, encode_varint

MAX = 262  # nanopb's PBEnvelope_size for the packaged schema: the widest payload, 255, + 7
TIMEOUT_WIDTH = 7  # the metadata field `timeout = 30` at its widest: a two-byte tag + 5
MODES: tuple[erc_codec.Mode, ...] = ("exact", "strip", "pad")
_T = FieldDescriptor

# The fleet's own envelope member names (RoboTeamTwente/ERC-Protobufs, envelope.proto), 1 to 21.
ENVELOPE_MEMBERS = {
    1: "ph_info",
    2: "arm_ctrl",
    3: "arm_diag",
    4: "arm_feedback",
    5: "arm_pos",
    6: "arm_target",
    7: "arm_obstructions",
    8: "drive_diag",
    9: "drive_motor",
    10: "drive_progress",
    11: "sensor_diag",
    12: "gps_info",
    13: "imu_info",
    14: "load_cell_info",
    15: "pressure_info",
    16: "control_mode",
    17: "detected_object",
    18: "object_selection",
    19: "rock_measure_request",
    20: "rock_measure_result",
    21: "rover_localization",
}

# -- bytes and messages ------------------------------------------------------------------------


def new(codec: Codec, name: str, **fields: Any) -> Any:
    """A message of the codec's schema (typed Any: its fields are only known at run time)."""
    return codec.message_class(name)(**fields)


def descriptor(message: Message | type[Message]) -> Descriptor:
    return cast(Descriptor, message.DESCRIPTOR)


def h(text: str) -> bytes:
    return bytes.fromhex(text)


def f32(value: float) -> bytes:
    return struct.pack("<f", value)


def varint_size(value: int) -> int:
    """The length of ``value`` as a protobuf varint (a negative int32/int64 takes ten bytes)."""
    return 10 if value < 0 else max(1, (value.bit_length() + 6) // 7)


def members(codec: Codec) -> list[FieldDescriptor]:
    """The envelope's member fields, in number order."""
    return list(descriptor(codec.message_class("PBEnvelope")).oneofs[0].fields)


def envelope_bytes(codec: Codec, kind: str, payload: Message) -> bytes:
    """protobuf's own serialization of a PBEnvelope carrying ``payload`` as member ``kind``."""
    envelope = new(codec, "PBEnvelope")
    getattr(envelope, kind).CopyFrom(payload)
    assert envelope.WhichOneof("payload") == kind
    data: bytes = envelope.SerializeToString()
    return data


def member_of(codec: Codec, payload: Message) -> str:
    """The envelope member carrying payloads of this type (the packaged schema has one each)."""
    name = descriptor(payload).full_name
    envelope = descriptor(codec.message_class("PBEnvelope"))
    (kind,) = [
        f.name for f in envelope.fields if f.message_type and f.message_type.full_name == name
    ]
    return kind


def with_unknown_field(codec: Codec, name: str, length: int) -> Any:
    """A payload parsed from bytes carrying an unknown field 15 (LEN) of ``length`` bytes."""
    extra = h("7a") + bytes([length & 0x7F | 0x80, length >> 7]) + b"\x01" * length
    assert length >= 128
    return codec.message_class(name).FromString(h("0d") + f32(2.0) + extra)


def beside(numbers: Iterable[int]) -> bytes:
    """An all-default gps_info with, beside it on the envelope, a varint field (value 1) of each
    of ``numbers``, which the packaged envelope lacks (1000 to 2047 take two-byte tags: 80 of
    them fit in a datagram)."""
    return h("6200") + b"".join(encode_varint(number << 3) + b"\x01" for number in numbers)


# -- assertions --------------------------------------------------------------------------------


def assert_decodes_to(codec: Codec, data: bytes, kind: str, payload: Message) -> None:
    decoded = codec.decode(data)
    assert isinstance(decoded, Decoded)
    assert decoded.kind == kind
    assert type(decoded.message) is type(payload)
    assert decoded.message == payload
    assert decoded.message.SerializeToString() == payload.SerializeToString()


def assert_all_forms(codec: Codec, payload: Message) -> bytes:
    """Encode in every mode, check the forms against each other and decode each; return exact."""
    kind = member_of(codec, payload)
    exact = codec.encode(payload, "exact")
    assert exact == envelope_bytes(codec, kind, payload)
    assert codec.encode(payload, "strip") == exact.rstrip(b"\0")
    assert codec.encode(payload, "pad") == exact + bytes(MAX - len(exact))
    assert len(codec.encode(payload, "pad")) == MAX
    for mode in MODES:
        assert_decodes_to(codec, codec.encode(payload, mode), kind, payload)
    return exact


# -- the hard cases ----------------------------------------------------------------------------

# The hard cases of stripping: encodings that end in 0x00 (so stripping removes
# bytes a naive "parse what came" receiver needs) and encodings that must not be touched.
# (id, builder, member, exact, stripped)
Build = Callable[[Codec], Message]


def gps_empty(codec: Codec) -> Message:
    message = new(codec, "SensorBoardDiagnostics")
    message.gps_sensor_1.SetInParent()
    return cast(Message, message)


def _last_motor_empty(codec: Codec) -> Message:
    message = new(codec, "DrivingBoardDiagnostics", state=1)
    message.steering_back_right_motor.SetInParent()
    return cast(Message, message)


def _only_last_motor_empty(codec: Codec) -> Message:
    message = new(codec, "DrivingBoardDiagnostics")
    message.steering_back_right_motor.SetInParent()
    return cast(Message, message)


def _arm_gripper_with_empty_fields(codec: Codec) -> Message:
    message = new(codec, "ArmBoardControlSignals")
    message.base.angle = 90.0
    message.gripper.SetInParent()
    return cast(Message, message)


def _m(name: str, **fields: Any) -> Build:
    return lambda codec: cast(Message, new(codec, name, **fields))


HARD_CASES: list[tuple[str, Build, str, str, str]] = [
    (
        "all-default feedback",
        _m("ArmBoardMovementFeedback"),
        "arm_feedback",
        "22 00",
        "22",
    ),
    (
        "feedback ALL_OK set explicitly",
        _m("ArmBoardMovementFeedback", error_code=0),
        "arm_feedback",
        "22 00",
        "22",
    ),
    (
        "control mode 0 (two-byte tag)",
        _m("BasestationControlMode", mode=0),
        "control_mode",
        "82 01 00",
        "82 01",
    ),
    (
        "stop command: zero speeds",
        _m("DrivingBoardMotorMessage", distance_to_go=0.0, turning_radius=0.0),
        "drive_motor",
        "4a 00",
        "4a",
    ),
    (
        "all-default localization (two-byte tag)",
        _m("BasestationRoverLocalization"),
        "rover_localization",
        "aa 01 00",
        "aa 01",
    ),
    (
        "all-default rock measure result (two-byte tag)",
        _m("BasestationRockMeasureResult"),
        "rock_measure_result",
        "a2 01 00",
        "a2 01",
    ),
    (
        "all-default ph info (member 1)",
        _m("SensorBoardPHInfo"),
        "ph_info",
        "0a 00",
        "0a",
    ),
    (
        "last field an empty gps submessage",
        gps_empty,
        "sensor_diag",
        "5a 02 32 00",
        "5a 02 32",
    ),
    (
        "last motor present but empty",
        _last_motor_empty,
        "drive_diag",
        "42 04 08 01 5a 00",
        "42 04 08 01 5a",
    ),
    (
        "only the last motor, empty",
        _only_last_motor_empty,
        "drive_diag",
        "42 02 5a 00",
        "42 02 5a",
    ),
    (
        "last arm joint present but empty",
        _arm_gripper_with_empty_fields,
        "arm_ctrl",
        "12 09 0a 05 0d 00 00 b4 42 32 00",
        "12 09 0a 05 0d 00 00 b4 42 32",
    ),
    (
        "last float denormal 1e-40",
        _m("DrivingBoardMotorPeriodicProgress", distance_left=1e-40),
        "drive_progress",
        "52 05 0d c2 16 01 00",
        "52 05 0d c2 16 01",
    ),
    (
        "last float smallest denormal 1e-45",
        _m("BasestationRockMeasureResult", request_id=7, status=1, distance=1e-45),
        "rock_measure_result",
        "a2 01 09 08 07 10 01 35 01 00 00 00",
        "a2 01 09 08 07 10 01 35 01",
    ),
    (
        "last double small: 64-bit fixed 1 (5e-324)",
        _m("SensorBoardGPSInfo", latitude=5e-324),
        "gps_info",
        "62 09 09 01 00 00 00 00 00 00 00",
        "62 09 09 01",
    ),
    (
        "last double 2.0: seven zero bytes then 0x40",
        _m("SensorBoardGPSInfo", latitude=2.0),
        "gps_info",
        "62 09 09 00 00 00 00 00 00 00 40",
        "62 09 09 00 00 00 00 00 00 00 40",
    ),
    (
        "last int64 small",
        _m("BasestationDetectedObject", timestamp_ms=1),
        "detected_object",
        "8a 01 02 50 01",
        "8a 01 02 50 01",
    ),
    (
        "last int64 negative: ten-byte varint",
        _m("BasestationRoverLocalization", timestamp_ms=-1),
        "rover_localization",
        "aa 01 0b 50 ff ff ff ff ff ff ff ff ff 01",
        "aa 01 0b 50 ff ff ff ff ff ff ff ff ff 01",
    ),
    (
        "negative zero floats",
        _m("DrivingBoardMotorMessage", distance_to_go=-0.0, turning_radius=-0.0),
        "drive_motor",
        "4a 0a 0d 00 00 00 80 15 00 00 00 80",
        "4a 0a 0d 00 00 00 80 15 00 00 00 80",
    ),
    (
        "negative zero then a denormal last",
        _m("DrivingBoardMotorMessage", distance_to_go=-0.0, turning_radius=1e-40),
        "drive_motor",
        "4a 0a 0d 00 00 00 80 15 c2 16 01 00",
        "4a 0a 0d 00 00 00 80 15 c2 16 01",
    ),
    (
        "negative zero double",
        _m("SensorBoardGPSInfo", longitude=-0.0),
        "gps_info",
        "62 09 11 00 00 00 00 00 00 00 80",
        "62 09 11 00 00 00 00 00 00 00 80",
    ),
    (
        "negative int32 in the middle: ten bytes",
        _m("SensorBoardLoadCellInfo", raw_counts=-1, is_calibrated=True),
        "load_cell_info",
        "72 0d 20 ff ff ff ff ff ff ff ff ff 01 28 01",
        "72 0d 20 ff ff ff ff ff ff ff ff ff 01 28 01",
    ),
]

# -- the longest payloads ----------------------------------------------------------------------

_WIDEST: dict[int, Any] = {
    _T.TYPE_FLOAT: 1.5,
    _T.TYPE_DOUBLE: -1.5,
    _T.TYPE_INT32: -1,
    _T.TYPE_INT64: -1,
    _T.TYPE_SINT32: -(2**31),
    _T.TYPE_SINT64: -(2**63),
    _T.TYPE_UINT32: 2**32 - 1,
    _T.TYPE_UINT64: 2**64 - 1,
    _T.TYPE_FIXED32: 2**32 - 1,
    _T.TYPE_FIXED64: 2**64 - 1,
    _T.TYPE_SFIXED32: -1,
    _T.TYPE_SFIXED64: -1,
    _T.TYPE_BOOL: True,
}


def fill_widest(message: Any) -> Any:
    """Set every field of ``message`` to the value with the longest encoding; return it."""
    for field in descriptor(message).fields:
        if field.type == _T.TYPE_MESSAGE:
            fill_widest(getattr(message, field.name))
        elif field.type == _T.TYPE_ENUM:
            assert field.enum_type is not None
            numbers = [value.number for value in field.enum_type.values]
            setattr(message, field.name, max(numbers, key=lambda n: (varint_size(n), n)))
        else:
            setattr(message, field.name, _WIDEST[field.type])
    return message


def widest_driving_diagnostics(codec: Codec, last_angle: float = 359.5) -> Any:
    message = new(codec, "DrivingBoardDiagnostics", state=3)
    for field in descriptor(message).fields[1:]:
        motor = getattr(message, field.name)
        motor.state = 3
        motor.motor_id = 2**32 - 1
        motor.rpm = -1500.25
        motor.voltage = 24.5
        motor.encoder_angle = 359.5
    message.steering_back_right_motor.encoder_angle = last_angle
    return message


def valid_datagrams(codec: Codec) -> list[bytes]:
    """The edges of the envelope in every form: 255 bytes (the widest payload) with a two-byte
    length, a stripped 255-byte datagram, the widest payloads with and without zeros at the
    end, empty ones."""
    payloads: list[Message] = [
        widest_driving_diagnostics(codec),
        widest_driving_diagnostics(codec, last_angle=1e-40),
        fill_widest(new(codec, "SensorBoardDiagnostics")),
        fill_widest(new(codec, "BasestationRoverLocalization")),
        new(codec, "DrivingBoardMotorPeriodicProgress", distance_left=1e-40),
        new(codec, "ArmBoardMovementFeedback"),
        gps_empty(codec),
    ]
    return [codec.encode(payload, mode) for payload in payloads for mode in MODES]


# -- random payloads ---------------------------------------------------------------------------

_POOLS: dict[int, list[Any]] = {
    _T.TYPE_FLOAT: [0.0, -0.0, 1e-40, 1e-45, 1.0, -2.5, 3.4e38, -math.inf, 1.1754943508e-38],
    _T.TYPE_DOUBLE: [0.0, -0.0, 5e-324, 2.2250738585072014e-308, 1.0, -123.456, 1e300, math.inf],
    _T.TYPE_INT32: [0, 1, -1, 127, 128, 2**31 - 1, -(2**31)],
    _T.TYPE_INT64: [0, 1, -1, 1_700_000_000_000, 2**63 - 1, -(2**63)],
    _T.TYPE_UINT32: [0, 1, 127, 128, 256, 2**32 - 1],
    _T.TYPE_BOOL: [False, True],
}


def fill_random(rng: random.Random, message: Any, depth: int = 0) -> Any:
    for field in descriptor(message).fields:
        if rng.random() < 0.3:
            continue  # left unset
        if field.type == _T.TYPE_MESSAGE:
            sub = getattr(message, field.name)
            if rng.random() < 0.3 or depth > 4:
                sub.SetInParent()  # present but empty
            else:
                fill_random(rng, sub, depth + 1)
        elif field.type == _T.TYPE_ENUM:
            assert field.enum_type is not None
            setattr(message, field.name, rng.choice(field.enum_type.values).number)
        else:
            setattr(message, field.name, rng.choice(_POOLS[field.type]))
    return message


def random_payloads(codec: Codec, seed: int, per_member: int) -> Iterator[tuple[str, Message]]:
    rng = random.Random(seed)
    for field in members(codec):
        assert field.message_type is not None
        cls = codec.message_class(field.message_type.full_name)
        for _ in range(per_member):
            yield field.name, fill_random(rng, cls())


# -- hostile datagrams -------------------------------------------------------------------------


@functools.cache
def payloads(codec: Codec, kind: str) -> st.SearchStrategy[Message]:
    """Any payload member ``kind`` carries, as ``erc_codec.strategies`` draws them."""
    return strategies.messages(codec, descriptor(codec.payload_class(kind)).full_name)


@functools.cache
def sent_datagrams(codec: Codec) -> st.SearchStrategy[bytes]:
    """What a sender may send: any payload of any member in any form, or an edge datagram."""
    kinds = sorted(codec.kinds().values())

    @st.composite
    def encoded(draw: st.DrawFn) -> bytes:
        message = draw(payloads(codec, draw(st.sampled_from(kinds))))
        return codec.encode(message, draw(st.sampled_from(MODES)))

    return st.one_of(st.sampled_from(valid_datagrams(codec)), encoded())


def arbitrary_bytes(codec: Codec) -> st.SearchStrategy[bytes]:
    """Any bytes, up to a little longer than the envelope."""
    return st.binary(max_size=codec.max_size(codec.root) + 8)


def behind_a_member_tag(codec: Codec) -> st.SearchStrategy[bytes]:
    """A member's tag (one byte or two; this schema's members and some it lacks), a length of one
    byte or two, then any bytes: cut anywhere, some zero-padded."""
    longest = codec.max_size(codec.root)
    tags = [encode_varint(number << 3 | LEN) for number in [*sorted(codec.kinds()), 22, 100, 2047]]

    @st.composite
    def build(draw: st.DrawFn) -> bytes:
        data = draw(st.sampled_from(tags)) + encode_varint(draw(st.integers(0, longest + 45)))
        data += draw(st.binary(max_size=60))
        data = data[: draw(st.integers(1, len(data)))]
        if draw(st.booleans()):
            data += bytes(draw(st.integers(0, longest)))
        return data

    return build()


MUTATIONS = ("flip", "cut", "insert", "delete", "pad", "strip")


def mutated_datagrams(codec: Codec) -> st.SearchStrategy[bytes]:
    """What a sender may send, then one to four of: a bit flipped, the end cut off, bytes inserted,
    a byte deleted, zeros appended (sometimes past the envelope's size), trailing zeros cut."""
    longest = codec.max_size(codec.root)

    @st.composite
    def mutate(draw: st.DrawFn) -> bytes:
        data = bytearray(draw(sent_datagrams(codec)))
        for _ in range(draw(st.integers(1, 4))):
            action = draw(st.sampled_from(MUTATIONS))
            at = draw(st.integers(0, max(len(data) - 1, 0)))
            if action == "flip" and data:
                data[at] ^= 1 << draw(st.integers(0, 7))
            elif action == "cut":
                del data[at:]
            elif action == "insert":
                data[at:at] = draw(st.binary(min_size=1, max_size=4))
            elif action == "delete" and data:
                del data[at]
            elif action == "pad":
                data += bytes(draw(st.integers(1, longest)))
            elif action == "strip":
                data = bytearray(bytes(data).rstrip(b"\0"))
        return bytes(data)

    return mutate()


def hostile_datagrams(codec: Codec) -> st.SearchStrategy[bytes]:
    """Whatever may arrive: any bytes, bytes behind a member tag, mutated datagrams."""
    return st.one_of(arbitrary_bytes(codec), behind_a_member_tag(codec), mutated_datagrams(codec))


# -- cut, not stripped (test_envelope_decode.py, test_wireshark.py) -----------------------------

# (id, schema, datagram, what the error names). The packaged schema's, then tests/contract_tree's
# (strings, bytes, packed lists, repeated messages, maps). Each restores, as the last field at the
# deepest level, a field without presence at its default, or a varint ending in 80 00.
TRUNCATED: list[tuple[str, str, str, str]] = [
    ("gps fix_quality DGPS_FIX cut off", "rover", "62 0b 09 d8 81 73 46 94 1e 4a 40 48",
     "SensorBoardGPSInfo.fix_quality = NO_FIX"),
    ("the same behind another member", "rover", "0a 00 62 0b 09 d8 81 73 46 94 1e 4a 40 48",
     "SensorBoardGPSInfo.fix_quality = NO_FIX"),
    ("a float restored to 0.0", "rover", "0a 05 0d", "SensorBoardPHInfo.ph_value = 0.0"),
    ("a double restored to 0.0", "rover", "62 09 09 00 00 00", "SensorBoardGPSInfo.latitude = 0.0"),
    ("a nested enum", "rover", "5a 04 32 02 48",
     "SensorBoardDiagnostics.gps_sensor_1.fix_quality = NO_FIX"),
    ("a bool restored to false", "rover", "72 02 28",
     "SensorBoardLoadCellInfo.is_calibrated = false"),
    ("an int64, two-byte member tag", "rover", "aa 01 02 50",
     "BasestationRoverLocalization.timestamp_ms = 0"),
    ("a varint cut in the middle", "rover", "62 03 40 a0",
     "its last byte in SensorBoardGPSInfo.satellites continues a varint"),
    ("a nested varint cut in the middle", "rover", "5a 05 32 03 40 a0",
     "in SensorBoardDiagnostics.gps_sensor_1.satellites continues a varint"),
    ("an empty string", "limits", "0a 02 0a", 'LimitsRecord.name = ""'),
    ("an empty bytes value", "limits", "0a 02 12", 'LimitsRecord.blob = ""'),
    ("an empty packed list", "limits", "0a 02 1a", "LimitsRecord.counts = [] (an empty packed"),
    ("an item of a repeated message", "limits", "0a 06 2a 00 2a 02 10",
     "LimitsRecord.points[1].x = 0"),
    ("a submessage's enum", "limits", "0a 04 4a 02 08",
     "LimitsRecord.origin.colour = LIMITS_COLOUR_NONE"),
    ("a map's message value", "limits", "0a 08 52 06 08 07 12 02 10",
     "LimitsRecord.places[key=7].x = 0"),
    ("a varint in a map entry", "limits", "0a 07 32 05 08 07 10 85",
     "in LimitsRecord.palette[key=7] continues a varint"),
    ("a tag cut in the middle", "limits", "0a 05 2a 00 b8",
     "its last byte in LimitsRecord.small continues a varint"),
    ("the same behind another member", "limits", "12 00 0a 05 2a 00 b8",
     "its last byte in LimitsRecord.small continues a varint"),
]  # fmt: skip


# What stays ambiguous, and so decodes (README, "Three transmission forms"): each restores a value
# some encoder does send. (id, schema, datagram, kind, the payload's fields).
AMBIGUOUS: list[tuple[str, str, str, str, dict[str, Any]]] = [
    ("the member present and empty", "rover", "4a", "drive_motor", {}),
    ("an envelope cut to its tag", "rover", "32", "arm_target", {}),
    ("a present empty submessage", "rover", "5a 02 32", "sensor_diag", {"gps_sensor_1": {}}),
    ("a tiny float", "rover", "0a 05 0d 01", "ph_info", {"ph_value": 1e-45}),
    ("a bytes value ending in zeros", "limits", "0a 04 12 02 01", "record", {"blob": b"\1\0"}),
    ("a string ending in a NUL", "limits", "0a 04 0a 02 61", "record", {"name": "a\0"}),
    ("a packed list ending in 0", "limits", "0a 04 1a 02 05", "record", {"counts": [5, 0]}),
    ("an unpacked item 0", "limits", "0a 02 18", "record", {"counts": [0]}),
    ("an empty item of a repeated message", "limits", "0a 02 2a", "record", {"points": [{}]}),
    ("a map entry's value 0", "limits", "0a 06 32 04 08 01 10", "record", {"palette": {1: 0}}),
    ("a map entry's key 0", "limits", "0a 04 32 02 08", "record", {"palette": {0: 0}}),
    ("an empty map value", "limits", "0a 06 52 04 08 07 12", "record", {"places": {7: {}}}),
    ("a field this schema lacks", "limits", "0a 02 78", "record", {}),
]  # fmt: skip
