"""Watchdog: timeouts fire once, recoveries follow, the clock is the caller's."""

import pytest
from hypothesis import given
from hypothesis import strategies as st

from erc_codec import Liveness, Watchdog


def recorder() -> tuple[Watchdog, list[tuple[str, str]]]:
    events: list[tuple[str, str]] = []
    dog = Watchdog(
        on_timeout=lambda kind: events.append(("timeout", kind)),
        on_recover=lambda kind: events.append(("recover", kind)),
    )
    return dog, events


def test_a_stopped_stream_times_out_once_and_recovers() -> None:
    dog, events = recorder()
    dog.watch("driving_motor_message", period=0.2)  # timeout: three periods, 0.6 s
    assert dog.state("driving_motor_message") is Liveness.INACTIVE
    for now in (0.0, 0.2, 0.4):
        dog.seen("driving_motor_message", now)
    assert dog.state("driving_motor_message") is Liveness.ACTIVE
    assert dog.poll(0.9) == []
    assert dog.poll(1.1) == ["driving_motor_message"]
    assert dog.poll(2.0) == []
    assert events == [("timeout", "driving_motor_message")]
    assert dog.state("driving_motor_message") is Liveness.INACTIVE
    dog.seen("driving_motor_message", 2.1)
    assert events[-1] == ("recover", "driving_motor_message")
    assert dog.state("driving_motor_message") is Liveness.ACTIVE


def test_nothing_fires_before_the_first_arrival() -> None:
    dog, events = recorder()
    dog.watch("gps_info", period=1.0, timeout=2.0)
    assert dog.poll(100.0) == []
    dog.seen("gps_info", 100.5)  # a first arrival is no recovery
    assert events == []


def test_measured_and_expected_rates() -> None:
    dog = Watchdog()
    dog.watch("imu_info", period=0.2)
    assert dog.rate("imu_info") is None
    for i in range(20):
        dog.seen("imu_info", i / 3.2)
    assert dog.rate("imu_info") == pytest.approx(3.2)
    assert dog.expected("imu_info") == pytest.approx(5.0)


def test_a_clock_stepping_back_delays_a_timeout_by_one_timeout_at_most() -> None:
    dog, events = recorder()
    dog.watch("gps_info", period=1.0, timeout=3.0)
    dog.seen("gps_info", 1000.0)
    assert dog.poll(5.0) == []  # the clock was reset
    assert dog.poll(7.9) == []
    assert dog.poll(8.1) == ["gps_info"]
    assert events == [("timeout", "gps_info")]


def test_unwatched_kinds() -> None:
    dog, events = recorder()
    dog.seen("gps_info", 1.0)
    assert dog.state("gps_info") is Liveness.UNCONFIGURED
    assert dog.rate("gps_info") is None
    assert dog.poll(10.0) == []
    assert events == []
    with pytest.raises(ValueError, match="positive"):
        dog.watch("gps_info", period=0)


EVENTS = st.lists(
    st.tuples(st.sampled_from(["seen", "poll"]), st.floats(0, 5, allow_nan=False)),
    max_size=60,
)


@given(EVENTS, st.booleans())
def test_timeouts_and_recoveries_alternate(steps: list[tuple[str, float]], monotonic: bool) -> None:
    dog, events = recorder()
    dog.watch("gps_info", period=0.25, timeout=0.5)
    now = last_seen = 0.0
    for action, value in steps:
        now = now + value if monotonic else value * 10
        before = len(events)
        if action == "seen":
            dog.seen("gps_info", now)
            last_seen = now
        else:
            fired = dog.poll(now)
            if monotonic:
                # Fires exactly when the stream was active and the timeout has passed.
                assert bool(fired) == (len(events) > before)
                if fired:
                    assert now - last_seen > 0.5
    kinds = [event for event, _ in events]
    assert kinds == ["timeout", "recover"] * (len(kinds) // 2) + ["timeout"] * (len(kinds) % 2)
    if kinds and kinds[-1] == "timeout":
        assert dog.state("gps_info") is Liveness.INACTIVE
