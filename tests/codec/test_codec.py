"""The Codec's public surface: kinds, sizes, classes, results, errors, module-level functions.

Also: messages built from another codec's classes (same full names, different classes) encode as
the codec's own do.
"""

import copy
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
    descriptor,
    h,
    new,
    random_payloads,
    widest_driving_diagnostics,
    with_unknown_field,
)

import erc_codec
from erc_codec import Codec, Decoded, DecodeError, EncodeError
from erc_schema import Sizes

# -- the codec's public surface ----------------------------------------------------------------


def test_kinds_are_the_envelope_members(codec: Codec) -> None:
    assert codec.kinds() == ENVELOPE_MEMBERS


def test_kinds_returns_a_copy(codec: Codec) -> None:
    codec.kinds().clear()
    assert codec.kinds() == ENVELOPE_MEMBERS


@pytest.mark.parametrize(
    ("name", "size"),
    [
        ("PBEnvelope", 262),  # the widest payload, 255, + timeout: 2 + 5
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


def test_payload_class_is_the_class_each_member_carries(codec: Codec) -> None:
    envelope = new(codec, "PBEnvelope")
    for kind in ENVELOPE_MEMBERS.values():
        cls = codec.payload_class(kind)
        assert type(getattr(envelope, kind)) is cls
        assert codec.message_class(descriptor(cls).full_name) is cls
    assert codec.payload_class("gps_info") is codec.message_class("SensorBoardGPSInfo")
    with pytest.raises(erc_codec.SchemaError, match=r"'gps' is not a payload kind of PBEnvelope"):
        codec.payload_class("gps")


def test_message_class_takes_a_kind_or_a_message_name(codec: Codec) -> None:
    assert codec.message_class("gps_info") is codec.message_class("SensorBoardGPSInfo")
    assert codec.message_class("drive_motor") is codec.payload_class("drive_motor")
    with pytest.raises(erc_codec.SchemaError, match=r"no message named 'gps'"):
        codec.message_class("gps")


def test_members_are_the_envelope_members_with_their_directions(codec: Codec) -> None:
    members = codec.members()
    assert [(m.number, m.kind) for m in members] == sorted(ENVELOPE_MEMBERS.items())
    assert all(codec.message_class(m.message) is codec.payload_class(m.kind) for m in members)
    by_kind = {m.kind: m for m in members}
    assert by_kind["gps_info"] == erc_codec.Member(
        12, "gps_info", "SensorBoardGPSInfo", erc_codec.Direction("Hardware", "ROS2")
    )
    assert by_kind["drive_motor"].direction == ("ROS2", "Hardware")
    assert by_kind["rover_localization"].direction == ("ROS2", "BS")
    assert by_kind["control_mode"].direction == ("BS", "ROS2")


def test_a_member_without_a_direction_comment_has_none(tmp_path: Path) -> None:
    (tmp_path / "e.proto").write_text(
        'syntax = "proto3";\n'
        "message A { int32 x = 1; }\n"
        "message PBEnvelope {\n"
        "  oneof payload {\n"
        "    A quiet = 3;\n"
        "    A told = 1;  // direction:  Base station  ->  Jetson   \n"
        "    A other = 2;  // sent now and then\n"
        "  }\n"
        "}\n"
    )
    members = Codec.from_path(tmp_path).members()
    assert members == (
        erc_codec.Member(1, "told", "A", erc_codec.Direction("Base station", "Jetson")),
        erc_codec.Member(2, "other", "A", None),
        erc_codec.Member(3, "quiet", "A", None),
    )


def test_schema_and_nanopb_are_the_codecs_own(codec: Codec) -> None:
    assert codec.root == codec.schema.root.full_name == "PBEnvelope"
    assert codec.schema.message_class("MotorInformation") is codec.message_class("MotorInformation")
    assert isinstance(codec.nanopb, Sizes)
    assert codec.nanopb is codec.nanopb  # one Sizes, computed once
    assert codec.nanopb.max_size("PBEnvelope") == codec.max_size("PBEnvelope") == MAX
    assert codec.nanopb.all() == codec.sizes()
    gps = descriptor(codec.message_class("SensorBoardGPSInfo"))
    assert codec.nanopb.max_size(gps.full_name) == 71
    assert not codec.nanopb.ignored(gps.fields_by_name["fix_quality"])


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


def test_decode_returns_exactly_the_decoded_the_class_would_build(codec: Codec) -> None:
    """decode builds its result with tuple.__new__, skipping NamedTuple's __new__ (for the decode
    target of benchmarks/bench_codec.py): what comes out must be the Decoded that
    ``Decoded(kind, message)`` builds, on the fast path and on the general one."""
    payload = new(codec, "SensorBoardGPSInfo", latitude=52.2389, satellites=9)
    exact = codec.encode(payload, "exact")
    # Every form takes the fast path; a member before the last one (the oneof's last member
    # wins) and a field after it take the general path.
    datagrams = [codec.encode(payload, mode) for mode in MODES]
    datagrams += [h("0a 00") + exact, exact + h("f8 01 01")]
    for data in datagrams:
        decoded = codec.decode(data)
        plain = Decoded("gps_info", payload)
        assert type(decoded) is Decoded
        assert decoded == plain
        assert (decoded.kind, decoded.message) == ("gps_info", payload)
        assert decoded._asdict() == plain._asdict() == {"kind": "gps_info", "message": payload}
        replaced = decoded._replace(kind="imu_info")
        assert type(replaced) is Decoded
        assert replaced.message is decoded.message
        assert replaced == plain._replace(kind="imu_info") == ("imu_info", payload)
        assert repr(decoded) == repr(plain)
        assert repr(decoded).startswith("Decoded(kind='gps_info', message=")
        assert type(copy.copy(decoded)) is Decoded
        assert copy.copy(decoded) == plain
        assert Decoded._make(decoded) == plain


def test_errors_share_one_base_class() -> None:
    for error in (erc_codec.DecodeError, erc_codec.EncodeError, erc_codec.SchemaError):
        assert issubclass(error, erc_codec.CodecError)
    assert issubclass(erc_codec.CodecError, Exception)


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
    too_long = with_unknown_field(other, "DrivingBoardMotorMessage", 252)
    with pytest.raises(EncodeError, match="262"):
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
        "arm_feedback",
        new(codec, "ArmBoardMovementFeedback"),
    )
    with pytest.raises(DecodeError):
        erc_codec.decode(b"")
    with pytest.raises(EncodeError):
        erc_codec.encode(new(codec, "MotorInformation"))
