"""Round-trip and robustness properties over every payload type, with hypothesis.

The fuzzer is here, and only here: its datagrams come from tests/datagrams.py (any bytes, bytes
behind a member tag, sent datagrams mutated), and each one goes through the same checks.
"""

import pytest
from datagrams import arbitrary_bytes, behind_a_member_tag, mutated_datagrams
from google.protobuf.message import Message
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import erc_codec
from erc_codec import strategies
from erc_codec.schema import descriptor_of, message_of

CODEC = erc_codec.Codec.default()
ENVELOPE = CODEC.message_class("PBEnvelope")
MAX = CODEC.max_size("PBEnvelope")
KINDS = sorted(CODEC.kinds().values())
MODES: list[erc_codec.Mode] = ["strip", "exact", "pad"]


def payload_type(kind: str) -> str:
    return message_of(descriptor_of(ENVELOPE).fields_by_name[kind]).full_name


def payloads(kind: str) -> st.SearchStrategy[Message]:
    return strategies.messages(CODEC, payload_type(kind))


@pytest.mark.parametrize("kind", KINDS)
@given(data=st.data())
def test_every_mode_round_trips(kind: str, data: st.DataObject) -> None:
    message = data.draw(payloads(kind))
    exact = CODEC.encode(message, "exact")
    wrapped = ENVELOPE()
    getattr(wrapped, kind).CopyFrom(message)
    assert exact == wrapped.SerializeToString()
    for mode in MODES:
        datagram = CODEC.encode(message, mode)
        decoded = CODEC.decode(datagram)
        assert decoded.kind == kind
        assert decoded.message == message
        # Byte equality also tells -0.0 from 0.0, which == does not.
        assert decoded.message.SerializeToString() == message.SerializeToString()
    assert CODEC.encode(message, "strip") == exact.rstrip(b"\0")
    assert len(CODEC.encode(message, "pad")) == MAX


@pytest.mark.parametrize("kind", KINDS)
@given(data=st.data())
def test_stripped_and_padded_forms_of_an_envelope_decode_alike(
    kind: str, data: st.DataObject
) -> None:
    envelope = ENVELOPE()
    getattr(envelope, kind).CopyFrom(data.draw(payloads(kind)))
    exact = envelope.SerializeToString()
    # Every length between stripped and padded is a form some sender may use.
    width = data.draw(st.integers(len(exact.rstrip(b"\0")), MAX))
    datagram = (exact.rstrip(b"\0") + bytes(MAX))[:width]
    if width < len(exact):
        assert exact[width:] == bytes(len(exact) - width)
    decoded = CODEC.decode(datagram)
    assert decoded.kind == kind
    assert decoded.message.SerializeToString() == getattr(envelope, kind).SerializeToString()


# -- the fuzzer: whatever arrives decodes or raises DecodeError ------------------------------------


def assert_decodes_soundly(data: bytes) -> None:
    """What ``decode`` makes of any datagram."""
    try:
        decoded = CODEC.decode(data)
    except erc_codec.DecodeError:
        return
    # Whatever decodes must be a message the envelope can carry again.
    assert decoded.kind in KINDS


@given(arbitrary_bytes(CODEC))
@settings(max_examples=2000, suppress_health_check=[HealthCheck.too_slow])
def test_arbitrary_bytes_decode_or_raise_decode_error(data: bytes) -> None:
    assert_decodes_soundly(data)


@given(behind_a_member_tag(CODEC))
@settings(max_examples=1000, suppress_health_check=[HealthCheck.too_slow])
def test_bytes_behind_a_member_tag_decode_or_raise_decode_error(data: bytes) -> None:
    assert_decodes_soundly(data)


@given(mutated_datagrams(CODEC))
@settings(max_examples=1000, suppress_health_check=[HealthCheck.too_slow])
def test_mutated_datagrams_decode_or_raise_decode_error(data: bytes) -> None:
    assert_decodes_soundly(data)


@pytest.mark.parametrize("kind", KINDS)
@given(data=st.data())
@settings(max_examples=25)
def test_strategy_draws_only_sendable_messages(kind: str, data: st.DataObject) -> None:
    message = data.draw(payloads(kind))
    assert len(CODEC.encode(message, "exact")) <= MAX
