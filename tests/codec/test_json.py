"""Codec.to_dict/to_json and from_dict/from_json: protobuf's JSON mapping, held to json_format.

``to_dict`` is a converter of its own (for erc-codec listen's rate, benchmarks/bench_json.py):
it must write exactly what ``json_format.MessageToDict`` writes with the two flags erc-codec
decode always passed, keys in .proto order at every level (``plain_to_dict``, the plain
version), on every payload type, on tests/contract_tree and on tests/json_tree (every scalar
type, maps with every kind of key, oneofs, optional fields, NaN, infinities, -0.0, 64-bit
extremes, enum numbers the schema does not declare). ``from_dict`` reads back what ``to_dict``
writes, and refuses, naming the field's path, every value json_format would wrap, round or take
for another.
"""

import json
import math
import struct
import subprocess
import sys
from typing import Any, cast

import pytest
from conftest import TESTS
from google.protobuf import json_format
from google.protobuf.descriptor import Descriptor, FieldDescriptor
from google.protobuf.internal.type_checkers import ToShortestFloat
from google.protobuf.message import Message
from hypothesis import example, given, settings
from hypothesis import strategies as st

from erc_codec import Codec, DecodeError, EncodeError, SchemaError, strategies
from erc_schema import descriptor_of, enum_of, message_of

HERE = TESTS
CODEC = Codec.default()
LIMITS = Codec.from_path(HERE / "contract_tree", root="LimitsEnvelope")
MAPPING = Codec.from_path(HERE / "json_tree", root="JsonEnvelope")
_T = FieldDescriptor


def plain_to_dict(message: Message) -> dict[str, Any]:
    """json_format's own reading, its keys put in the order of the .proto at every level."""
    document = json_format.MessageToDict(
        message, always_print_fields_with_no_presence=True, preserving_proto_field_name=True
    )
    return in_field_order(document, descriptor_of(type(message)))


def in_field_order(document: dict[str, Any], descriptor: Descriptor) -> dict[str, Any]:
    ordered: dict[str, Any] = {}
    for field in descriptor.fields:
        if field.name not in document:
            continue
        value = document[field.name]
        inner = field.message_type
        if inner is not None and inner.GetOptions().map_entry:
            values = inner.fields_by_name["value"].message_type
            if values is not None:
                value = {key: in_field_order(item, values) for key, item in value.items()}
        elif inner is not None and inner.full_name.startswith("google.protobuf."):
            pass  # a well-known type: written its own way
        elif inner is not None and field.is_repeated:
            value = [in_field_order(item, inner) for item in value]
        elif inner is not None:
            value = in_field_order(value, inner)
        ordered[field.name] = value
    return ordered


# -- writing: the same as json_format ------------------------------------------------------------


def undeclared(field: FieldDescriptor) -> st.SearchStrategy[int]:
    """Numbers the enum of ``field`` does not declare (an int32, as protobuf stores them)."""
    declared = frozenset(value.number for value in enum_of(field).values)
    return st.integers(-(2**31), 2**31 - 1).filter(lambda number: number not in declared)


@st.composite
def with_undeclared_enums(draw: st.DrawFn, message: Any) -> Any:
    """``message`` with some enum values, at any depth, numbers its enum does not declare."""
    for field in message.DESCRIPTOR.fields:
        value = getattr(message, field.name)
        entry = field.message_type
        if entry is not None and entry.GetOptions().map_entry:
            draw(_in_map(value, entry.fields_by_name["value"]))
        elif field.type == _T.TYPE_ENUM and field.is_repeated:
            if value and draw(st.booleans()):
                value[draw(st.integers(0, len(value) - 1))] = draw(undeclared(field))
        elif field.type == _T.TYPE_ENUM:
            if draw(st.booleans()):
                setattr(message, field.name, draw(undeclared(field)))
        elif field.type == _T.TYPE_MESSAGE and field.is_repeated:
            for item in value:
                draw(with_undeclared_enums(item))
        elif field.type == _T.TYPE_MESSAGE and message.HasField(field.name):
            draw(with_undeclared_enums(value))
    return message


@st.composite
def _in_map(draw: st.DrawFn, items: Any, value: FieldDescriptor) -> None:
    if value.type == _T.TYPE_ENUM and items and draw(st.booleans()):
        items[draw(st.sampled_from(sorted(items)))] = draw(undeclared(value))
    elif value.type == _T.TYPE_MESSAGE:
        for key in sorted(items):
            draw(with_undeclared_enums(items[key]))


def drawable(codec: Codec) -> list[str]:
    return sorted(
        message_of(member).full_name
        for member in descriptor_of(codec.message_class(codec.root)).oneofs[0].fields
        if message_of(member).full_name != "JsonWellKnown"
    )


CASES = [(CODEC, name) for name in drawable(CODEC)]
CASES += [(LIMITS, name) for name in ("LimitsRecord", "LimitsPoint", "LimitsPanel")]
CASES += [(MAPPING, name) for name in drawable(MAPPING)]


@pytest.mark.parametrize(("codec", "name"), CASES, ids=[name for _, name in CASES])
@given(data=st.data())
@settings(max_examples=60)
def test_to_dict_writes_what_json_format_writes(
    codec: Codec, name: str, data: st.DataObject
) -> None:
    message = data.draw(strategies.messages(codec, name, allow_nan=True))
    if data.draw(st.booleans()):
        message = data.draw(with_undeclared_enums(message))
    ours = codec.to_dict(message)
    assert json.dumps(ours) == json.dumps(plain_to_dict(message))  # the keys' order too
    assert codec.to_json(message) == json.dumps(ours)


EDGES: dict[str, list[float]] = {
    "a_double": [math.nan, math.inf, -math.inf, -0.0, 5e-324, 1.7976931348623157e308],
    "a_float": [math.nan, -math.inf, -0.0, 1e-45, 3.4028234663852886e38, 0.1, 16777217.0],
    "an_int64": [-(2**63), 2**63 - 1],
    "a_uint64": [2**64 - 1],
    "a_sint64": [-(2**63)],
    "a_fixed64": [2**64 - 1],
    "an_sfixed64": [-(2**63)],
    "colour": [-2, 300, 7, -(2**31)],
}


@pytest.mark.parametrize(
    ("field", "value"),
    [(field, value) for field, values in EDGES.items() for value in values],
)
def test_to_dict_at_the_edges(field: str, value: Any) -> None:
    message = MAPPING.message_class("JsonScalars")(**{field: value})
    assert json.dumps(MAPPING.to_dict(message)) == json.dumps(plain_to_dict(message))


F32 = struct.Struct("<f")


def as_float32(value: float) -> float:
    return float(F32.unpack(F32.pack(value))[0])


POWERS_OF_TWO = [sign * 2.0**k for k in range(-149, 128) for sign in (1, -1)]
AROUND_THEM = [
    struct.unpack("<f", struct.pack("<I", struct.unpack("<I", F32.pack(v))[0] + step))[0]
    for v in POWERS_OF_TWO
    for step in (-1, 1)
    if abs(v) > 2**-149 or step > 0
]


@given(st.floats(width=32, allow_nan=False, allow_infinity=False))
@example(0.1)
@example(1e-45)
def test_a_float_is_written_as_toshortestfloat_writes_it(value: float) -> None:
    """to_dict tries 7 digits first, then 6 or 8 (for the to_dict target of bench_json.py): the
    same as json_format's ToShortestFloat, which tries 6, 7, 8, 9 in turn. Powers of two, where
    a float's neighbours are unevenly far apart, are all checked below."""
    message = MAPPING.message_class("JsonScalars")(a_float=value)
    written = MAPPING.to_dict(message)["a_float"]
    assert repr(written) == repr(ToShortestFloat(as_float32(value)))  # what the field holds


def test_every_power_of_two_and_its_neighbours_are_written_as_toshortestfloat_writes_them() -> None:
    Scalars = MAPPING.message_class("JsonScalars")
    for value in [as_float32(v) for v in POWERS_OF_TWO + AROUND_THEM]:
        if math.isfinite(value) and value:
            written = MAPPING.to_dict(Scalars(a_float=value))["a_float"]
            assert repr(written) == repr(ToShortestFloat(value)), value


def test_to_dict_shows_what_erc_codec_decode_prints(codec: Codec) -> None:
    GPSInfo = codec.message_class("SensorBoardGPSInfo")
    fix = GPSInfo(latitude=52.2389, altitude=-0.0, hdop=0.9, fix_quality=2, utc_timestamp=-1)
    assert codec.to_dict(fix) == {
        "latitude": 52.2389,
        "longitude": 0.0,
        "altitude": -0.0,
        "speed": 0.0,
        "heading": 0.0,
        "hdop": 0.9,
        "vdop": 0.0,
        "satellites": 0,
        "fix_quality": "DGPS_FIX",
        "state": "SENSOR_IDLE",
        "error_code": "GPS_NO_ERROR",
        "utc_timestamp": "-1",
    }
    assert list(codec.to_dict(fix)) == [field.name for field in fix.DESCRIPTOR.fields]


def test_well_known_types_are_json_formats_own() -> None:
    Known = MAPPING.message_class("JsonWellKnown")
    known: Any = Known(plain=3)
    known.at.FromSeconds(1_700_000_000)
    known.count.value = -(2**63)
    known.level.value = 0.1
    written = MAPPING.to_dict(known)
    assert written == {
        "at": "2023-11-14T22:13:20Z",
        "count": str(-(2**63)),
        "level": json_format.MessageToDict(known.level),
        "plain": 3,
    }
    assert json.dumps(written) == json.dumps(plain_to_dict(known))
    assert MAPPING.from_dict("known", written) == known


# -- reading back what is written ------------------------------------------------------------


@pytest.mark.parametrize(("codec", "name"), CASES, ids=[name for _, name in CASES])
@given(data=st.data())
@settings(max_examples=60)
def test_from_dict_reads_back_what_to_dict_writes(
    codec: Codec, name: str, data: st.DataObject
) -> None:
    message = data.draw(strategies.messages(codec, name, allow_nan=True))
    text = codec.to_json(message)
    for back in (codec.from_dict(name, json.loads(text)), codec.from_json(name, text)):
        assert type(back) is type(message)
        # A map's entries come out in the order protobuf's map keeps them, which depends on its
        # history, not on its entries: the same document, keys in any order.
        assert sorted_json(codec.to_json(back)) == sorted_json(text)
        if "NaN" not in text:  # JSON keeps no NaN's sign nor payload
            assert back.SerializeToString(deterministic=True) == message.SerializeToString(
                deterministic=True
            )


def sorted_json(text: str) -> str:
    return json.dumps(json.loads(text), sort_keys=True)


def test_from_dict_takes_a_kind_or_a_message_name(codec: Codec) -> None:
    fields = {"latitude": 52.2389, "fixQuality": "DGPS_FIX", "utc_timestamp": "1700000000000"}
    GPSInfo = codec.message_class("SensorBoardGPSInfo")
    expected = GPSInfo(latitude=52.2389, fix_quality=2, utc_timestamp=1_700_000_000_000)
    assert codec.from_dict("gps_info", fields) == expected
    assert codec.from_dict("SensorBoardGPSInfo", fields) == expected
    assert codec.from_dict(GPSInfo, fields) == expected
    assert codec.from_json(GPSInfo, json.dumps(fields).encode()) == expected
    assert codec.from_json("gps_info", json.dumps(fields)) == expected
    envelope = codec.from_dict("PBEnvelope", {"gps_info": fields})
    assert envelope.gps_info == expected  # type: ignore[attr-defined]
    with pytest.raises(SchemaError, match=r"'gps' is neither a payload kind of PBEnvelope"):
        codec.from_dict("gps", {})
    with pytest.raises(TypeError, match=r"a kind, a message name or a message class, not int"):
        codec.from_dict(cast(str, 7), {})


READABLE: list[tuple[str, Any, Any]] = [
    # (field of JsonScalars, JSON value, the value stored)
    ("an_int32", 1.0, 1),
    ("an_int32", "-12", -12),
    ("an_int64", 1e3, 1000),
    ("a_uint64", str(2**64 - 1), 2**64 - 1),
    ("an_sfixed64", -(2**63), -(2**63)),
    ("colour", "JSON_COLOUR_WIDE", 300),
    ("colour", 300, 300),
    ("colour", "-2", -2),
    ("a_double", "Infinity", math.inf),
    ("a_double", "-1.5e3", -1500.0),
    ("a_double", math.inf, math.inf),
    ("a_float", 3.4028234663852886e38, 3.4028234663852886e38),
    ("a_float", 3.4028235e38, 3.4028234663852886e38),  # how to_dict writes the largest float
    ("a_float", 1e-45, 1e-45),
    ("some_bytes", "AQID", b"\1\2\3"),
    ("some_bytes", "-_8", b"\xfb\xff"),  # URL-safe, padding left out
    ("a_string", "é€", "é€"),
    ("maybe", 0, 0),
    ("inner", None, None),
]


@pytest.mark.parametrize(("field", "value", "stored"), READABLE)
def test_values_the_mapping_allows(field: str, value: Any, stored: Any) -> None:
    message: Any = MAPPING.from_dict("scalars", {field: value})
    if stored is None:
        assert not message.HasField(field)
    elif isinstance(stored, float):
        assert getattr(message, field) == pytest.approx(stored, rel=1e-7)
    else:
        assert getattr(message, field) == stored
    if field == "maybe":
        assert message.HasField("maybe")  # an optional field given as 0 is present


REFUSED: list[tuple[str, str, dict[str, Any], str]] = [
    # The enum values json_format wraps or takes for another (1099511627776 was NO_FIX,
    # 4294967298 DGPS_FIX, 1.5 and true GPS_FIX) or overflows on (Infinity).
    ("gps_info", "fix_quality", {"fix_quality": 1099511627776},
     "SensorBoardGPSInfo.fix_quality: 1099511627776 is not a declared value: GPSFixQuality "
     "takes one of NO_FIX, GPS_FIX, DGPS_FIX, PPS_FIX, RTK_FIX, RTK_FLOAT"),
    ("gps_info", "fix_quality", {"fix_quality": 4294967298},
     "SensorBoardGPSInfo.fix_quality: 4294967298 is not a declared value"),
    ("gps_info", "fix_quality", {"fix_quality": 1.5},
     "SensorBoardGPSInfo.fix_quality: 1.5 is not an integer: GPSFixQuality takes one of NO_FIX, "
     "GPS_FIX, DGPS_FIX, PPS_FIX, RTK_FIX, RTK_FLOAT"),
    ("gps_info", "fix_quality", {"fix_quality": True},
     "SensorBoardGPSInfo.fix_quality: true is not a name or an integer: GPSFixQuality takes"),
    ("gps_info", "error_code", {"error_code": math.inf},
     "SensorBoardGPSInfo.error_code: Infinity is not an integer: GPSErrorCode takes one of "
     "GPS_NO_ERROR,"),
    ("gps_info", "fix_quality", {"fix_quality": "DGPS"},
     'SensorBoardGPSInfo.fix_quality: "DGPS" is not one of its names: GPSFixQuality takes'),
    ("gps_info", "fix_quality", {"fix_quality": 9},
     "SensorBoardGPSInfo.fix_quality: 9 is not a declared value"),
    # Integers, per their type, before anything converts them.
    ("gps_info", "satellites", {"satellites": 2**31},
     "SensorBoardGPSInfo.satellites: 2147483648 is out of range for int32 "
     "(-2147483648..2147483647)"),
    ("gps_info", "satellites", {"satellites": 9.5},
     "SensorBoardGPSInfo.satellites: 9.5 is not an integer (int32)"),
    ("gps_info", "satellites", {"satellites": False},
     "SensorBoardGPSInfo.satellites: false is not an integer (int32)"),
    ("gps_info", "satellites", {"satellites": math.nan},
     "SensorBoardGPSInfo.satellites: NaN is not an integer (int32)"),
    ("gps_info", "satellites", {"satellites": "9 "},
     'SensorBoardGPSInfo.satellites: "9 " is not an integer (int32)'),
    ("gps_info", "utc_timestamp", {"utc_timestamp": "9223372036854775808"},
     'SensorBoardGPSInfo.utc_timestamp: "9223372036854775808" is out of range for int64'),
    ("motor", "motor_id", {"motor_id": -1},
     "MotorInformation.motor_id: -1 is out of range for uint32 (0..4294967295)"),
    ("motor", "motor_id", {"motor_id": 1e300},
     "MotorInformation.motor_id: 1e+300 is out of range for uint32"),
    # Floats that would turn to infinity or to zero; other types.
    ("gps_info", "altitude", {"altitude": 3.4028236e38},
     "SensorBoardGPSInfo.altitude: 3.4028236e+38 is out of range for float: it would be "
     "infinity"),
    ("gps_info", "latitude", {"latitude": "1.8e308"},
     'SensorBoardGPSInfo.latitude: "1.8e308" is out of range for double: it would be infinity'),
    ("gps_info", "altitude", {"altitude": 1e-46},
     "SensorBoardGPSInfo.altitude: 1e-46 is too small for float: it would be 0"),
    ("gps_info", "altitude", {"altitude": "nan"},
     'SensorBoardGPSInfo.altitude: "nan" is not a number (float)'),
    ("gps_info", "altitude", {"altitude": True},
     "SensorBoardGPSInfo.altitude: true is not a number (float)"),
    ("load_cell_info", "is_calibrated", {"is_calibrated": 1},
     "SensorBoardLoadCellInfo.is_calibrated: 1 is not true or false (a bool)"),
    # Names: as in the .proto, or lowerCamelCase, once each; and the message's shape.
    ("gps_info", "fixquality", {"fixquality": 2},
     'SensorBoardGPSInfo: no field named "fixquality": SensorBoardGPSInfo has latitude, '
     "longitude, altitude, speed, heading, hdop, vdop, satellites, fix_quality, state, "
     "error_code, utc_timestamp"),
    ("gps_info", "fix_quality", {"fix_quality": 2, "fixQuality": 2},
     "SensorBoardGPSInfo.fix_quality: given twice, as 'fix_quality' and 'fixQuality'"),
    ("sensor_diag", "gps_sensor_1", {"gps_sensor_1": {"fix_quality": 7}},
     "SensorBoardDiagnostics.gps_sensor_1.fix_quality: 7 is not a declared value"),
    ("sensor_diag", "gps_sensor_1", {"gps_sensor_1": [1]},
     "SensorBoardDiagnostics.gps_sensor_1: [1] is not an object (the fields of "
     "SensorBoardGPSInfo)"),
]  # fmt: skip


@pytest.mark.parametrize(
    ("kind", "field", "document", "complaint"),
    REFUSED,
    ids=[f"{c[1]}={json.dumps(next(iter(c[2].values())))}" for c in REFUSED],
)
def test_values_that_would_change_on_their_way_are_refused(
    codec: Codec, kind: str, field: str, document: dict[str, Any], complaint: str
) -> None:
    """Each failure names the field's full path and what the field takes."""
    kind = "drive_diag" if kind == "motor" else kind
    if kind == "drive_diag":
        document = {"front_left_motor": document}
        complaint = complaint.replace(
            "MotorInformation.", "DrivingBoardDiagnostics.front_left_motor."
        )
    with pytest.raises(EncodeError) as caught:
        codec.from_dict(kind, document)
    assert str(caught.value).startswith(complaint), str(caught.value)
    with pytest.raises(EncodeError):
        codec.from_json(kind, json.dumps(document))


def test_json_format_would_have_sent_another_fix(codec: Codec) -> None:
    """Why from_dict checks before converting: json_format wraps 4294967298 to 2 (DGPS_FIX),
    and 1099511627776 to 0 (NO_FIX), a value the undeclared-value check then accepts."""
    GPSInfo = codec.message_class("SensorBoardGPSInfo")
    wrapped: Any = json_format.ParseDict({"fix_quality": 4294967298}, GPSInfo())
    assert wrapped.fix_quality == 2
    wrapped = json_format.ParseDict({"fix_quality": 1099511627776}, GPSInfo())
    assert wrapped.fix_quality == 0


PATHS: list[tuple[str, dict[str, Any], str]] = [
    ("record", {"points": [{}, {"colour": "BLUE"}]}, 'LimitsRecord.points[1].colour: "BLUE" is'),
    ("record", {"palette": {"1": 1.5}}, "LimitsRecord.palette[key=1]: 1.5 is not an integer"),
    ("record", {"palette": {"01": 7}}, "LimitsRecord.palette[key=01]: 7 is not a declared value"),
    ("record", {"palette": {"x": 1}}, 'LimitsRecord.palette[key=x]: "x" is not a key of type'),
    ("record", {"palette": {"-1": 1}}, 'LimitsRecord.palette[key=-1]: "-1" is out of range for'),
    ("record", {"places": {"7": {"x": 1.5}}}, "LimitsRecord.places[key=7].x: 1.5 is not an"),
    ("record", {"counts": [1, None]}, "LimitsRecord.counts[1]: null is not an item of a list"),
    ("record", {"counts": 3}, "LimitsRecord.counts: 3 is not a list (a repeated uint32)"),
    ("record", {"palette": [1]}, "LimitsRecord.palette: [1] is not an object (a map<uint32, "
     "LimitsColour>)"),
    ("record", {"blob": "****"}, 'LimitsRecord.blob: "****" is not base64 text (bytes)'),
    ("record", {"blob": "AQ=="}, ""),
    ("record", {"name": 7}, "LimitsRecord.name: 7 is not a string"),
    ("record", {"name": "\ud800"}, 'LimitsRecord.name: "\\ud800" is not valid Unicode'),
]  # fmt: skip


@pytest.mark.parametrize(("kind", "document", "complaint"), PATHS)
def test_a_refusal_names_the_full_path_items_by_index_and_entries_by_key(
    kind: str, document: dict[str, Any], complaint: str
) -> None:
    if not complaint:
        LIMITS.from_dict(kind, document)
        return
    with pytest.raises(EncodeError) as caught:
        LIMITS.from_dict(kind, document)
    assert str(caught.value).startswith(complaint), str(caught.value)


def test_a_oneof_takes_one_member_and_null_leaves_a_field_unset() -> None:
    with pytest.raises(EncodeError, match=r"JsonScalars: number and word are both members of "):
        MAPPING.from_dict("scalars", {"number": 1, "word": "x"})
    message: Any = MAPPING.from_dict("scalars", {"number": None, "word": "x", "inner": None})
    assert message.WhichOneof("choice") == "word"
    assert not message.HasField("inner")


def test_from_json_reads_strictly() -> None:
    for text, complaint in [
        ('{"an_int32": 1, "an_int32": 2}', "JSON is not valid: key 'an_int32' appears twice"),
        ("{an_int32: 1}", "JSON is not valid: Expecting property name"),
        ("[" * 100_000, "JSON is not valid"),
    ]:
        with pytest.raises(EncodeError, match=complaint):
            MAPPING.from_json("scalars", text)
    # Digits beyond a double's are kept: 2**53 + 1 is not rounded to 2**53 on its way.
    exact: Any = MAPPING.from_json("scalars", '{"an_int64": 9007199254740993.0}')
    assert exact.an_int64 == 2**53 + 1


def test_null_is_a_value_of_value_and_nullvalue_fields_and_unsets_the_others() -> None:
    """As json_format reads it: null sets a Value to null_value and a NullValue field to its
    one value; for any other field, it leaves the field unset."""
    document = {"anything": None, "nothing": None, "plain": None}
    ours: Any = MAPPING.from_dict("JsonLoose", document)
    theirs = json_format.ParseDict(document, MAPPING.message_class("JsonLoose")())
    assert ours == theirs
    assert ours.HasField("anything")
    assert ours.anything.WhichOneof("kind") == "null_value"
    assert (
        MAPPING.to_dict(ours)
        == plain_to_dict(ours)
        == {"anything": None, "nothing": None, "plain": 0}
    )
    listed: Any = MAPPING.from_dict("JsonLoose", {"anything": [1, "a", {"b": None}]})
    assert MAPPING.to_dict(listed)["anything"] == [1.0, "a", {"b": None}]


@pytest.mark.parametrize("value", [2**128 - 2**103 - 1, "340282356779733661637539395458142568447"])
def test_a_float_that_rounds_to_infinity_through_its_double_is_refused(value: Any) -> None:
    """2**128 - 2**103 - 1 is below the float's overflow threshold, but the double it rounds to
    first is on it: protobuf would store infinity (struct, once, an OverflowError traceback)."""
    with pytest.raises(EncodeError, match=r"JsonScalars\.a_float: .* it would be infinity"):
        MAPPING.from_dict("scalars", {"a_float": value})
    below: Any = MAPPING.from_dict("scalars", {"a_float": 2**128 - 2**104})
    assert below.a_float == 3.4028234663852886e38


def test_a_message_nested_too_deep_is_refused() -> None:
    document: dict[str, Any] = {"n": 1}
    for _ in range(99):
        document = {"nested": document}
    assert MAPPING.from_dict("JsonNode", document).ByteSize() > 0  # 100 levels: protobuf's limit
    with pytest.raises(EncodeError, match=r"JsonNode(\.nested)+: messages nest more than 100"):
        MAPPING.from_dict("JsonNode", {"nested": document})


@pytest.mark.parametrize("given", [b"x", "gps_info", None])
def test_what_is_no_message_is_a_type_error_naming_it(given: object) -> None:
    for write in (CODEC.to_dict, CODEC.to_json):
        with pytest.raises(TypeError, match=f"not {type(given).__name__}$"):
            write(given)  # type: ignore[arg-type]


# -- what has no JSON form ------------------------------------------------------------------------

WIRESHARK = Codec.from_path(HERE / "wireshark_tree", root="Env")
# Found by fuzzing erc-codec decode against the dissector: each was a traceback.
NOT_UTF8 = bytes.fromhex("1210120201011a07739caaaec28f3020ef04")  # a proto2 string, not UTF-8
BAD_NANOS = bytes.fromhex(
    "11ce367260799ecde710ce9ba7c25222290a1608ee8fbee6ffffffffff011098aefeffffffffffff0112030895"
    "021a050d0000807f20d69ed503"
)  # a Timestamp with nanos -26856


def test_a_string_that_is_not_utf8_has_no_json_form_and_says_where() -> None:
    _, message = WIRESHARK.decode(NOT_UTF8)  # protobuf reads it: proto2 does not check
    with pytest.raises(DecodeError, match=r"^Closed\.label: 7 bytes that are not UTF-8") as caught:
        WIRESHARK.to_dict(message)
    assert caught.value.reason == "not_json"


def test_a_well_known_value_out_of_its_range_has_no_json_form_and_says_where() -> None:
    decoded = MAPPING.decode(BAD_NANOS)
    with pytest.raises(
        DecodeError, match=r"^JsonWellKnown\.at: google\.protobuf\.Timestamp has no"
    ):
        decoded.to_dict()
    with pytest.raises(json_format.Error, match="Nanos -26856"):  # json_format's own verdict
        json_format.MessageToDict(decoded.message)


@pytest.mark.parametrize(
    ("tree", "root", "data", "where"),
    [
        ("wireshark_tree", "Env", NOT_UTF8, "Closed.label"),
        ("json_tree", "JsonEnvelope", BAD_NANOS + bytes(4), "JsonWellKnown.at"),
    ],
)
def test_decode_prints_what_has_no_json_form_as_an_error_line(
    tree: str, root: str, data: bytes, where: str
) -> None:
    command = [sys.executable, "-m", "erc_codec", "decode", "--proto", str(HERE / tree)]
    done = subprocess.run(
        [*command, "--root", root, "-"],
        input=f"{data.hex()}\n{_any_datagram(Codec.from_path(HERE / tree, root=root)).hex()}\n",
        capture_output=True,
        text=True,
    )
    assert done.returncode == 1, done.stderr
    first, second = (json.loads(line) for line in done.stdout.splitlines())
    assert (first["reason"], first["length"]) == ("not_json", len(data))
    assert first["error"].startswith(where + ": ")
    assert "kind" in second  # the next datagram is decoded as usual


def _any_datagram(codec: Codec) -> bytes:
    """A datagram of the first kind whose all-default payload can be sent."""
    for kind in codec.kinds().values():
        try:
            return codec.encode(codec.message_class(kind)())
        except EncodeError:
            continue
    raise AssertionError("no kind sends an empty payload")
