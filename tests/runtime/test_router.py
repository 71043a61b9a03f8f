"""Router: by kind, direction and source; each destination's form; drops counted; the failsafe."""

from typing import Any

import pytest
from datagrams import MAX, h

from erc_codec import Codec, SchemaError
from erc_codec.runtime import Failsafe, FailsafeEvent, Outgoing, Route, Router

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


def test_unknown_fields_beside_the_payload_travel_byte_for_byte_in_every_form(
    codec: Codec,
) -> None:
    """A newer sender's envelope field reaches a newer receiver through this relay: re-encoding
    the payload alone dropped it."""
    router = Router(codec, FORMS, [Route(("base", "jetson", "logger"))])
    # drive_motor (a stop), field 40 (length-delimited, PBEnvelope lacks it), the timeout
    newer = h("4a 00 c2 02 02 01 ff f0 01 ac 02")
    base, jetson, logger = router.route(newer, "board", 0.0)
    exact = h("4a 00 f0 01 ac 02 c2 02 02 01 ff")  # protobuf writes the fields it knows first
    assert base.data == jetson.data == exact
    assert logger.data == exact + bytes(MAX - len(exact))
    assert codec.decode(base.data).envelope_unknown_fields == codec.decode(newer).unknown_fields
    assert codec.decode(base.data).timeout == 300
    # and one that ends in zeros beside the payload is stripped as its own last field
    zero_ended = h("4a 00 a0 01 00")  # field 20 as the varint 0
    assert router.route(zero_ended, "board", 0.0)[1] == Outgoing("jetson", h("4a 00 a0 01"))
    assert router.stats().dropped == {}


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
    to_board = [Route(("board",), kinds=("drive_motor",))]
    for rate in (0, 1e-300, 0.009, 1001, 1e9, float("nan"), True):
        with pytest.raises(ValueError, match=r"rate must be a number of Hz from 0\.01 to 1000"):
            Router(codec, FORMS, to_board, [Failsafe("drive_motor", stop, ("board",), rate, 0.3)])
    for timeout in (-1, None, float("nan")):
        failsafe = Failsafe("drive_motor", stop, ("board",), 10, timeout)  # type: ignore[arg-type]
        with pytest.raises(ValueError, match="timeout must be a positive"):
            Router(codec, FORMS, to_board, [failsafe])
    for timeout in (1e-300, 0.0009, 3601, 1e308):
        failsafe = Failsafe("drive_motor", stop, ("board",), 10, timeout)
        with pytest.raises(ValueError, match=r"timeout must be from 0\.001 to 3600 seconds"):
            Router(codec, FORMS, to_board, [failsafe])
    twice = Failsafe("drive_motor", stop, ("board", "board"), 10, 0.3)
    with pytest.raises(ValueError, match="to names a destination twice"):
        Router(codec, FORMS, to_board, [twice])
    with pytest.raises(ValueError, match="failsafe drive_motor: to names no destination"):
        Router(codec, FORMS, to_board, [Failsafe("drive_motor", stop, (), 10, 0.3)])
    brake = Failsafe("drive_motor", stop, ("board",), 10, 0.3)
    with pytest.raises(ValueError, match="a second failsafe for drive_motor"):
        Router(codec, FORMS, to_board, [brake, brake._replace(rate=5)])
    with pytest.raises(ValueError, match="no route takes drive_motor to board: it could never"):
        Router(codec, FORMS, [Route(("base",), kinds=("drive_motor",))], [brake])
    from_ground = [Route(("board",), kinds=("drive_motor",), sources=("ground",))]
    with pytest.raises(ValueError, match="no route takes drive_motor to board from rover"):
        Router(codec, FORMS, from_ground, [brake._replace(sources=("rover",))])


def brake(codec: Codec, timeout: float) -> tuple[Router, list[FailsafeEvent]]:
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
    advertised, _ = brake(codec, timeout=0.3)
    go = codec.encode(codec.message_class("drive_motor")(distance_to_go=2.0), "exact", timeout=200)
    advertised.route(go, "base", 0.0)
    assert advertised.poll(0.2) == []
    assert advertised.poll(0.21) != []  # the sender asked for 0.2 s: stricter, so it holds
    capped, _ = brake(codec, timeout=0.3)
    lax = codec.encode(codec.message_class("drive_motor")(), "exact", timeout=60_000)
    capped.route(lax, "base", 0.0)
    assert capped.poll(0.31) != []  # the sender asked for a minute: the configured 0.3 s wins


def test_an_advertised_timeout_holds_for_one_gap_only(codec: Codec) -> None:
    """One datagram advertising 1 ms does not shorten the watch for the commands after it that
    advertise none: the brake would flap between every command."""
    router, events = brake(codec, timeout=0.3)
    Drive = codec.message_class("drive_motor")
    router.route(codec.encode(Drive(distance_to_go=1.0), "exact", timeout=1), "base", 0.0)
    assert router.poll(0.002) == [Outgoing("board", h("4a 00"))]  # the promised 1 ms passed
    plain = codec.encode(Drive(distance_to_go=1.0), "exact")
    for now in (0.1, 0.2, 0.3, 0.4):
        router.route(plain, "base", now)
        assert router.poll(now + 0.05) == []  # 0.3 s again, the configured timeout
    assert [event.engaged for event in events] == [True, False]


def test_routes_around_a_failsafes_sources_are_named(codec: Codec) -> None:
    """A route delivering the watched kind to the failsafe's destinations from senders its
    sources leave out: those senders' commands reach the board between the brake's datagrams."""
    Drive = codec.message_class("drive_motor")
    routes = [
        Route(("board",), kinds=("drive_motor",), sources=("ground",)),
        Route(("jetson",), kinds=("drive_motor",)),
        Route(("board",), sources=("ground", "test")),
        Route(("board", "jetson"), kinds=("drive_motor", "arm_ctrl")),
    ]
    watched = Failsafe("drive_motor", Drive(), ("board",), 10, 0.3, sources=("ground",))
    assert Router(codec, FORMS, routes, [watched]).bypassing("drive_motor") == [2, 3]
    anyone = watched._replace(sources=None)  # every sender counts: nothing goes around it
    assert Router(codec, FORMS, routes, [anyone]).bypassing("drive_motor") == []


def test_a_kind_that_never_arrives_engages_its_failsafe_a_timeout_after_the_start(
    codec: Codec,
) -> None:
    """A relay restarted while the base station is down brakes: its first poll is an arrival."""
    router, events = brake(codec, timeout=0.3)
    assert router.poll(10.0) == []  # the start
    assert router.poll(10.25) == []
    assert router.poll(10.31) == [Outgoing("board", h("4a 00"))]
    assert events == [FailsafeEvent("drive_motor", True, 10.31)]
    early, _ = brake(codec, timeout=0.3)  # a command before the first poll: the watch runs
    early.route(h("4a"), "base", 5.0)  # from it, not from the later first poll
    assert early.poll(5.31) == [Outgoing("board", h("4a 00"))]


def test_only_what_reaches_the_failsafes_destinations_releases_it(codec: Codec) -> None:
    """A command dropped (unrouted, contract), from a source the failsafe does not accept, or
    routed elsewhere only is not an arrival: the board got nothing, so the brake stays on."""
    Drive, Control = codec.message_class("drive_motor"), codec.message_class("control_mode")
    events: list[FailsafeEvent] = []
    router = Router(
        codec,
        FORMS,
        [
            Route(("board",), kinds=("drive_motor",), sources=("ground", "test")),
            Route(("jetson",), kinds=("drive_motor",)),
            Route(("base",), kinds=("control_mode",)),
        ],
        [
            Failsafe("drive_motor", Drive(), ("board",), 10, 0.3, sources=("ground",)),
            Failsafe("control_mode", Control(), ("base",), 10, 0.3),
        ],
        on_event=events.append,
    )
    go = codec.encode(Drive(distance_to_go=1.0), "exact")
    mode = codec.encode(Control(mode=1), "exact")
    undeclared = mode[:-1] + bytes([99])  # decodes, but breaks the fixed-size contract
    assert router.route(go, "ground", 0.0) == [Outgoing("board", go), Outgoing("jetson", go)]
    router.route(mode, "ground", 0.0)
    assert len(router.poll(0.31)) == 2
    assert router.engaged() == {"drive_motor", "control_mode"}
    assert router.route(go, "rover", 0.35) == [Outgoing("jetson", go)]  # not to the board
    assert router.route(go, "test", 0.36) == [Outgoing("board", go), Outgoing("jetson", go)]
    assert router.route(undeclared, "ground", 0.37) == []
    assert router.stats().dropped == {"contract": 1}
    assert router.engaged() == {"drive_motor", "control_mode"}  # neither released
    assert router.poll(0.42) == [Outgoing("board", h("4a 00")), Outgoing("base", h("82 01 00"))]
    router.route(go, "ground", 0.5)
    assert router.engaged() == {"control_mode"}
    assert [event.kind for event in events] == ["drive_motor", "control_mode", "drive_motor"]
    only = Router(
        codec,
        {"board": "exact"},
        [Route(("board",), kinds=("drive_motor",), sources=("ground",))],
        [Failsafe("drive_motor", Drive(), ("board",), rate=10, timeout=0.3)],
    )
    only.route(go, "ground", 0.0)
    assert only.poll(0.31) != []
    assert only.route(go, "rover", 0.35) == []  # unrouted
    assert only.engaged() == {"drive_motor"}


def test_each_form_is_the_codecs_own_for_every_kind(codec: Codec) -> None:
    """The router cuts strip and pad from the exact encoding (``in_form``): the same datagrams
    as ``encode``'s forms, for each member, empty and with its metadata."""
    router = Router(codec, FORMS, [Route(("base", "jetson", "logger"))])
    for kind in codec.kinds().values():
        for metadata in ({}, {"timeout": 300}):
            message = codec.message_class(kind)()
            out = router.route(codec.encode(message, "exact", **metadata), "x", 0.0)
            assert out == [
                Outgoing("base", codec.encode(message, "exact", **metadata)),
                Outgoing("jetson", codec.encode(message, "strip", **metadata)),
                Outgoing("logger", codec.encode(message, "pad", **metadata)),
            ], kind
