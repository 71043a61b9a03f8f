"""Envelope.decode: every form restored to the message sent, and every other datagram refused.

Stripped datagrams get back the zeros their last field needs, padded ones lose their padding,
explicitly present zeros survive both; anything else is a DecodeError saying what and where.
"""

import array
import contextlib
import math
from typing import Any, cast

import pytest
from conftest import TESTS
from datagrams import (
    AMBIGUOUS,
    HARD_CASES,
    MAX,
    MODES,
    TRUNCATED,
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
    ("too long: zeros", bytes(MAX + 1), r"263 bytes.*262"),
    ("too long: padded", h("22") + bytes(MAX), r"263 bytes.*262"),
    ("too long: 300", h("22 00") + bytes(298), r"300 bytes.*262"),
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
    ("payload longer than the envelope", h("82 01 86 02"), r"262"),
    ("payload length 1000", h("0a e8 07 01"), r"262"),
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
    """262 bytes ending in a tag whose value was "stripped": restored, it would be 263 bytes.

    A receiver padding to PBEnvelope_size (262) cannot hold the last field's length byte, and no
    sender can have produced it: encode refuses anything longer than 262.
    """
    filler = h("b2 01 fe 01") + b"\x01" * 254  # unknown member 22, 254 bytes
    ends_in_len_tag = h("22 00") + filler + h("b2 01")
    assert len(ends_in_len_tag) == MAX
    ends_in_i32_tag = h("22 00") + filler + h("b5 01")
    with pytest.raises(DecodeError, match="262"):
        codec.decode(ends_in_i32_tag)  # restored to 266 bytes
    with pytest.raises(DecodeError, match="262"):
        codec.decode(ends_in_len_tag)  # restored to 263 bytes


def test_a_cut_that_restores_a_default_is_refused_and_a_tiny_value_is_not(codec: Codec) -> None:
    """A float whose high bytes are zero is a tiny value, and its stripped form decodes; restored
    to all zeros it would be 0.0, which no proto3 encoder sends for ph_value (implicit presence):
    that datagram was cut, not stripped. (Once, decode took it for an explicit 0.0.)"""
    tiny = new(codec, "SensorBoardPHInfo", ph_value=1e-45)
    assert codec.encode(tiny, "exact") == h("0a 05 0d 01 00 00 00")
    assert codec.decode(h("0a 05 0d 01")) == ("ph_info", tiny)  # its stripped form
    for cut in (h("0a 05 0d 00 00"), h("0a 05 0d")):
        with pytest.raises(DecodeError, match=r"SensorBoardPHInfo\.ph_value = 0\.0") as caught:
            codec.decode(cut)
        assert caught.value.reason == "truncated"


def test_only_the_padded_forms_may_have_zeros_after_the_payload(codec: Codec) -> None:
    payload = new(codec, "BasestationControlMode", mode=2)
    exact = codec.encode(payload, "exact")
    assert exact == h("82 01 02 08 02")
    for extra in range(MAX - len(exact) + 1):
        assert codec.decode(exact + bytes(extra)).message == payload
    with pytest.raises(DecodeError, match="263"):
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


PRESENCE_TREE = TESTS / "schema_trees" / "presence"


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


# -- cut, not stripped: restored zeros no encoder would have sent -----------------------------

LIMITS_TREE = TESTS / "contract_tree"


@pytest.fixture(scope="module")
def limits() -> Codec:
    return Codec.from_path(LIMITS_TREE, root="LimitsEnvelope")


@pytest.mark.parametrize(
    ("schema", "data", "named"), [c[1:] for c in TRUNCATED], ids=[c[0] for c in TRUNCATED]
)
def test_a_cut_datagram_is_not_taken_for_a_stripped_one(
    codec: Codec, limits: Codec, schema: str, data: str, named: str
) -> None:
    """The receiver restores only zeros some encoder could have written: none writes a field
    without presence at its default, nor a varint ending in a zero after a continuation byte.
    decode refuses, peek does not locate it, the dispatcher counts it, all as "truncated"."""
    receiver = codec if schema == "rover" else limits
    with pytest.raises(DecodeError) as caught:
        receiver.decode(h(data))
    assert caught.value.reason == "truncated"
    assert named in str(caught.value)
    assert str(caught.value).startswith(f"datagram of {len(h(data))} bytes was cut short: ")
    assert receiver.peek(h(data)) is None
    dispatcher = erc_codec.runtime.Dispatcher(receiver)
    assert not dispatcher.feed(h(data))
    assert dispatcher.stats().undecodable == {"truncated": 1}


def test_a_payload_missing_a_required_field_is_judged_not_refused() -> None:
    """A proto2 payload without its required field parses, so decode takes it in every form.
    Judging its restored zeros serialized it, and protobuf's serializer raised its own
    EncodeError for the missing field, out of decode (a traceback from erc-codec decode)."""
    every = Codec.from_path(TESTS / "wireshark_tree", "Env")
    closed = new(every, "Closed", modes=[1, 0])  # no id
    for data in (h("12 04 12 02 01"), h("1a 00 12 04 12 02 01")):  # fast path, general path
        assert every.decode(data) == ("closed", closed)
    for data in (h("12 04 12 02 81"), h("1a 00 12 04 12 02 81")):  # the last item cut: 81 00
        with pytest.raises(DecodeError, match=r"in Closed\.modes continues a varint") as caught:
            every.decode(data)
        assert caught.value.reason == "truncated"


def test_the_first_datagram_cut_is_a_fix_that_was_sent(codec: Codec) -> None:
    """620b...4048 is 620b...404802, fix_quality DGPS_FIX, with its last byte lost."""
    GPSInfo = codec.message_class("SensorBoardGPSInfo")
    sent = h("62 0b 09 d8 81 73 46 94 1e 4a 40 48 02")
    assert codec.decode(sent).message == GPSInfo(latitude=52.2389, fix_quality=2)
    assert codec.encode(GPSInfo(latitude=52.2389, fix_quality=2)) == sent


@pytest.mark.parametrize(
    ("schema", "data", "kind", "fields"),
    [c[1:] for c in AMBIGUOUS],
    ids=[c[0] for c in AMBIGUOUS],
)
def test_what_some_encoder_sends_is_restored(
    codec: Codec, limits: Codec, schema: str, data: str, kind: str, fields: dict[str, Any]
) -> None:
    receiver = codec if schema == "rover" else limits
    decoded = receiver.decode(h(data))
    expected = receiver.payload_class(kind)(**fields)
    assert decoded.kind == kind
    assert decoded.message.ListFields() == expected.ListFields()  # unknown fields aside
    assert receiver.peek(h(data)) is not None


def test_explicit_presence_keeps_its_zero_when_stripped(presence: Codec) -> None:
    """An optional or oneof field is sent at zero, so its restored zero is the one sent (the
    presence cases above hold every form); a field without presence beside them is not."""
    assert presence.decode(h("0a 02 10")).message == new(presence, "Counter", count=0)
    assert presence.decode(h("12 02 10")).message == new(presence, "Choice", flag=False)
    with pytest.raises(DecodeError, match=r"Counter\.id = 0") as caught:
        presence.decode(h("0a 02 08"))
    assert caught.value.reason == "truncated"


def _cut_outcome(codec: Codec, data: bytes) -> tuple[str, bytes] | str:
    try:
        decoded = codec.decode(data)
    except DecodeError as error:
        return error.reason
    return decoded.kind, decoded.message.SerializeToString()


def assert_a_cut_is_refused_or_a_stripped_form(codec: Codec, message: Any, at: int) -> None:
    """Cut a sender's stripped datagram short by at least one byte that was sent: decode refuses
    it, or it is exactly the stripped form of what it decodes to, a datagram some sender sends.
    The general path (after an empty member of another kind) judges it alike."""
    stripped = codec.encode(message, "strip")
    cut = stripped[:at]
    outcome = _cut_outcome(codec, cut)
    if not isinstance(outcome, str):
        decoded = codec.decode(cut)
        try:
            again = codec.encode(decoded.message, "strip")
        except erc_codec.EncodeError:
            again = None  # zeros made more items than max_count: not ours, but Google's sends it
        if again is not None and again != cut.rstrip(b"\0"):
            # map entries serialize in no fixed order: the same entries, the same bytes
            assert sorted(again) == sorted(cut.rstrip(b"\0")), (cut.hex(), again.hex())
    first = min(codec.kinds())  # member 1: a one-byte tag
    other = h(f"{first << 3 | 2:02x} 00")
    if len(codec.encode(message, "exact")) + len(other) <= codec.max_size(codec.root):
        assert _cut_outcome(codec, other + cut) == outcome, cut.hex()


@pytest.mark.parametrize("kind", KINDS)
@given(data=st.data())
@settings(max_examples=40)
def test_a_cut_datagram_is_refused_or_what_a_sender_strips(kind: str, data: st.DataObject) -> None:
    """Every payload type, cut anywhere: before this held, a cut gps fix read as NO_FIX."""
    message = data.draw(payloads(CODEC, kind))
    stripped = CODEC.encode(message, "strip")
    if len(stripped) > 1:
        assert_a_cut_is_refused_or_a_stripped_form(
            CODEC, message, data.draw(st.integers(1, len(stripped) - 1))
        )


@pytest.mark.parametrize("tree", ["limits", "presence"])
@given(data=st.data())
@settings(max_examples=150, suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_a_cut_of_strings_maps_and_optional_fields_is_refused_or_stripped(
    limits: Codec, presence: Codec, tree: str, data: st.DataObject
) -> None:
    codec = limits if tree == "limits" else presence
    kind = data.draw(st.sampled_from(sorted(codec.kinds().values())))
    message = data.draw(payloads(codec, kind))
    stripped = codec.encode(message, "strip")
    if len(stripped) > 1:
        at = data.draw(st.integers(1, len(stripped) - 1))
        assert_a_cut_is_refused_or_a_stripped_form(codec, message, at)


@pytest.mark.parametrize("tree", ["limits", "presence"])
@given(data=st.data())
@settings(max_examples=100, suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_every_form_of_strings_maps_and_optional_fields_decodes(
    limits: Codec, presence: Codec, tree: str, data: st.DataObject
) -> None:
    """What a sender sends is never taken for a cut: every form, every length between."""
    codec = limits if tree == "limits" else presence
    kind = data.draw(st.sampled_from(sorted(codec.kinds().values())))
    message = data.draw(payloads(codec, kind))
    exact = codec.encode(message, "exact")
    stripped, longest = exact.rstrip(b"\0"), codec.max_size(codec.root)
    datagram = (stripped + bytes(longest))[: data.draw(st.integers(len(stripped), longest))]
    decoded = codec.decode(datagram)
    assert decoded.kind == kind
    assert decoded.message == message


# -- any bytes-like object ---------------------------------------------------------------------


def _views(data: bytes) -> list[object]:
    return [
        bytearray(data),
        memoryview(data),
        memoryview(bytearray(b"xy" + data))[2:],
        array.array("B", data),
    ]


def test_decode_and_peek_take_any_bytes_like_object(codec: Codec) -> None:
    """bytes, bytearray, memoryview (once an AttributeError on the padded path), array: the
    same outcome as the bytes."""
    samples = [*valid_datagrams(codec), *(h(c[2]) for c in TRUNCATED if c[1] == "rover")]
    samples += [h("b2 01 00"), h("22 00 00 01"), b""]
    for data in samples:
        expected = _cut_outcome(codec, data)
        for view in _views(data):
            assert _cut_outcome(codec, cast(bytes, view)) == expected, (type(view), data.hex())
            assert codec.peek(cast(bytes, view)) == codec.peek(data)
    wide = array.array("H", [0x0022])  # a buffer of 2-byte items: its bytes, 22 00
    assert codec.decode(cast(bytes, wide)).kind == "arm_feedback"


@pytest.mark.parametrize("value", ["22", 34, None, [0x22, 0x00]])
def test_decode_refuses_what_is_not_bytes(codec: Codec, value: object) -> None:
    name = type(value).__name__
    with pytest.raises(TypeError, match=rf"a datagram is bytes .*not {name}"):
        codec.decode(cast(bytes, value))
    with pytest.raises(TypeError, match=rf"not {name}"):
        codec.peek(cast(bytes, value))
