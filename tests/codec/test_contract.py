"""The fixed-size contract on encode: what a nanopb receiver would drop or misread is refused.

The contract's compiled checks and byte screens are held to a plain recursive reading of the same
rules (``plain_complaints``), on the rover's payload types and on tests/contract_tree.
"""

import functools
import itertools
import random
import struct
from collections.abc import Callable, Iterator, Mapping, MutableMapping
from typing import Any, cast

import pytest
from conftest import TESTS
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
from erc_codec.codec._contract import Contract, contract
from erc_schema import Sizes, descriptor_of, enum_of, message_of

CODEC = erc_codec.Codec.default()
LIMITS = erc_codec.Codec.from_path(TESTS / "contract_tree", root="LimitsEnvelope")
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
    for member in ENVELOPE.oneofs[0].fields
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


def test_a_screen_only_where_it_saves_more_reads_than_it_costs() -> None:
    """The motors' diagnostics hold one enum tag among about a hundred bytes of floats: a scan
    of their bytes is cheaper than reading ten submessages. The sensor board's holds eight
    enum tags among as many bytes, which float bytes match by chance nearly always, and the
    small types hold too few fields to be worth a scan."""
    screened = {name for name in PAYLOAD_TYPES if (rules := compiled(CODEC, name)) and rules.screen}
    assert screened == {"ArmBoardDiagnostics", "DrivingBoardDiagnostics"}
    sensors = CODEC.message_class("SensorBoardDiagnostics")()
    fill_random(random.Random(7), sensors)
    sensors.gps_sensor_1.fix_quality = 77  # type: ignore[attr-defined]
    with pytest.raises(EncodeError, match=r"gps_sensor_1\.fix_quality = 77 is not a declared"):
        CODEC.encode(sensors)


def test_the_default_form_is_the_plain_paths_on_every_payload_type() -> None:
    """One random payload of each type, sent in the default form (the compiled sender) and in
    the exact form stripped by hand (the plain path); a payload made too long by fields the
    schema does not know is refused by both in the same words."""
    rng = random.Random(20261202)
    for member in ENVELOPE.oneofs[0].fields:
        payload = fill_random(rng, CODEC.message_class(message_of(member).full_name)())
        assert CODEC.encode(payload) == CODEC.encode(payload, "exact").rstrip(b"\0")
    padded = CODEC.message_class("SensorBoardGPSInfo")(satellites=9)
    padded.MergeFromString(b"\xfa\x3f\x84\x02" + bytes([1]) * 260)  # field 1023, 260 bytes
    refusals = []
    for mode in ("strip", "exact"):
        with pytest.raises(EncodeError, match="would be 269 bytes, more than the 262") as refused:
            CODEC.encode(padded, mode)
        refusals.append(str(refused.value))
    assert refusals[0] == refusals[1]


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
        (
            {"points": [{"x": 200}]},
            r"LimitsRecord.points\[0\].x = 200 does not fit nanopb int_size",
        ),
        ({"points": [{}, {"colour": 2}]}, r"LimitsRecord.points\[1\].colour = 2 is not a declared"),
        ({"palette": {1: 1, 2: 1, 3: 1}}, r"LimitsRecord.palette holds 3 items"),
        ({"palette": {1: 5}}, r"LimitsRecord.palette\[key=1\] = 5 is not a declared value"),
        ({"small": 65536}, r"LimitsRecord.small = 65536 does not fit nanopb int_size \(0..65535\)"),
        ({"colour": 299}, r"LimitsRecord.colour = 299 is not a declared value of LimitsColour"),
        ({"origin": {"colour": 2}}, r"LimitsRecord.origin.colour = 2 is not a declared value"),
        ({"origin": {"x": 128}}, r"LimitsRecord.origin.x = 128 does not fit nanopb int_size"),
        ({"places": {1: {}, 2: {}, 3: {}}}, r"LimitsRecord.places holds 3 items"),
        ({"places": {7: {"x": -129}}}, r"LimitsRecord.places\[key=7\].x = -129 does not fit"),
    ],
)
def test_nanopb_limits_are_enforced(values: dict[str, Any], complaint: str) -> None:
    """Each complaint names the field by its full path from the payload type: an item by its
    index, a map's value by its key as JSON writes it."""
    with pytest.raises(erc_codec.EncodeError, match=complaint):
        LIMITS.encode(record(**values))


@pytest.mark.parametrize(
    ("values", "path"),
    [
        ({"points": [{}, {"colour": 2}]}, "LimitsRecord.points[1].colour = 2"),
        ({"palette": {1: 5}}, "LimitsRecord.palette[key=1] = 5"),
        ({"places": {7: {"x": -129}}}, "LimitsRecord.places[key=7].x = -129"),
        ({"places": {3: {"colour": 9}}}, "LimitsRecord.places[key=3].colour = 9"),
        ({"origin": {"x": 128}}, "LimitsRecord.origin.x = 128"),
    ],
)
def test_a_complaint_names_the_full_path_not_the_inner_type(
    values: dict[str, Any], path: str
) -> None:
    with pytest.raises(erc_codec.EncodeError) as caught:
        LIMITS.encode(record(**values))
    assert str(caught.value).startswith(path + " "), str(caught.value)


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
        "sensor_diag",
        "SensorBoardDiagnostics.gps_sensor_1.fix_quality",
        "= -1",
    ),
    (
        "nested motor",
        _nested_motor_state_7,
        "drive_diag",
        "DrivingBoardDiagnostics.back_left_motor.state",
        "= 7",
    ),
    ("wide value", _top_level_state_1000, "arm_diag", "ArmBoardDiagnostics.state", "= 1000"),
    (
        "nested imu",
        _nested_sensor_state,
        "sensor_diag",
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


# -- the compiled check and its screen, held to a plain reading of the contract ----------------

# contract() compiles a straight-line check per payload type and screens serialized bytes with a
# regular expression first (for the encode target of benchmarks/bench_codec.py). Below is the
# plain version: the contract read field by field, recursively, the slow obvious way.

_T = FieldDescriptor
_TEXT = (_T.TYPE_STRING, _T.TYPE_BYTES)
_WIRE_RANGES = {  # the values protobuf itself lets an integer field hold
    _T.TYPE_INT32: (-(2**31), 2**31 - 1),
    _T.TYPE_SINT32: (-(2**31), 2**31 - 1),
    _T.TYPE_INT64: (-(2**63), 2**63 - 1),
    _T.TYPE_SINT64: (-(2**63), 2**63 - 1),
    _T.TYPE_UINT32: (0, 2**32 - 1),
    _T.TYPE_UINT64: (0, 2**64 - 1),
}


def item_field(field: FieldDescriptor) -> FieldDescriptor:
    """The field whose values a repeated field holds: a map's value field, or the field itself."""
    entry = field.message_type
    if entry is not None and entry.GetOptions().map_entry:
        return entry.fields_by_name["value"]
    return field


def plain_complaints(sizes: Sizes, message: Any, path: str = "") -> list[str]:
    """Every way ``message`` breaks the fixed-size contract, in field order, named as the codec
    names it: by the full path from the payload type (``Top.sub.state``), an item by its index
    in the field (``Top.points[2].x``), a map's value by its key (``Top.palette[key=1]``, in
    iteration order)."""
    descriptor = message.DESCRIPTOR
    path = path or descriptor.full_name
    found: list[str] = []
    for field in descriptor.fields:
        if sizes.ignored(field):
            continue
        value = getattr(message, field.name)
        where = f"{path}.{field.name}"
        if field.is_repeated:
            count = sizes.max_count(field)
            if count is not None and len(value) > count:
                found.append(f"{where} holds {len(value)} items, more than its max_count {count}")
            if isinstance(value, Mapping):
                for key, item in value.items():
                    found += plain_item(sizes, item_field(field), item, f"{where}[key={key}]")
            else:
                for index, item in enumerate(value):
                    found += plain_item(sizes, item_field(field), item, f"{where}[{index}]")
        elif field.type == _T.TYPE_MESSAGE:
            found += plain_complaints(sizes, value, where)
        else:
            found += plain_item(sizes, field, value, where)
    return found


def plain_item(sizes: Sizes, field: FieldDescriptor, value: Any, path: str) -> list[str]:
    """What is wrong with one value of ``field`` (a single field's, or one item's)."""
    if field.type == _T.TYPE_MESSAGE:
        return plain_complaints(sizes, value, path)
    if field.type == _T.TYPE_ENUM:
        if value in {declared.number for declared in enum_of(field).values}:
            return []
        return [f"{path} = {value} is not a declared value of {enum_of(field).full_name}"]
    limit = sizes.max_bytes(field) if field.type in _TEXT else None
    if limit is not None:
        length = len(value.encode("utf-8") if field.type == _T.TYPE_STRING else value)
        if length <= limit:
            return []
        return [f"{path} is {length} bytes long, more than the {limit} allowed"]
    bounds = sizes.int_range(field)
    if bounds is not None and not bounds[0] <= value <= bounds[1]:
        return [f"{path} = {value} does not fit nanopb int_size ({bounds[0]}..{bounds[1]})"]
    return []


# -- breaking one field at random, anywhere

Draw = Callable[[st.SearchStrategy[Any]], Any]


def bad_values(sizes: Sizes, field: FieldDescriptor) -> st.SearchStrategy[Any] | None:
    """Values of ``field`` (a scalar) that the contract refuses, if there are any."""
    if field.type == _T.TYPE_ENUM:
        declared = {value.number for value in enum_of(field).values}
        numbers = st.one_of(st.integers(-3, 400), st.integers(-(2**31), 2**31 - 1))
        return numbers.filter(lambda number: number not in declared)
    limit = sizes.max_bytes(field) if field.type in _TEXT else None
    if limit is not None:
        if field.type == _T.TYPE_BYTES:
            return st.binary(min_size=limit + 1, max_size=limit + 8)
        return st.text(max_size=limit + 8).map(lambda text: too_long(text, limit))
    bounds = sizes.int_range(field)
    if bounds is None:
        return None
    low, high = _WIRE_RANGES[field.type]
    outside = [st.integers(low, bounds[0] - 1)] if low < bounds[0] else []
    outside += [st.integers(bounds[1] + 1, high)] if bounds[1] < high else []
    return st.one_of(outside) if outside else None


def too_long(text: str, limit: int) -> str:
    """``text``, lengthened with euro signs (three bytes, one character) past ``limit`` bytes."""
    while len(text.encode("utf-8")) <= limit:
        text += "\u20ac"
    return text


def breakable(sizes: Sizes, field: FieldDescriptor) -> bool:
    """Whether some value of ``field`` breaks the contract."""
    if sizes.ignored(field):
        return False
    if field.is_repeated and sizes.max_count(field) is not None:
        return True
    item = item_field(field)
    if item.type == _T.TYPE_MESSAGE:
        return any(breakable(sizes, inner) for inner in message_of(item).fields)
    return bad_values(sizes, item) is not None


def break_message(draw: Draw, sizes: Sizes, message: Any) -> None:
    """Break exactly one field of ``message``, at any depth, so that the contract refuses it."""
    fields = [field for field in message.DESCRIPTOR.fields if breakable(sizes, field)]
    field = draw(st.sampled_from(fields))
    if field.is_repeated:
        break_repeated(draw, sizes, message, field)
    elif field.type == _T.TYPE_MESSAGE:
        break_message(draw, sizes, getattr(message, field.name))
    else:
        strategy = bad_values(sizes, field)
        assert strategy is not None
        setattr(message, field.name, draw(strategy))


def break_repeated(draw: Draw, sizes: Sizes, message: Any, field: FieldDescriptor) -> None:
    """Give a repeated field (or map) more items than ``max_count``, or one item that is bad."""
    values = getattr(message, field.name)
    count = sizes.max_count(field)
    item = item_field(field)
    bad = bad_values(sizes, item) if item.type != _T.TYPE_MESSAGE else None
    one_bad = bad is not None or (item.type == _T.TYPE_MESSAGE and breakable(sizes, item))
    room = count is None or len(values) < count  # for one more item
    if count is not None and not (one_bad and (room or values) and draw(st.booleans())):
        while len(values) <= count:
            add_item(values, item)
        return
    at = draw(st.integers(0, len(values) if room else len(values) - 1))  # len(values): a new one
    if at == len(values):
        add_item(values, item)
    key = list(values)[at] if isinstance(values, Mapping) else at
    if bad is None:
        break_message(draw, sizes, values[key])
    else:
        values[key] = draw(bad)


def add_item(values: Any, item: FieldDescriptor) -> None:
    """One more item the contract accepts: a default value, or an empty message."""
    if isinstance(values, MutableMapping):
        # The contract tree's maps have integer keys: the first one free, counting up from 0,
        # so a key drawn at the type's maximum does not overflow it.
        key = next(k for k in itertools.count() if k not in values)
        if item.type == _T.TYPE_MESSAGE:
            values[key].SetInParent()
        else:
            values[key] = zero(item)
    elif item.type == _T.TYPE_MESSAGE:
        values.add()
    else:
        values.append(zero(item))


def zero(field: FieldDescriptor) -> Any:
    """The zero value of a scalar field, which every limit accepts (a proto3 enum declares 0)."""
    zeros = {_T.TYPE_STRING: "", _T.TYPE_BYTES: b"", _T.TYPE_BOOL: False}
    return zeros.get(field.type, 0.0 if field.cpp_type == _T.CPPTYPE_FLOAT else 0)


@functools.cache
def compiled(codec: Codec, name: str) -> Contract | None:
    return contract(codec.nanopb, codec.schema.descriptor(name))


@functools.cache
def drawn(codec: Codec, name: str) -> st.SearchStrategy[Message]:
    return strategies.messages(codec, name)


def assert_the_compiled_check_agrees(schema: Codec, name: str, data: st.DataObject) -> None:
    """A message drawn whole, perhaps with one field broken: the compiled check refuses it exactly
    when the plain reading does, in the same words; the screen lets every such message through to
    the check; encode, which runs the two, refuses the same."""
    sizes = schema.nanopb
    rules = compiled(schema, name)
    message = data.draw(drawn(schema, name))
    can_break = any(breakable(sizes, field) for field in schema.schema.descriptor(name).fields)
    assert rules is not None or not can_break  # a type with no contract has nothing to break
    broken = can_break and data.draw(st.booleans())
    if broken:
        break_message(data.draw, sizes, message)
    complaints = plain_complaints(sizes, message)
    assert len(complaints) == broken, complaints  # one field broken, one complaint
    if rules is None:
        return
    try:
        rules.check(message)
        refused = None
    except EncodeError as error:
        refused = str(error)
    assert refused == (complaints[0] if complaints else None)
    if complaints and rules.screen is not None:
        assert rules.screen(message.SerializeToString()), complaints[0]
    sent: bytes | str
    sent_plainly: bytes | str
    try:
        sent = schema.encode(message)  # the default form: one compiled sender per payload type
    except EncodeError as error:
        sent = str(error)
    try:  # the plain path (every form but the default one takes it), stripped by hand
        sent_plainly = schema.encode(message, "exact").rstrip(b"\0")
    except EncodeError as error:
        sent_plainly = str(error)
    assert sent == sent_plainly
    assert isinstance(sent, bytes) if refused is None else sent == refused


PAYLOAD_TYPES = [message_of(member).full_name for member in ENVELOPE.oneofs[0].fields]


@pytest.mark.parametrize("name", PAYLOAD_TYPES)
@given(data=st.data())
@settings(max_examples=30)
def test_the_compiled_check_and_its_screen_agree_with_the_plain_reading(
    name: str, data: st.DataObject
) -> None:
    """Every payload type of the rover's schema: enum fields at every depth, three screens."""
    assert_the_compiled_check_agrees(CODEC, name, data)


@pytest.mark.parametrize("name", ["LimitsRecord", "LimitsPoint", "LimitsPanel"])
@given(data=st.data())
@settings(max_examples=150)
def test_the_compiled_check_agrees_with_the_plain_reading_on_every_limit(
    name: str, data: st.DataObject
) -> None:
    """tests/contract_tree: strings, bytes, repeated fields, maps and int_size, at the top and
    below it; a screened type whose enum fields share a tag but not their declared values."""
    assert_the_compiled_check_agrees(LIMITS, name, data)
