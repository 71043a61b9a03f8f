"""Dispatcher: every datagram lands in exactly one counter, and every drop is reported."""

import pytest
from google.protobuf.message import Message
from hypothesis import given
from hypothesis import strategies as st

import erc_codec
from erc_codec import strategies
from erc_codec._schema import descriptor_of, message_of

CODEC = erc_codec.Codec.default()
GPS = CODEC.message_class("SensorBoardGPSInfo")
IMU = CODEC.message_class("SensorBoardIMUInfo")


def test_handlers_get_their_payloads() -> None:
    seen: list[Message] = []
    dispatcher = erc_codec.Dispatcher(CODEC)
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


def test_unknown_kinds_cannot_be_registered() -> None:
    with pytest.raises(erc_codec.SchemaError, match="'gps' is not a payload kind of PBEnvelope"):
        erc_codec.Dispatcher(CODEC).register("gps", print)


def test_every_drop_is_counted_and_reported() -> None:
    drops: list[erc_codec.Drop] = []
    dispatcher = erc_codec.Dispatcher(CODEC, on_drop=drops.append)

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

    dispatcher = erc_codec.Dispatcher(CODEC)
    dispatcher.register("gps_info", flaky)
    assert not dispatcher.feed(CODEC.encode(GPS(latitude=1)))
    assert dispatcher.feed(CODEC.encode(GPS(latitude=2)))
    assert calls == [1, 2]


def test_stats_are_snapshots() -> None:
    dispatcher = erc_codec.Dispatcher(CODEC)
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
    drops: list[erc_codec.Drop] = []
    dispatcher = erc_codec.Dispatcher(CODEC, on_drop=drops.append)
    for kind in registered:
        dispatcher.register(kind, lambda message: None)
    handled = sum(dispatcher.feed(data) for _, data in fed)
    stats = dispatcher.stats()
    assert sum(stats.handled.values()) == handled
    assert handled + stats.dropped == len(fed)
    assert len(drops) == stats.dropped
    expected = sum(1 for kind, _ in fed if kind in registered)
    assert handled >= expected  # random bytes may happen to decode, too
