"""Round-trip and robustness properties over every payload type, with hypothesis."""

import contextlib

import pytest
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


@given(st.binary(max_size=MAX + 8))
@settings(max_examples=2000, suppress_health_check=[HealthCheck.too_slow])
def test_arbitrary_bytes_decode_or_raise_decode_error(data: bytes) -> None:
    with contextlib.suppress(erc_codec.DecodeError):
        CODEC.decode(data)


@st.composite
def mutated_datagrams(draw: st.DrawFn) -> bytes:
    kind = draw(st.sampled_from(KINDS))
    datagram = bytearray(CODEC.encode(draw(payloads(kind)), draw(st.sampled_from(MODES))))
    for _ in range(draw(st.integers(1, 4))):
        action = draw(st.sampled_from(["flip", "cut", "insert", "delete"]))
        at = draw(st.integers(0, max(len(datagram) - 1, 0)))
        if action == "flip" and datagram:
            datagram[at] ^= 1 << draw(st.integers(0, 7))
        elif action == "cut":
            del datagram[at:]
        elif action == "insert":
            datagram[at:at] = draw(st.binary(min_size=1, max_size=4))
        elif datagram:
            del datagram[at]
    return bytes(datagram)


@given(mutated_datagrams())
@settings(max_examples=1000, suppress_health_check=[HealthCheck.too_slow])
def test_mutated_datagrams_decode_or_raise_decode_error(data: bytes) -> None:
    try:
        decoded = CODEC.decode(data)
    except erc_codec.DecodeError:
        return
    # Whatever decodes must be a message the envelope can carry again.
    assert decoded.kind in KINDS


@pytest.mark.parametrize("kind", KINDS)
@given(data=st.data())
@settings(max_examples=25)
def test_strategy_draws_only_sendable_messages(kind: str, data: st.DataObject) -> None:
    message = data.draw(payloads(kind))
    assert len(CODEC.encode(message, "exact")) <= MAX
