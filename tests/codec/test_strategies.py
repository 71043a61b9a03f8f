"""erc_codec.strategies reaches the corners a fixed-size receiver must handle."""

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from conftest import TESTS
from hypothesis import Phase, find, given, settings
from hypothesis import strategies as st

import erc_codec
from erc_codec import strategies

CODEC = erc_codec.Codec.default()
# Finding an example is the test; shrinking it would only cost time.
QUICK = settings(max_examples=5000, phases=[Phase.generate], database=None)


def floats(message: Any) -> list[float]:
    return [value for field, value in message.ListFields() if isinstance(value, float)]


@pytest.mark.parametrize(
    ("name", "condition"),
    [
        (
            "SensorBoardIMUInfo",
            lambda m: any(v == 0 and math.copysign(1, v) < 0 for v in floats(m)),
        ),
        ("SensorBoardIMUInfo", lambda m: any(math.isinf(v) and v < 0 for v in floats(m))),
        ("SensorBoardIMUInfo", lambda m: any(0 < abs(v) < 1.2e-38 for v in floats(m))),
        ("SensorBoardGPSInfo", lambda m: m.latitude == 1.7976931348623157e308),
        ("SensorBoardGPSInfo", lambda m: m.utc_timestamp == -(2**63)),
        ("SensorBoardGPSInfo", lambda m: m.satellites == 2**31 - 1),
        ("SensorBoardGPSInfo", lambda m: m.fix_quality == 5),  # RTK_FLOAT, the largest
        ("SensorBoardDiagnostics", lambda m: not m.HasField("gps_sensor_1")),
        ("SensorBoardDiagnostics", lambda m: m.HasField("gps_sensor_1")),
    ],
)
def test_corner_cases_are_drawn(name: str, condition: Callable[[Any], bool]) -> None:
    find(strategies.messages(CODEC, name), condition, settings=QUICK)


def test_nan_only_on_request() -> None:
    find(
        strategies.messages(CODEC, "SensorBoardPHInfo", allow_nan=True),
        lambda m: math.isnan(m.ph_value),
        settings=QUICK,
    )


def test_an_unknown_message_name_is_a_schema_error() -> None:
    with pytest.raises(erc_codec.SchemaError, match="NoSuchMessage"):
        strategies.messages(CODEC, "NoSuchMessage")


PRESENCE = erc_codec.Codec.from_path(TESTS / "schema_trees" / "presence", root="Env")


@pytest.mark.parametrize("name", ["Counter", "Choice"])
@given(data=st.data())
def test_presence_is_drawn_and_survives_every_form(name: str, data: st.DataObject) -> None:
    message = data.draw(strategies.messages(PRESENCE, name))
    for mode in ("strip", "exact", "pad"):
        decoded = PRESENCE.decode(PRESENCE.encode(message, mode)).message
        assert decoded.SerializeToString() == message.SerializeToString()
        assert decoded.ListFields() == message.ListFields()  # presence included


@pytest.mark.parametrize(
    ("name", "condition"),
    [
        ("Counter", lambda m: m.HasField("count") and m.count == 0),  # an explicit zero
        ("Counter", lambda m: not m.HasField("level")),
        ("Choice", lambda m: m.WhichOneof("value") is None),
        ("Choice", lambda m: m.WhichOneof("value") == "flag" and not m.flag),
    ],
)
def test_presence_corners_are_drawn(name: str, condition: Callable[[Any], bool]) -> None:
    find(strategies.messages(PRESENCE, name), condition, settings=QUICK)


WIDE_PROTO = """syntax = "proto3";
message Wide {
  string text = 1;
  repeated string words = 2;
  map<string, string> by = 3;
}
"""
WIDE_OPTIONS = """Wide.text max_size:1024
Wide.words max_size:256 max_count:4
Wide.by max_count:4
Wide.ByEntry.key max_size:64
Wide.ByEntry.value max_size:256
"""


def test_every_string_drawn_is_utf8(tmp_path: Path) -> None:
    # A surrogate (category Cs) is a str but no UTF-8: drawing one once raised UnicodeEncodeError,
    # after some 3,000 messages of short strings. Long strings, alone, in lists and as map keys and
    # values, meet one in about 4 runs of 5 with the old alphabet, at a tenth of the time; the run
    # must reach past the BMP.
    (tmp_path / "wide.proto").write_text(WIDE_PROTO)
    (tmp_path / "wide.options").write_text(WIDE_OPTIONS)
    wide = erc_codec.Codec.from_path(tmp_path, root="Wide")
    widest = []

    @settings(max_examples=1000, phases=[Phase.generate], database=None, deadline=None)
    @given(strategies.messages(wide, "Wide"))
    def check(message: Any) -> None:
        texts = [message.text, *message.words, *message.by, *message.by.values()]
        for text in texts:
            text.encode("utf-8")
        widest.append(max((ord(c) for text in texts for c in text), default=0))
        wide.encode(message)

    check()
    assert max(widest) > 0xFFFF


ENVELOPES = {
    "packaged": CODEC,
    "metadata": erc_codec.Codec.from_path(TESTS / "schema_trees" / "metadata", root="Env"),
    # two of its three members nobody can send as nanopb reads them, and a timeout beside them
    "unsendable": erc_codec.Codec.from_path(TESTS / "any_trees" / "unsendable", root="Env"),
}


@pytest.mark.parametrize("tree", sorted(ENVELOPES))
@given(data=st.data())
@settings(max_examples=100)
def test_an_envelope_root_always_carries_one_payload_and_round_trips(
    tree: str, data: st.DataObject
) -> None:
    """The envelope root of each codec: every draw sets one member the codec sends, with its
    metadata, and decodes back, in every form, to the same envelope."""
    codec = ENVELOPES[tree]
    envelope: Any = data.draw(strategies.messages(codec, codec.root))
    member = next(iter(codec.kinds().values()))
    oneof = codec.schema.descriptor(codec.root).fields_by_name[member].containing_oneof
    assert oneof is not None
    kind = envelope.WhichOneof(oneof.name)
    assert kind is not None
    codec.payload_class(kind)  # one the codec can send
    for mode in ("strip", "exact", "pad"):
        decoded = codec.decode(codec.encode(envelope, mode), strict=True)
        rebuilt = codec.message_class(codec.root)(**{kind: decoded.message}, **decoded.metadata)
        assert (decoded.kind, rebuilt) == (kind, envelope)


@pytest.mark.parametrize(
    "condition",
    [
        lambda m: m.WhichOneof("payload") == "note" and m.origin and m.HasField("offset"),
        lambda m: m.WhichOneof("payload") == "ping" and not m.ListFields()[1:],
    ],
    ids=["all-metadata", "no-metadata"],
)
def test_an_envelopes_metadata_is_drawn_set_and_not(condition: Callable[[Any], bool]) -> None:
    find(strategies.messages(ENVELOPES["metadata"], "Env"), condition, settings=QUICK)
