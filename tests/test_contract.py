"""The fixed-size contract on encode: what a nanopb receiver would drop or misread is refused."""

from pathlib import Path
from typing import Any

import pytest
from google.protobuf.descriptor import Descriptor, FieldDescriptor
from google.protobuf.message import Message
from hypothesis import given, settings
from hypothesis import strategies as st

import erc_codec
from erc_codec import strategies
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
    )
    assert LIMITS.decode(LIMITS.encode(widest)).message == widest


@given(strategies.messages(LIMITS, "LimitsRecord"))
def test_strategies_respect_every_limit(message: Message) -> None:
    assert LIMITS.decode(LIMITS.encode(message)).message == message
