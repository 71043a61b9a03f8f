"""Router: by kind, direction and source; each destination's form; drops counted; the failsafe."""

from typing import Any

import pytest
from datagrams import MAX, h

from erc_codec import (
    Codec,
    Failsafe,
    FailsafeEvent,
    Outgoing,
    Route,
    Router,
    SchemaError,
)

FORMS: dict[str, Any] = {"base": "exact", "jetson": "strip", "logger": "pad", "board": "exact"}


def rover(codec: Codec, **kwargs: Any) -> Router:
    return Router(
        codec,
        FORMS,
        [
            Route(("base",), receiver="BS"),
            Route(("jetson",), sources=("board",)),
            Route(("board",), kinds=("drive_motor", "arm_ctrl")),
        ],
        **kwargs,
    )


def test_by_direction_source_and_kind_each_in_its_form(codec: Codec) -> None:
    router = rover(codec)
    diagnostics = codec.encode(codec.message_class("drive_diag")(), "strip")
    assert diagnostics == h("42")  # all-zero: "42 00" stripped
    assert router.route(diagnostics, "board", 0.0) == [Outgoing("jetson", h("42"))]
    stop = h("4a")  # a stop command, stripped by its sender
    assert router.route(stop, "base", 0.0) == [Outgoing("board", h("4a 00"))]
    # Hardware -> ROS2 from the board goes to the Jetson; ROS2 -> BS to the base station, exact.
    localization = codec.encode(codec.message_class("rover_localization")(x=1.0), "strip")
    out = router.route(localization, "jetson", 0.0)
    assert out == [Outgoing("base", codec.encode(codec.decode(localization).message, "exact"))]
    assert router.stats().forwarded == {"base": 1, "jetson": 1, "logger": 0, "board": 1}


def test_a_datagram_matching_several_routes_goes_once_to_each(codec: Codec) -> None:
    router = Router(
        codec,
        FORMS,
        [Route(("logger", "base")), Route(("base",), kinds=("drive_motor",))],
    )
    out = router.route(h("4a 00"), "anyone", 0.0)
    assert out == [Outgoing("logger", h("4a") + bytes(MAX - 1)), Outgoing("base", h("4a 00"))]


def test_the_timeout_metadata_travels_in_every_form(codec: Codec) -> None:
    router = Router(codec, FORMS, [Route(("base", "jetson", "logger"))])
    command = codec.encode(codec.message_class("drive_motor")(), "strip", timeout=300)
    exact = h("4a 00 f0 01 ac 02")
    assert command == exact  # the last field is the timeout: nothing to strip
    base, jetson, logger = router.route(command, "base", 0.0)
    assert base.data == jetson.data == exact
    assert logger.data == exact + bytes(MAX - len(exact))


@pytest.mark.parametrize(
    ("data", "reason"),
    [
        (h("b2 01 00"), "unknown_member"),  # member 22, from a newer schema
        (h("5a 02 08 81"), "corrupt"),
        (b"", "empty"),
    ],
)
def test_undecodable_datagrams_are_counted_and_go_raw_to_debug(
    codec: Codec, data: bytes, reason: str
) -> None:
    quiet = rover(codec)
    assert quiet.route(data, "board", 0.0) == []
    assert quiet.stats().dropped == {reason: 1}
    loud = rover(codec, debug="logger")
    assert loud.route(data, "board", 0.0) == [Outgoing("logger", data)]
    assert (loud.stats().dropped, loud.stats().debug) == ({reason: 1}, 1)


def test_unrouted_and_contract_breaking_datagrams_are_counted(codec: Codec) -> None:
    router = Router(codec, FORMS, [Route(("board",), kinds=("drive_motor",))], debug="logger")
    assert router.route(h("22 00"), "x", 0.0) == [Outgoing("logger", h("22 00"))]
    mode = codec.encode(codec.message_class("control_mode")(mode=1), "exact")
    undeclared = mode[:-1] + bytes([99])  # an enum value the schema does not declare
    assert codec.decode(undeclared)  # it decodes (proto3 enums are open)...
    everything = Router(codec, FORMS, [Route(("base",))])
    assert everything.route(undeclared, "x", 0.0) == []  # ...but no fixed-size receiver gets it
    assert router.stats().dropped == {"unrouted": 1}
    assert everything.stats().dropped == {"contract": 1}


def test_configuration_errors_name_what_is_wrong(codec: Codec) -> None:
    with pytest.raises(ValueError, match="no destination 'nowhere'"):
        Router(codec, FORMS, [Route(("nowhere",))])
    with pytest.raises(SchemaError, match="route to base: drive is not a payload kind"):
        Router(codec, FORMS, [Route(("base",), kinds=("drive",))])
    with pytest.raises(ValueError, match=r"no member .* Mars.*Hardware"):
        Router(codec, FORMS, [Route(("base",), receiver="Mars")])
    with pytest.raises(ValueError, match="form must be exact, strip or pad"):
        Router(codec, {"base": "stripped"}, [])  # type: ignore[dict-item]
    stop = codec.message_class("drive_motor")()
    with pytest.raises(ValueError, match="rate must be a positive"):
        Router(codec, FORMS, [], [Failsafe("drive_motor", stop, ("board",), rate=0)])
    with pytest.raises(ValueError, match="timeout must be a positive"):
        Router(codec, FORMS, [], [Failsafe("drive_motor", stop, ("board",), 10, timeout=-1)])


def brake(codec: Codec, timeout: float | None) -> tuple[Router, list[FailsafeEvent]]:
    events: list[FailsafeEvent] = []
    failsafe = Failsafe(
        "drive_motor", codec.message_class("drive_motor")(), ("board",), rate=10, timeout=timeout
    )
    router = rover(codec, failsafes=[failsafe], on_event=events.append)
    return router, events


def test_the_failsafe_repeats_while_commands_are_silent_and_stops_when_they_resume(
    codec: Codec,
) -> None:
    router, events = brake(codec, timeout=0.3)
    go = codec.encode(codec.message_class("drive_motor")(distance_to_go=2.0), "exact")
    assert router.poll(10.0) == []  # never arrived: nothing to miss yet
    for now in (0.0, 0.1, 0.2):
        router.route(go, "base", now)
        assert router.poll(now) == []
    assert router.poll(0.5) == []  # 0.3 s after the last one: not past it yet
    assert router.poll(0.51) == [Outgoing("board", h("4a 00"))]  # the zero drive command
    assert router.engaged() == {"drive_motor"}
    assert router.poll(0.55) == []
    assert router.poll(0.61) == [Outgoing("board", h("4a 00"))]  # every 1 / rate seconds
    assert router.poll(1.5) == [Outgoing("board", h("4a 00"))]  # late: one, not a burst
    assert router.poll(1.55) == []
    assert router.route(go, "base", 1.6) == [Outgoing("board", go)]
    assert router.poll(1.65) == []
    assert router.engaged() == frozenset()
    assert events == [
        FailsafeEvent("drive_motor", True, 0.51),
        FailsafeEvent("drive_motor", False, 1.6),
    ]
    stats = router.stats()
    assert (stats.engaged, stats.released) == ({"drive_motor": 1}, {"drive_motor": 1})
    assert stats.failsafe_sent["board"] == 3


def test_the_failsafe_follows_an_advertised_timeout_but_never_a_longer_one(codec: Codec) -> None:
    advertised, _ = brake(codec, timeout=None)
    go = codec.encode(codec.message_class("drive_motor")(distance_to_go=2.0), "exact", timeout=200)
    advertised.route(go, "base", 0.0)
    assert advertised.poll(0.2) == []
    assert advertised.poll(0.21) != []
    capped, _ = brake(codec, timeout=0.3)
    lax = codec.encode(codec.message_class("drive_motor")(), "exact", timeout=60_000)
    capped.route(lax, "base", 0.0)
    assert capped.poll(0.31) != []  # the sender asked for a minute: the configured 0.3 s wins
    unadvertised, _ = brake(codec, timeout=None)
    unadvertised.route(codec.encode(codec.message_class("drive_motor")()), "base", 0.0)
    assert unadvertised.poll(100.0) == []  # no timeout configured, none advertised: unwatched
