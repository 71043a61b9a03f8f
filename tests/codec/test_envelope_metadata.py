"""Envelope metadata: fields beside the oneof, encoded on request and returned on decode.

The packaged envelope has one, ``uint32 timeout = 30``, written after the payload (fields go out
in number order), so the datagram's last field is not the payload. Another schema's metadata may
be numbered below the payload, or be several fields: they are carried the same way.
"""

from pathlib import Path
from typing import Any

import pytest
from datagrams import MAX, MODES, h

import erc_codec
from erc_codec import Codec, Decoded, DecodeError, EncodeError


def test_timeout_is_the_packaged_envelopes_metadata(codec: Codec) -> None:
    assert codec.metadata_fields() == {30: "timeout"}
    assert 30 not in codec.kinds()


@pytest.mark.parametrize("mode", MODES)
def test_a_stop_command_with_a_timeout_in_every_form(codec: Codec, mode: erc_codec.Mode) -> None:
    stop = codec.message_class("drive_motor")()
    data = codec.encode(stop, mode, timeout=300)
    exact = h("4a 00 f0 01 ac 02")  # payload "4a 00", then field 30: varint 300
    assert data == (exact + bytes(MAX - len(exact)) if mode == "pad" else exact)
    decoded = codec.decode(data)
    kind, message = decoded  # today's two-name unpacking keeps working
    assert (kind, message) == ("drive_motor", stop)
    assert decoded.timeout == 300
    assert dict(decoded.metadata) == {"timeout": 300}
    assert decoded == Decoded("drive_motor", stop)
    assert "metadata={'timeout': 300}" in repr(decoded)


def test_without_metadata_nothing_changes(codec: Codec) -> None:
    stop = codec.message_class("drive_motor")()
    assert codec.encode(stop, "exact") == h("4a 00")
    assert codec.encode(stop, "strip", timeout=0) == h("4a")  # 0 is never sent
    decoded = codec.decode(h("4a"))
    assert decoded.timeout == 0
    assert dict(decoded.metadata) == {}
    assert repr(decoded) == "Decoded(kind='drive_motor', message=)"


def test_a_whole_envelope_carries_its_metadata(codec: Codec) -> None:
    envelope: Any = codec.message_class("PBEnvelope")()
    envelope.drive_motor.distance_to_go = 1.0
    envelope.timeout = 5
    data = codec.encode(envelope)
    assert data == h("4a 05 0d 00 00 80 3f f0 01 05")
    assert codec.decode(data).timeout == 5
    # A keyword wins over the envelope's own value.
    assert codec.decode(codec.encode(envelope, timeout=7)).timeout == 7


def test_metadata_errors_name_the_field(codec: Codec) -> None:
    stop = codec.message_class("drive_motor")()
    with pytest.raises(EncodeError, match=r"no metadata field 'period'.*timeout"):
        codec.encode(stop, period=1)
    with pytest.raises(EncodeError, match=r"PBEnvelope\.timeout cannot be -1"):
        codec.encode(stop, timeout=-1)
    with pytest.raises(EncodeError, match=r"PBEnvelope\.timeout cannot be 'soon'"):
        codec.encode(stop, timeout="soon")
    with pytest.raises(EncodeError, match=r"PBEnvelope\.timeout cannot be 4294967296"):
        codec.encode(stop, timeout=2**32)


def test_a_cut_timeout_is_an_error(codec: Codec) -> None:
    with pytest.raises(DecodeError):
        codec.decode(h("4a 00 f0 01 ac"))  # its varint cut off: "ac" continues


def write(tmp_path: Path, text: str) -> Path:
    (tmp_path / "env.proto").write_text('syntax = "proto3";\n' + text)
    return tmp_path


OTHER = """
message Ping { uint32 id = 1; }
message Stop { float speed = 1; }
message Env {
  uint32 sequence = 1;
  oneof payload { Ping ping = 2; Stop stop = 3; }
  bool urgent = 20;
  sint32 skew = 21;
}
"""


def test_several_metadata_fields_before_and_after_the_payload(tmp_path: Path) -> None:
    other = Codec.from_path(write(tmp_path, OTHER), "Env")
    assert other.kinds() == {2: "ping", 3: "stop"}
    assert other.metadata_fields() == {1: "sequence", 20: "urgent", 21: "skew"}
    assert other.max_size("Env") == 6 + 8 + 3 + 7  # sequence, ping (1 + 1 + 6), urgent, skew
    stop = other.message_class("Stop")()
    data = other.encode(stop, "strip", sequence=7, urgent=True, skew=-1)
    assert data == h("08 07 1a 00 a0 01 01 a8 01 01")  # in number order: the payload between
    for mode in MODES:
        decoded = other.decode(other.encode(stop, mode, sequence=7, urgent=True, skew=-1))
        assert decoded == ("stop", stop)
        assert dict(decoded.metadata) == {"sequence": 7, "urgent": True, "skew": -1}
        assert decoded.timeout == 0  # this schema declares none
    # The payload last, ending in zeros, after metadata: stripped and restored.
    ping = other.message_class("Ping")()
    assert other.encode(ping, "strip", sequence=1) == h("08 01 12")
    assert other.decode(h("08 01 12")) == ("ping", ping)


def test_a_message_beside_the_oneof_makes_a_plain_root(tmp_path: Path) -> None:
    """A message with more than single scalars beside its oneof is no envelope: it loads as a
    plain root, sent as itself, with no kinds and no metadata."""
    tree = write(tmp_path, OTHER.replace("sint32 skew = 21;", "Ping extra = 30;"))
    codec = Codec.from_path(tree, "Env")
    assert isinstance(codec, erc_codec.MessageCodec)
    assert codec.kinds() == {}
    env = codec.message_class("Env")()
    assert codec.decode(codec.encode(env, "exact")) == ("Env", env)


def test_a_repeated_field_beside_the_oneof_needs_a_limit(tmp_path: Path) -> None:
    tree = write(tmp_path, OTHER.replace("sint32 skew = 21;", "repeated uint32 extra = 30;"))
    with pytest.raises(erc_codec.SchemaError, match=r"Env\.extra: repeated field without"):
        Codec.from_path(tree, "Env")


def test_metadata_without_a_payload_says_so(codec: Codec) -> None:
    with pytest.raises(DecodeError, match=r"metadata \(timeout\) but no payload") as caught:
        codec.decode(h("f0 01 05"))
    assert caught.value.reason == "no_payload"
    # A timeout cut off after its tag: restored, it would be 0, which no encoder sends.
    with pytest.raises(DecodeError, match=r"PBEnvelope\.timeout = 0") as cut:
        codec.decode(h("4a 00 f0 01"))
    assert cut.value.reason == "truncated"


def test_metadata_may_be_named_like_encodes_own_parameters(tmp_path: Path) -> None:
    """``mode`` and ``message`` are positional-only in ``encode``: a field may take the names."""
    text = OTHER.replace("bool urgent", "uint32 mode").replace("skew", "message")
    other = Codec.from_path(write(tmp_path, text), "Env")
    assert other.metadata_fields() == {1: "sequence", 20: "mode", 21: "message"}
    ping = other.message_class("Ping")(id=1)
    data = other.encode(ping, "exact", mode=3, message=-1)
    assert data == h("12 02 08 01 a0 01 03 a8 01 01")
    assert dict(other.decode(data).metadata) == {"mode": 3, "message": -1}
    router = erc_codec.runtime.Router(other, {"x": "strip"}, [erc_codec.runtime.Route(("x",))])
    assert router.route(data, "anyone", 0.0) == [erc_codec.runtime.Outgoing("x", data)]
