"""nanopb's field model (label_override, type_override) is one, and everything follows it.

The size engine, the contract, strict decode and erc_codec.strategies ask ``Sizes`` what nanopb
makes of a field; these tests hold each to it without the C library
(tests/interop/test_interop_overrides.py holds them to the C library itself).
"""

from pathlib import Path
from typing import Any

import pytest
from conftest import TESTS
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import erc_codec
from erc_codec import strategies
from erc_schema import Sizes, load_schema

OVERRIDES = TESTS / "any_trees" / "overrides"
CODECS = {
    root: erc_codec.Codec.from_path(OVERRIDES, root=root) for root in ("Overrides2", "Overrides3")
}


def _field(root: str, name: str) -> Any:
    return CODECS[root].message_class(root).DESCRIPTOR.fields_by_name[name]


@pytest.mark.parametrize(
    ("root", "name", "repeated", "required"),
    [
        ("Overrides3", "latest", False, False),
        ("Overrides3", "only", False, True),
        ("Overrides3", "history", True, False),
        ("Overrides3", "count", False, True),
        ("Overrides2", "last", False, False),
        ("Overrides2", "must", False, True),
        ("Overrides2", "loose", False, False),
        ("Overrides2", "words", False, True),
    ],
)
def test_the_model_reads_label_override(
    root: str, name: str, repeated: bool, required: bool
) -> None:
    sizes = CODECS[root].nanopb
    assert (sizes.repeated(_field(root, name)), sizes.required(_field(root, name))) == (
        repeated,
        required,
    )


def test_the_model_reads_type_override() -> None:
    sizes = CODECS["Overrides3"].nanopb
    label, name = _field("Overrides3", "label"), _field("Overrides3", "name")
    assert sizes.field_type(label) == label.TYPE_BYTES
    assert sizes.max_bytes(label) == 32  # max_length 31 + the NUL bytes do not need
    assert sizes.field_type(name) == name.TYPE_STRING
    assert sizes.max_bytes(name) == 7  # max_size 8 less the NUL
    assert sizes.int_range(_field("Overrides3", "wide")) == (0, 2**32 - 1)
    assert sizes.int_range(_field("Overrides3", "narrow")) == (-(2**31), 2**31 - 1)
    assert sizes.c_integer(_field("Overrides3", "wide")) == ("unsigned", 32)


def test_sizes_come_from_the_same_model() -> None:
    """label 1 + 1 + 32; history (1 + 1 + 6) * 2; latest, only 1 + 1 + 6 each; ..."""
    assert CODECS["Overrides3"].sizes() == {"Reading": 6, "Overrides3": 98}
    assert CODECS["Overrides2"].sizes() == {"Overrides2": 39}


@pytest.mark.parametrize(
    ("values", "error"),
    [
        (
            {"count": 0},
            r"Overrides3\.count is required \(nanopb label_override\) but holds its default",
        ),
        ({"only": []}, r"Overrides3\.only holds 0 items; label_override REQUIRED needs exactly 1"),
        ({"latest": [{}, {}]}, r"Overrides3\.latest holds 2 items, more than the one nanopb holds"),
        ({"label": "x" * 33}, r"Overrides3\.label is 33 bytes long, more than the 32 allowed"),
        ({"name": b"a\0b"}, r"Overrides3\.name holds a NUL at byte 1"),
        ({"name": b"x" * 8}, r"Overrides3\.name is 8 bytes long, more than the 7 allowed"),
        (
            {"wide": 2**32},
            r"Overrides3\.wide = 4294967296 does not fit nanopb's type_override TYPE_UINT32",
        ),
        ({"narrow": -(2**31) - 1}, r"Overrides3\.narrow = -2147483649 does not fit"),
    ],
)
def test_the_contract_follows_the_model(values: dict[str, Any], error: str) -> None:
    codec = CODECS["Overrides3"]
    message = codec.message_class("Overrides3")(**{"only": [{}], "count": 1, **values})
    with pytest.raises(erc_codec.EncodeError, match=error):
        codec.encode(message)


def test_what_the_raw_descriptor_would_refuse_is_sent() -> None:
    codec = CODECS["Overrides3"]
    message = codec.message_class("Overrides3")(only=[{}], count=1, label="a\0" * 16)
    assert codec.decode(codec.encode(message), strict=True).message == message
    loose = CODECS["Overrides2"].message_class("Overrides2")(must=0, words=["w"])  # no `loose`
    assert CODECS["Overrides2"].decode(CODECS["Overrides2"].encode(loose), strict=True) == (
        "Overrides2",
        loose,
    )


@pytest.mark.parametrize(
    ("field", "why"),
    [
        ("repeated int32 x = 1 [(nanopb).label_override = LABEL_OPTIONAL];", "packed"),
        (
            "int32 x = 1 [(nanopb).label_override = LABEL_REPEATED, (nanopb).max_count = 2];",
            "nanopb writes it packed",
        ),
        ("int32 x = 1 [(nanopb).type_override = TYPE_SINT32];", "type_override SINT32 of a INT32"),
        ("float x = 1 [(nanopb).type_override = TYPE_INT32];", "written differently"),
    ],
    ids=["packed-made-single", "single-made-array", "zigzag", "float-as-int"],
)
def test_an_override_protobuf_cannot_write_as_nanopb_reads_it_is_a_schema_error(
    tmp_path: Path, field: str, why: str
) -> None:
    """The codec loads with nanopb's size; encoding or decoding M is the SchemaError."""
    (tmp_path / "m.proto").write_text(
        f'syntax = "proto3";\nimport "nanopb.proto";\nmessage M {{\n  {field}\n}}\n'
    )
    size = Sizes(load_schema(tmp_path, root="M")).max_size("M")
    assert size > 0  # nanopb sizes it all the same
    codec = erc_codec.Codec.from_path(tmp_path, root="M")
    assert codec.max_size("M") == codec.sizes()["M"] == size
    message = codec.schema.message_class("M")()
    for attempt in (
        lambda: codec.encode(message),
        lambda: codec.decode(b"\x08\x01"),
        lambda: codec.message_class("M"),
    ):
        with pytest.raises(erc_codec.SchemaError, match=rf"M\.x: .*{why}"):
            attempt()


@pytest.mark.parametrize("root", sorted(CODECS))
@given(data=st.data())
@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_strategies_draw_what_the_contract_and_strict_decode_take(
    root: str, data: st.DataObject
) -> None:
    codec = CODECS[root]
    message = data.draw(strategies.messages(codec, root))
    for mode in ("exact", "strip", "pad"):
        assert codec.decode(codec.encode(message, mode), strict=True) == (root, message)


def test_an_envelope_sends_a_proto2_required_field_nanopb_does_not_require(tmp_path: Path) -> None:
    """Overrides2.loose is proto2 ``required``, made optional by label_override: protobuf's
    own serializer refuses the payload without it, nanopb takes it (it was an EncodeError, and
    protobuf's own with a traceback for a whole envelope)."""
    (tmp_path / "overrides2.proto").write_text((OVERRIDES / "overrides2.proto").read_text())
    (tmp_path / "env.proto").write_text(
        'syntax = "proto3";\nimport "overrides2.proto";\n'
        "message Env {\n  oneof payload {\n    Overrides2 two = 1;\n  }\n}\n"
    )
    codec = erc_codec.Codec.from_path(tmp_path, root="Env")
    payload = codec.message_class("Overrides2")(must=0, words=["w"])
    envelope = codec.message_class("Env")(two=payload)
    for message in (payload, envelope):
        data = codec.encode(message, "exact")
        assert data == envelope.SerializePartialToString()
        assert codec.decode(data, strict=True) == ("two", payload)
    with pytest.raises(erc_codec.EncodeError, match=r"Overrides2\.must is required"):
        codec.encode(codec.message_class("Overrides2")(words=["w"]))


def test_an_envelope_sends_an_unrequired_field_unset_when_nothing_else_is_checked(
    tmp_path: Path,
) -> None:
    """A payload whose only rule is a required field made optional (label_override) has no
    contract check at all: sent without it, with and without metadata, not refused as "unset
    required fields" (nor by protobuf's serializer when the metadata is set)."""
    (tmp_path / "loose.proto").write_text(
        'syntax = "proto2";\nimport "nanopb.proto";\n'
        "message Loose {\n"
        "  required int32 a = 1 [(nanopb).label_override = LABEL_OPTIONAL];\n"
        "  optional int32 b = 2;\n}\n"
    )
    (tmp_path / "env.proto").write_text(
        'syntax = "proto3";\nimport "loose.proto";\n'
        "message Env {\n  oneof payload {\n    Loose loose = 1;\n  }\n  uint32 timeout = 5;\n}\n"
    )
    codec = erc_codec.Codec.from_path(tmp_path, root="Env")
    payload = codec.message_class("Loose")(b=1)
    envelope = codec.message_class("Env")(loose=payload)
    data = codec.encode(payload, "exact")
    assert data == envelope.SerializePartialToString() == bytes.fromhex("0a021001")
    assert codec.decode(data, strict=True) == ("loose", payload)
    with_timeout = codec.encode(payload, "exact", timeout=3)
    assert with_timeout == bytes.fromhex("0a0210012803")
    decoded = codec.decode(with_timeout, strict=True)
    assert (decoded.kind, decoded.message, decoded.metadata) == ("loose", payload, {"timeout": 3})
