"""Dispatcher: every datagram lands in exactly one counter, and every drop is reported."""

from collections.abc import Callable
from pathlib import Path

import pytest
from datagrams import MAX, beside, h, hostile_datagrams, widest_driving_diagnostics
from google.protobuf.message import Message
from hypothesis import example, given
from hypothesis import strategies as st

import erc_codec
from erc_codec import strategies
from erc_codec.codec._unknown import MAX_UNKEPT_NUMBERS
from erc_schema import descriptor_of, message_of

CODEC = erc_codec.Codec.default()
GPS = CODEC.message_class("SensorBoardGPSInfo")
IMU = CODEC.message_class("SensorBoardIMUInfo")


def test_handlers_get_their_payloads() -> None:
    seen: list[Message] = []
    dispatcher = erc_codec.runtime.Dispatcher(CODEC)
    dispatcher.register("gps_info", seen.append)

    @dispatcher.on("imu_info")
    def imu(message: Message) -> None:
        seen.append(message)

    fix, motion = GPS(latitude=52.2, satellites=7), IMU(accel_z=9.81)
    assert dispatcher.feed(CODEC.encode(fix))
    assert dispatcher.feed(CODEC.encode(motion, "pad"))
    assert seen == [fix, motion]
    assert dispatcher.stats().handled == {"gps_info": 1, "imu_info": 1}
    assert imu.__name__ == "imu"  # the decorator returns the function itself


def test_fields_beside_the_payload_are_counted_not_lost_without_a_word() -> None:
    """A handler takes the payload; an unknown field on the envelope has nowhere to go."""
    seen: list[Message] = []
    dispatcher = erc_codec.runtime.Dispatcher(CODEC)
    dispatcher.register("gps_info", seen.append)
    assert dispatcher.feed(h("62 00 a0 01 01"))  # field 20 as a varint, beside gps_info
    assert dispatcher.feed(h("a0 01 01 62 00 c2 02 02 01 ff a0 01 02"))  # 20 twice, and 40
    assert dispatcher.feed(h("62 02 68 05"))  # the payload's own: the handler has it
    assert seen == [GPS()] * 2 + [CODEC.decode(h("62 02 68 05")).message]
    stats = dispatcher.stats()
    assert (stats.handled, stats.unkept, stats.dropped) == ({"gps_info": 3}, {20: 2, 40: 1}, 0)


def test_the_unkept_table_stops_at_its_bound_and_counts_the_fields_past_it() -> None:
    """A sender of ever new field numbers beside the payload: the table lists the first numbers
    to come, no more, and counts every field of the others, once per datagram and number."""
    dispatcher = erc_codec.runtime.Dispatcher(CODEC)
    dispatcher.register("gps_info", lambda message: None)
    numbers = list(range(1000, 1000 + MAX_UNKEPT_NUMBERS + 100))
    rounds = [numbers[start : start + 50] for start in range(0, len(numbers), 50)]
    for numbers_of_one in rounds * 2:  # each number in two datagrams, once given twice
        assert dispatcher.feed(beside(numbers_of_one + numbers_of_one[-1:]))
    stats = dispatcher.stats()
    assert stats.handled == {"gps_info": 2 * len(rounds)}
    assert stats.unkept == {number: 2 for number in numbers[:MAX_UNKEPT_NUMBERS]}
    assert stats.unkept_unlisted == 2 * 100


def test_unknown_kinds_cannot_be_registered() -> None:
    with pytest.raises(erc_codec.SchemaError, match="'gps' is not a payload kind of PBEnvelope"):
        erc_codec.runtime.Dispatcher(CODEC).register("gps", print)


def test_every_drop_is_counted_and_reported() -> None:
    drops: list[erc_codec.runtime.Drop] = []
    dispatcher = erc_codec.runtime.Dispatcher(CODEC, on_drop=drops.append)

    def broken(message: Message) -> None:
        raise RuntimeError("handler bug")

    dispatcher.register("imu_info", broken)
    unhandled = CODEC.encode(GPS(satellites=3))
    datagrams = [b"", bytes.fromhex("b20100"), b"\x0a\x05\x01", unhandled, CODEC.encode(IMU())]
    assert [dispatcher.feed(d) for d in datagrams] == [False] * 5
    stats = dispatcher.stats()
    assert stats.undecodable == {"empty": 1, "unknown_member": 1, "corrupt": 1}
    assert stats.unhandled == {"gps_info": 1}
    assert stats.handler_errors == {"imu_info": 1}
    assert stats.dropped == 5
    assert [(d.reason, d.kind) for d in drops] == [
        ("empty", None),
        ("unknown_member", None),
        ("corrupt", None),
        ("unhandled", "gps_info"),
        ("handler_error", "imu_info"),
    ]
    assert drops[3].data == unhandled
    assert isinstance(drops[4].error, RuntimeError)
    assert isinstance(drops[1].error, erc_codec.DecodeError)


def test_a_failing_handler_does_not_stop_later_datagrams() -> None:
    calls: list[float] = []

    def flaky(message: Message) -> None:
        calls.append(message.latitude)  # type: ignore[attr-defined]
        if len(calls) == 1:
            raise ValueError("first one fails")

    dispatcher = erc_codec.runtime.Dispatcher(CODEC)
    dispatcher.register("gps_info", flaky)
    assert not dispatcher.feed(CODEC.encode(GPS(latitude=1)))
    assert dispatcher.feed(CODEC.encode(GPS(latitude=2)))
    assert calls == [1, 2]


def test_stats_are_snapshots() -> None:
    dispatcher = erc_codec.runtime.Dispatcher(CODEC)
    snapshot = dispatcher.stats()
    dispatcher.feed(b"")
    assert snapshot.undecodable == {}
    assert dispatcher.stats().undecodable == {"empty": 1}


KINDS = sorted(CODEC.kinds().values())


@st.composite
def datagrams(draw: st.DrawFn) -> tuple[str | None, bytes]:
    if draw(st.booleans()):
        return None, draw(st.binary(max_size=40))
    kind = draw(st.sampled_from(KINDS))
    member = descriptor_of(CODEC.message_class("PBEnvelope")).fields_by_name[kind]
    message = draw(strategies.messages(CODEC, message_of(member).full_name))
    return kind, CODEC.encode(message, draw(st.sampled_from(["strip", "exact", "pad"])))


@given(st.lists(datagrams(), max_size=30), st.sets(st.sampled_from(KINDS)))
def test_every_datagram_lands_in_exactly_one_counter(
    fed: list[tuple[str | None, bytes]], registered: set[str]
) -> None:
    drops: list[erc_codec.runtime.Drop] = []
    dispatcher = erc_codec.runtime.Dispatcher(CODEC, on_drop=drops.append)
    for kind in registered:
        dispatcher.register(kind, lambda message: None)
    handled = sum(dispatcher.feed(data) for _, data in fed)
    stats = dispatcher.stats()
    assert sum(stats.handled.values()) == handled
    assert handled + stats.dropped == len(fed)
    assert len(drops) == stats.dropped
    expected = sum(1 for kind, _ in fed if kind in registered)
    assert handled >= expected  # random bytes may happen to decode, too


@st.composite
def damaged_datagrams(draw: st.DrawFn) -> bytes:
    """Datagrams of every form, some cut, lengthened or with a byte changed: the edges of the
    dispatcher's short cut for exact datagrams (length bytes, sizes, payloads that fail)."""
    data = bytearray(draw(datagrams())[1])
    for _ in range(draw(st.integers(0, 2))):
        action = draw(st.sampled_from(["change", "cut", "grow"]))
        if action == "change" and data:
            data[draw(st.integers(0, len(data) - 1))] = draw(st.integers(0, 255))
        elif action == "cut" and data:
            del data[draw(st.integers(0, len(data) - 1)) :]
        else:
            data += draw(st.binary(min_size=1, max_size=140))
    return bytes(data)


def outcome(data: bytes) -> tuple[str, bytes] | str:
    """What decode makes of ``data``: kind and payload bytes, or the reason it fails."""
    try:
        decoded = CODEC.decode(data)
    except erc_codec.DecodeError as error:
        return error.reason
    return decoded.kind, decoded.message.SerializeToString()


CONTROL = CODEC.message_class("BasestationControlMode")
# The edges of the short cut: member 16 (a two-byte tag) padded, stripped to its tag, and with a
# payload its class cannot parse, padded too; a 255-byte datagram with a two-byte length; a
# datagram peek does not locate but decode reads (a field after the member); datagrams cut short,
# which look stripped (a fix's last byte lost, a varint cut in the middle, the same after
# another member).
EDGES = [
    CODEC.encode(CONTROL(mode=2), "pad"),
    CODEC.encode(CONTROL(), "strip"),
    h("82 01 01 08") + bytes(MAX - 4),
    h("0a 01 00"),
    CODEC.encode(widest_driving_diagnostics(CODEC), "exact"),
    h("22 00 28 00"),
    h("62 0b 09 d8 81 73 46 94 1e 4a 40 48"),
    h("62 03 40 a0"),
    h("0a 00 62 0b 09 d8 81 73 46 94 1e 4a 40 48"),
]


@example(fed=EDGES)
@given(st.lists(st.one_of(damaged_datagrams(), hostile_datagrams(CODEC)), max_size=20))
def test_handlers_get_exactly_what_decode_gives(fed: list[bytes]) -> None:
    """The dispatcher parses what peek locates itself (for the Dispatcher.feed target of
    benchmarks/bench_runtime.py): its handlers must get what decode gives, and its drops must
    carry decode's reasons, for every form, on hostile bytes too."""
    seen: list[tuple[str, bytes] | str] = []

    def recorder(kind: str) -> Callable[[Message], None]:
        return lambda message: seen.append((kind, message.SerializeToString()))

    dispatcher = erc_codec.runtime.Dispatcher(CODEC, on_drop=lambda drop: seen.append(drop.reason))
    for kind in KINDS:
        dispatcher.register(kind, recorder(kind))
    for data in fed:
        dispatcher.feed(data)
    assert seen == [outcome(data) for data in fed]


def unknown_field(size: int) -> bytes:
    """``size`` bytes that any message parses: one unknown length-delimited field (number 15)."""
    body = size - 3  # tag, two-byte length
    return bytes([15 << 3 | 2, body & 0x7F | 0x80, body >> 7]) + bytes(body)


def test_a_length_byte_that_continues_is_not_a_one_byte_length() -> None:
    # 0x85 equals the bytes after it, but as a varint it continues into the next byte.
    data = bytes([1 << 3 | 2, 0x85]) + unknown_field(0x85)
    assert outcome(data) == "corrupt"
    dispatcher = erc_codec.runtime.Dispatcher(CODEC)
    dispatcher.register(KINDS[0], lambda message: None)
    assert not dispatcher.feed(data)
    assert dispatcher.stats().undecodable == {"corrupt": 1}


def test_a_datagram_over_the_envelopes_size_is_dropped_however_it_looks(tmp_path: Path) -> None:
    (tmp_path / "small.proto").write_text(
        'syntax = "proto3";\nmessage Ping { uint32 n = 1; }\n'
        "message Env { oneof payload { Ping ping = 1; } }\n"
    )
    codec = erc_codec.Codec.from_path(tmp_path, root="Env")
    dispatcher = erc_codec.runtime.Dispatcher(codec)
    dispatcher.register("ping", lambda message: None)
    exact = bytes([1 << 3 | 2, 40]) + unknown_field(40)  # exact in form, but Env_size is 8
    # Stripped in form: a 10-byte payload whose last 8 bytes (zeros) are not sent.
    stripped = bytes([1 << 3 | 2, 10, 15 << 3 | 2, 8])
    for data in (exact, stripped):
        with pytest.raises(erc_codec.DecodeError) as raised:
            codec.decode(data)
        assert not dispatcher.feed(data)
        assert dispatcher.stats().undecodable[raised.value.reason] >= 1
    assert dispatcher.stats().dropped == 2
