"""Round-trip and robustness properties over every payload type, with hypothesis.

The fuzzer is here, and only here: its datagrams come from tests/datagrams.py (any bytes, bytes
behind a member tag, sent datagrams mutated), and each one goes through the same checks
(``assert_decodes_soundly``): protobuf's own parser is the reference for what an exact datagram
holds, every other form of a datagram decodes alike, and what decodes encodes again.
"""

from collections.abc import Callable

import pytest
from datagrams import (
    MAX,
    MODES,
    arbitrary_bytes,
    behind_a_member_tag,
    h,
    mutated_datagrams,
    payloads,
    widest_driving_diagnostics,
)
from google.protobuf.message import DecodeError as ProtobufDecodeError
from google.protobuf.unknown_fields import UnknownFieldSet
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import erc_codec
from erc_codec import Decoded
from erc_schema import SGROUP

CODEC = erc_codec.Codec.default()
ENVELOPE = CODEC.message_class("PBEnvelope")
KINDS = sorted(CODEC.kinds().values())


@pytest.mark.parametrize("kind", KINDS)
@given(data=st.data())
def test_every_mode_round_trips(kind: str, data: st.DataObject) -> None:
    message = data.draw(payloads(CODEC, kind))
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
    getattr(envelope, kind).CopyFrom(data.draw(payloads(CODEC, kind)))
    exact = envelope.SerializeToString()
    # Every length between stripped and padded is a form some sender may use.
    width = data.draw(st.integers(len(exact.rstrip(b"\0")), MAX))
    datagram = (exact.rstrip(b"\0") + bytes(MAX))[:width]
    if width < len(exact):
        assert exact[width:] == bytes(len(exact) - width)
    decoded = CODEC.decode(datagram)
    assert decoded.kind == kind
    assert decoded.message.SerializeToString() == getattr(envelope, kind).SerializeToString()


# -- the fuzzer: whatever arrives is read as protobuf reads its exact form, or refused ---------


REASONS = {"empty", "too_long", "no_payload", "unknown_member", "corrupt", "truncated"}


def protobuf_reading(data: bytes) -> tuple[str, bytes] | None:
    """What protobuf's own parser makes of ``data`` as an envelope: the member and its payload's
    bytes. ``None`` where it refuses the bytes or finds no member in them, and where it takes a
    group at the top level, which the codec refuses (no proto3 envelope holds one)."""
    try:
        envelope = ENVELOPE.FromString(data)
    except ProtobufDecodeError:
        return None
    kind = envelope.WhichOneof("payload")
    unknown = UnknownFieldSet(envelope)
    if kind is None or any(unknown[i].wire_type == SGROUP for i in range(len(unknown))):
        return None
    return kind, getattr(envelope, kind).SerializeToString()


def zero_tail_forms(data: bytes) -> list[bytes]:
    """``data`` with some of its trailing zeros cut, or with zeros appended up to the envelope's
    size: the forms a sender's exact datagram may arrive in, if ``data`` is one of them. Shortest
    first, so the exact one comes early."""
    shortest = len(data.rstrip(b"\0"))
    return [data[:n] for n in range(shortest, len(data))] + [
        data + bytes(n) for n in range(1, MAX - len(data) + 1)
    ]


def decode_outcome(data: bytes) -> Decoded | erc_codec.DecodeError:
    """Decode, turning a DecodeError into a value; any other exception propagates (and fails)."""
    try:
        return CODEC.decode(data)
    except erc_codec.DecodeError as error:
        return error


def reading(decoded: Decoded) -> tuple[str, bytes]:
    """A decoded datagram as comparable values (bytes tell -0.0 from 0.0, and NaN from NaN)."""
    return decoded.kind, decoded.message.SerializeToString()


def canonical(form: bytes) -> bool:
    """Whether ``form`` is what protobuf (and so nanopb) writes for what it reads in it."""
    return ENVELOPE.FromString(form).SerializeToString() == form


def assert_decodes_soundly(data: bytes) -> None:
    """What ``decode`` makes of any datagram is what protobuf makes of its exact form, or a
    DecodeError; a cut datagram ("truncated") is one whose restored form no encoder writes;
    other forms of the same datagram decode alike, but for cut forms of a datagram no encoder
    writes; and whatever decodes is a message that encodes again to datagrams that decode to
    it."""
    exact = protobuf_reading(data) if len(data) <= MAX else None
    outcome = decode_outcome(data)
    forms = zero_tail_forms(data)
    if isinstance(outcome, erc_codec.DecodeError):
        assert outcome.reason in REASONS
        assert (outcome.reason == "empty") == (not data)
        assert (outcome.reason == "too_long") == (len(data) > MAX)
        assert exact is None, f"{data.hex()}: protobuf reads it as it came, decode says {outcome}"
        if outcome.reason == "truncated":
            # Restored, it is a form protobuf reads but never writes so (a default it leaves
            # out, a varint it writes shorter).
            longer = [form for form in forms if len(form) > len(data)]
            assert any(protobuf_reading(f) and not canonical(f) for f in longer), data.hex()
        return
    read = reading(outcome)
    kind = outcome.kind
    sent = ENVELOPE(**{kind: outcome.message}).SerializeToString()
    from_a_sender = sent.rstrip(b"\0") == data.rstrip(b"\0")
    if exact is not None:  # already exact: what protobuf's own parser makes of it, no less
        assert read == exact, data.hex()
    else:  # else what protobuf makes of the exact form it was stripped or padded from
        assert any(protobuf_reading(form) == read for form in forms), data.hex()
    # Every form decodes alike: each cut one, the first few padded ones (where a stripped last
    # field gets its zeros back), the fully padded one.
    for form in forms[: len(data) - len(data.rstrip(b"\0")) + 16] + forms[-1:]:
        if len(form) < len(data) and form[-1] & 0x80:
            continue  # the cut zero ended a varint no sender writes (0x80 0x00 for 0): not a form
        other = decode_outcome(form)
        if isinstance(other, erc_codec.DecodeError) and not from_a_sender and len(form) < len(data):
            assert other.reason == "truncated", (data.hex(), form.hex(), str(other))
            continue  # cut from what no encoder writes: its zeros were sent, not stripped
        assert not isinstance(other, erc_codec.DecodeError), (data.hex(), form.hex(), str(other))
        assert reading(other) == read, (data.hex(), form.hex())
    try:
        CODEC.encode(outcome.message, "exact")
    except erc_codec.EncodeError:
        return  # a flipped bit may make a value the contract refuses (an undeclared enum, say)
    for mode in MODES:
        assert reading(CODEC.decode(CODEC.encode(outcome.message, mode))) == read, mode


@given(arbitrary_bytes(CODEC))
@settings(max_examples=2000, suppress_health_check=[HealthCheck.too_slow])
def test_arbitrary_bytes_decode_or_raise_decode_error(data: bytes) -> None:
    assert_decodes_soundly(data)


@given(behind_a_member_tag(CODEC))
@settings(max_examples=1000, suppress_health_check=[HealthCheck.too_slow])
def test_bytes_behind_a_member_tag_decode_or_raise_decode_error(data: bytes) -> None:
    assert_decodes_soundly(data)


WIDEST = CODEC.encode(widest_driving_diagnostics(CODEC), "exact")  # 255 bytes, two-byte length
# Where the fuzzer seldom goes by chance: the widest datagram cut inside its header or short of
# its end, or one byte longer; varints no sender writes (a tag, a length); a group at the top level
# (protobuf takes it, the codec does not); a field after the member; two members; a length that
# restores past the envelope.
EDGES = [
    *(WIDEST[:n] for n in (1, 2, 3, 4, MAX - 1)),
    WIDEST[1:],
    WIDEST + b"\1",
    h("8a 00"),
    h("0a 80 00"),
    h("22 00 2b 2c"),
    h("22 00 28 00"),
    h("0a 00 12 00"),
    h("0a fd 01 0d 01"),
]


def at_the_edges(test: Callable[[bytes], None]) -> Callable[[bytes], None]:
    for data in EDGES:
        test = example(data)(test)
    return test


@at_the_edges
@given(mutated_datagrams(CODEC))
@settings(max_examples=1000, suppress_health_check=[HealthCheck.too_slow])
def test_mutated_datagrams_decode_or_raise_decode_error(data: bytes) -> None:
    assert_decodes_soundly(data)


@pytest.mark.parametrize("kind", KINDS)
@given(data=st.data())
@settings(max_examples=25)
def test_strategy_draws_only_sendable_messages(kind: str, data: st.DataObject) -> None:
    message = data.draw(payloads(CODEC, kind))
    assert len(CODEC.encode(message, "exact")) <= MAX
