"""Unknown data is visible: fields a schema does not know show in ``Decoded.unknown_fields`` and
in decode's output, ``strict=True`` / ``--strict`` makes them an error; a message class of another
schema is an ``EncodeError`` saying so, and arguments of the wrong type a ``TypeError``."""

import json
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import REPO
from datagrams import MAX, hostile_datagrams
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import erc_codec
from erc_codec import Codec, DecodeError, EncodeError
from erc_schema import LEN, VARINT, WireError, encode_varint, next_field

# gps_info (12), its payload holding field 13 as a varint: a number SensorBoardGPSInfo lacks.
UNKNOWN = bytes.fromhex("62026805")


def test_an_unknown_field_is_listed_with_its_number_and_wire_type(codec: Codec) -> None:
    """``62026805`` decoded, exit 0, without a word about field 13."""
    decoded = codec.decode(UNKNOWN)
    assert decoded.kind == "gps_info"
    assert decoded.unknown_fields == (erc_codec.UnknownField("", 13, 0),)
    assert decoded.to_dict()["unknown_fields"] == [{"path": "", "number": 13, "wire_type": 0}]
    # kept: a relay sends on what it did not understand
    assert codec.decode(codec.encode(decoded.message)).unknown_fields == decoded.unknown_fields


def test_a_known_number_with_another_wire_type_is_unknown_too(codec: Codec) -> None:
    # gps_info's field 8 (satellites, a varint) as a 32-bit value
    decoded = codec.decode(bytes.fromhex("620545") + bytes(4)[:-1] + b"\x01")
    assert decoded.unknown_fields == (erc_codec.UnknownField("", 8, 5),)
    assert decoded.message.satellites == 0  # type: ignore[attr-defined]


def test_unknown_fields_inside_a_nested_message_name_its_path(codec: Codec) -> None:
    motor = codec.message_class("arm_diag")().base_motor  # type: ignore[attr-defined]
    assert motor is not None
    nested = codec.encode(codec.from_dict("arm_diag", {"base_motor": {"motor_id": 3}}), "exact")
    # append field 15 (varint 1) inside base_motor: rebuild the payload by hand
    payload = codec.decode(nested).message.SerializeToString()
    number = codec.message_class("arm_diag").DESCRIPTOR.fields_by_name["base_motor"].number
    inner = payload[2:] + b"\x78\x01"
    body = bytes([number << 3 | 2, len(inner)]) + inner
    datagram = bytes([3 << 3 | 2, len(body)]) + body
    assert codec.decode(datagram).unknown_fields == (erc_codec.UnknownField("base_motor", 15, 0),)


def test_strict_makes_unknown_fields_a_decode_error(codec: Codec) -> None:
    with pytest.raises(DecodeError, match="does not know: 13 \\(wire type 0\\)") as raised:
        codec.decode(UNKNOWN, strict=True)
    assert raised.value.reason == "unknown_fields"
    known = codec.encode(codec.from_dict("gps_info", {"satellites": 9}))
    assert codec.decode(known, strict=True).kind == "gps_info"


def test_decode_output_carries_unknown_fields_and_strict_refuses_them() -> None:
    def run(*args: str) -> subprocess.CompletedProcess[str]:
        command = [sys.executable, "-m", "erc_codec", "decode", *args]
        return subprocess.run(command, capture_output=True, text=True, check=False)

    done = run(UNKNOWN.hex())
    assert done.returncode == 0
    record = json.loads(done.stdout)
    assert record["unknown_fields"] == [{"path": "", "number": 13, "wire_type": 0}]
    assert list(record) == ["kind", "length", "message", "unknown_fields"]
    strict = run("--strict", UNKNOWN.hex())
    assert strict.returncode == 1
    assert json.loads(strict.stdout)["reason"] == "unknown_fields"


def test_decoded_turns_into_the_cli_json_object(codec: Codec) -> None:
    datagram = codec.encode(codec.from_dict("gps_info", {"satellites": 9, "latitude": 1.5}))
    done = subprocess.run(
        [sys.executable, "-m", "erc_codec", "decode", datagram.hex()],
        capture_output=True,
        text=True,
        check=True,
    )
    line = json.loads(done.stdout)
    assert line.pop("length") == len(datagram)
    assert line == codec.decode(datagram).to_dict()
    assert json.loads(codec.decode(datagram).to_json()) == line


def test_a_message_class_of_another_schema_is_an_encode_error(codec: Codec, fleet: Path) -> None:
    """The fleet's envelope given to the packaged codec encoded into whatever member it named."""
    fleet_codec = Codec.from_path(fleet)
    envelope = fleet_codec.from_dict("PBEnvelope", {"gps_info": {"satellites": 3}})
    with pytest.raises(EncodeError, match="PBEnvelope is a message class of another schema"):
        codec.encode(envelope)
    with pytest.raises(EncodeError, match="not a payload type of PBEnvelope"):
        codec.encode(fleet_codec.message_class("manual_arm_velocity")())
    # the same declaration in another pool (as generated code of the same .proto has) is fine
    same = Codec.from_path(REPO / "proto").message_class("gps_info")(satellites=3)
    assert codec.decode(codec.encode(same)).message == codec.from_dict(
        "gps_info", {"satellites": 3}
    )


@pytest.mark.parametrize("value", [b"620b09", "gps_info", 5, None])
def test_encode_of_what_is_no_message_is_a_type_error(codec: Codec, value: object) -> None:
    with pytest.raises(
        TypeError, match=f"encode takes a protobuf message .*not {type(value).__name__}"
    ):
        codec.encode(value)  # type: ignore[arg-type]


def test_loading_with_wrong_types_is_a_type_error() -> None:
    with pytest.raises(TypeError, match="tree is a folder"):
        Codec.from_path(5)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="root is a message name"):
        Codec.from_path(REPO / "proto", root=b"PBEnvelope")  # type: ignore[arg-type]


# gps_info (12, empty), then field 20 as a varint on PBEnvelope itself: 20 is a member, which a
# varint cannot be, so protobuf keeps it as an unknown field of the envelope.
BESIDE = bytes.fromhex("6200a00101")
# gps_info, then field 40 (length-delimited, two bytes): a number PBEnvelope lacks altogether.
LACKED = bytes.fromhex("6200c2020201ff")


def test_an_unknown_field_beside_the_payload_is_listed_on_the_envelope(codec: Codec) -> None:
    """``6200a00101`` decoded as gps_info with no unknown fields: field 20 went unseen."""
    decoded = codec.decode(BESIDE)
    assert decoded.kind == "gps_info"
    assert decoded.unknown_fields == (erc_codec.UnknownField("PBEnvelope", 20, 0),)
    assert decoded.envelope_unknown_fields == decoded.unknown_fields
    assert codec.decode(LACKED).unknown_fields == (erc_codec.UnknownField(codec.root, 40, 2),)
    assert decoded.to_dict()["unknown_fields"] == [
        {"path": "PBEnvelope", "number": 20, "wire_type": 0}
    ]
    # the payload's own come after the envelope's; a datagram of this schema has none at all
    both = codec.decode(bytes.fromhex("62026805a00101"))
    assert both.unknown_fields == (
        erc_codec.UnknownField("PBEnvelope", 20, 0),
        erc_codec.UnknownField("", 13, 0),
    )
    with_timeout = codec.encode(codec.message_class("drive_motor")(), "strip", timeout=300)
    assert codec.decode(with_timeout).unknown_fields == ()
    assert codec.decode(with_timeout).envelope_unknown_fields == ()


def test_an_unknown_field_before_the_payload_is_listed_too(codec: Codec) -> None:
    decoded = codec.decode(bytes.fromhex("a001016200"))
    assert (decoded.kind, decoded.unknown_fields) == (
        "gps_info",
        (erc_codec.UnknownField("PBEnvelope", 20, 0),),
    )


@pytest.mark.parametrize("mode", ["strip", "exact", "pad"])
def test_every_form_of_such_a_datagram_shows_its_envelope_field(codec: Codec, mode: str) -> None:
    datagram = {"strip": LACKED, "exact": LACKED, "pad": LACKED + bytes(8)}[mode]
    assert codec.decode(datagram).envelope_unknown_fields == (
        erc_codec.UnknownField("PBEnvelope", 40, 2),
    )


def test_strict_refuses_unknown_fields_on_the_envelope_in_the_payloads_words(
    codec: Codec,
) -> None:
    with pytest.raises(DecodeError) as raised:
        codec.decode(BESIDE, strict=True)
    assert raised.value.reason == "unknown_fields"
    assert str(raised.value) == (
        "datagram of 5 bytes: its envelope holds fields PBEnvelope does not know: "
        "20 (wire type 0) (another schema?)"
    )
    with pytest.raises(DecodeError) as both:
        codec.decode(bytes.fromhex("62026805a00101"), strict=True)
    assert str(both.value) == (
        "datagram of 7 bytes: its envelope holds fields PBEnvelope does not know: "
        "20 (wire type 0); its gps_info payload holds fields SensorBoardGPSInfo does not know: "
        "13 (wire type 0) (another schema?)"
    )
    timed = codec.encode(codec.message_class("drive_motor")(), "strip", timeout=300)
    assert codec.decode(timed, strict=True).timeout == 300


def test_decode_output_shows_the_envelopes_unknown_fields_and_strict_refuses_them() -> None:
    def run(*args: str) -> subprocess.CompletedProcess[str]:
        command = [sys.executable, "-m", "erc_codec", "decode", *args]
        return subprocess.run(command, capture_output=True, text=True, check=False)

    done = run(BESIDE.hex())
    assert done.returncode == 0, done.stderr
    record = json.loads(done.stdout)
    assert record["unknown_fields"] == [{"path": "PBEnvelope", "number": 20, "wire_type": 0}]
    strict = run("--strict", BESIDE.hex())
    assert strict.returncode == 1
    refused = json.loads(strict.stdout)
    assert refused["reason"] == "unknown_fields"
    assert "its envelope holds fields PBEnvelope does not know: 20" in refused["error"]


def test_reencode_sends_on_the_envelopes_unknown_fields_byte_for_byte(codec: Codec) -> None:
    """Re-encoding the payload loses what sat beside it; ``reencode`` keeps all of it."""
    assert codec.encode(codec.decode(BESIDE).message) == bytes.fromhex("62")  # field 20 gone
    assert codec.reencode(codec.decode(BESIDE)) == BESIDE
    assert codec.reencode(codec.decode(LACKED), "exact") == LACKED
    assert codec.reencode(codec.decode(LACKED), "pad") == LACKED + bytes(MAX - len(LACKED))
    # protobuf writes the fields it knows first: the unknown one moves, its bytes stay
    assert codec.reencode(codec.decode(bytes.fromhex("a001016200"))) == BESIDE
    # metadata, unknown fields beside it and in the payload: everything, both ways round
    mixed = codec.decode(bytes.fromhex("62026805a00101f001ac02"))
    assert codec.reencode(mixed) == bytes.fromhex("62026805f001ac02a00101")
    again = codec.decode(codec.reencode(mixed))
    assert (again.timeout, again.unknown_fields) == (300, mixed.unknown_fields)
    # a datagram of the usual shape re-encodes as encode does it
    usual = codec.encode(codec.from_dict("gps_info", {"satellites": 9}))
    assert codec.decode(usual).envelope is None
    assert codec.reencode(codec.decode(usual)) == usual
    with pytest.raises(TypeError, match="reencode takes what decode returned"):
        codec.reencode(codec.decode(usual).message)  # type: ignore[arg-type]


def test_an_envelope_in_a_package_is_named_in_full_and_a_plain_root_reencodes(
    tmp_path: Path,
) -> None:
    (tmp_path / "p.proto").write_text(
        'syntax = "proto3";\npackage rover;\n'
        "message Reading { uint32 b = 2; }\n"
        "message Env { oneof payload { Reading reading = 1; } }\n"
    )
    envelope = Codec.from_path(tmp_path, "rover.Env")
    decoded = envelope.decode(bytes.fromhex("0a00a00101"))
    assert decoded.unknown_fields == (erc_codec.UnknownField("rover.Env", 20, 0),)
    assert decoded.unknown_fields[0].path == envelope.root
    with pytest.raises(
        DecodeError, match=r"its envelope holds fields rover\.Env does not know: 20"
    ):
        envelope.decode(bytes.fromhex("0a00a00101"), strict=True)
    plain = Codec.from_path(tmp_path, "rover.Reading")
    data = bytes.fromhex("1007a00101")  # b: 7, and field 20, which Reading lacks: the root's own
    assert plain.decode(data).unknown_fields == (erc_codec.UnknownField("", 20, 0),)
    assert plain.reencode(plain.decode(data)) == data


# -- the fast path never looks, and never needs to --------------------------------------------

CODEC = Codec.default()


def beside_the_payload(data: bytes) -> tuple[erc_codec.UnknownField, ...]:
    """The plain version: walk the top-level fields (zeros restored past the end, a zero byte
    where a tag is expected ending the message); a number neither a member sent
    length-delimited nor a metadata field sent as a varint is unknown to the envelope."""
    found, pos = [], 0
    while pos < len(data) and data[pos]:
        field = next_field(data, pos, zeros_past_end=True)
        if field.number in CODEC.kinds():
            expected = LEN
        else:
            expected = VARINT if field.number in CODEC.metadata_fields() else -1
        if field.wire_type != expected:
            found.append(erc_codec.UnknownField(CODEC.root, field.number, field.wire_type))
        pos = field.end
    return tuple(found)


def assert_listed_as_the_walk_finds(data: bytes) -> None:
    try:
        decoded = CODEC.decode(data)
    except DecodeError:
        return
    walked = beside_the_payload(data)
    assert decoded.envelope_unknown_fields == walked
    assert decoded.unknown_fields[: len(walked)] == walked
    if not walked:
        return
    try:
        sent = CODEC.reencode(decoded, "exact")
    except EncodeError:  # hostile bytes may break the contract: those are not sent at all
        return
    # sent on, all of them; protobuf writes the fields it knows first, so in any order
    assert sorted(CODEC.decode(sent).envelope_unknown_fields) == sorted(walked)


@given(hostile_datagrams(CODEC))
@settings(max_examples=300, suppress_health_check=[HealthCheck.too_slow])
def test_the_envelopes_unknown_fields_are_what_a_walk_finds_on_hostile_bytes(
    data: bytes,
) -> None:
    """decode's fast path takes only a datagram that is one member field and nothing else, so it
    never looks for unknown fields beside the payload (benchmarks/bench_codec.py's decode target);
    the general path lists them. Both agree with a plain walk of the top level."""
    assert_listed_as_the_walk_finds(data)


@given(
    st.sampled_from(
        [bytes.fromhex("6200"), bytes.fromhex("4a00"), bytes.fromhex("62026805"), b"\x62"]
    ),
    st.lists(
        st.tuples(st.integers(1, 2047).filter(lambda n: n != 30), st.sampled_from([VARINT, LEN])),
        max_size=3,
    ),
    st.booleans(),
)
def test_the_envelopes_unknown_fields_are_what_a_walk_finds_beside_any_payload(
    payload: bytes, extra: list[tuple[int, int]], before: bool
) -> None:
    fields = b"".join(
        encode_varint(number << 3 | wire) + (b"\x01" if wire == VARINT else b"\x01\xff")
        for number, wire in extra
        if not (number in CODEC.kinds() and wire == LEN)  # that would be a second payload
    )
    data = fields + payload if before else payload + fields
    try:
        beside_the_payload(data)
    except WireError:
        return
    assert_listed_as_the_walk_finds(data)
