"""Unknown data is visible: fields a schema does not know show in ``Decoded.unknown_fields`` and
in decode's output, ``strict=True`` / ``--strict`` makes them an error; a message class of another
schema is an ``EncodeError`` saying so, and arguments of the wrong type a ``TypeError``."""

import json
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import REPO

import erc_codec
from erc_codec import Codec, DecodeError, EncodeError

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
