"""Watchdog: timeouts fire once, recoveries follow, the clock is the caller's."""

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from erc_codec.runtime import Liveness, Watchdog


def recorder() -> tuple[Watchdog, list[tuple[str, str]]]:
    events: list[tuple[str, str]] = []
    dog = Watchdog(
        on_timeout=lambda kind: events.append(("timeout", kind)),
        on_recover=lambda kind: events.append(("recover", kind)),
    )
    return dog, events


def test_a_stopped_stream_times_out_once_and_recovers() -> None:
    dog, events = recorder()
    dog.watch("drive_motor", period=0.2)  # timeout: three periods, 0.6 s
    assert dog.state("drive_motor") is Liveness.INACTIVE
    for now in (0.0, 0.2, 0.4):
        dog.seen("drive_motor", now)
    assert dog.state("drive_motor") is Liveness.ACTIVE
    assert dog.poll(0.9) == []
    assert dog.poll(1.1) == ["drive_motor"]
    assert dog.poll(2.0) == []
    assert events == [("timeout", "drive_motor")]
    assert dog.state("drive_motor") is Liveness.INACTIVE
    dog.seen("drive_motor", 2.1)
    assert events[-1] == ("recover", "drive_motor")
    assert dog.state("drive_motor") is Liveness.ACTIVE


def test_last_seen_is_the_last_arrival_watched_or_not() -> None:
    dog, _ = recorder()
    dog.watch("drive_motor", period=0.2)
    assert dog.last_seen("drive_motor") is None
    for now in (5.0, 5.2, 5.4):
        dog.seen("drive_motor", now)
    dog.seen("gps_info", 7.5)
    assert dog.poll(9.0) == ["drive_motor"]
    assert (dog.last_seen("drive_motor"), dog.last_seen("gps_info")) == (5.4, 7.5)
    assert dog.last_seen("never") is None


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


HUGE = pytest.param(10**400, id="10**400")  # beyond every float: was an OverflowError
NOT_SECONDS = [math.nan, math.inf, -math.inf, -1.0, 0, 0.0, True, "1", HUGE]


@pytest.mark.parametrize("bad", NOT_SECONDS)
def test_periods_and_timeouts_are_positive_finite_seconds(bad: object) -> None:
    dog = Watchdog()
    expected = f"must be a positive, finite number of seconds, not {bad!r}"
    with pytest.raises(ValueError, match=rf"^gps_info: period {expected}$"):
        dog.watch("gps_info", period=bad)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=rf"^gps_info: timeout {expected}$"):
        dog.watch("gps_info", period=1.0, timeout=bad)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=rf"^timeout_periods {expected}$"):
        Watchdog(timeout_periods=bad)  # type: ignore[arg-type]
    assert dog.state("gps_info") is Liveness.UNCONFIGURED  # nothing was watched


def test_a_period_whose_default_timeout_overflows_is_refused() -> None:
    with pytest.raises(ValueError, match=r"period \* timeout_periods must be .*, not inf"):
        Watchdog().watch("gps_info", period=1e308)  # three periods: beyond every float


@pytest.mark.parametrize(
    "bad", [math.nan, math.inf, -math.inf, HUGE, pytest.param(-(10**400), id="-10**400"), True, "1"]
)
def test_a_clock_reading_that_is_not_finite_is_refused(bad: float) -> None:
    dog, events = recorder()
    dog.watch("gps_info", period=0.1)
    dog.seen("gps_info", 1.0)
    with pytest.raises(ValueError, match=rf"^now must be a .* in seconds, not {bad!r}$"):
        dog.seen("gps_info", bad)
    with pytest.raises(ValueError, match=r"^now must be a finite clock reading"):
        dog.poll(bad)
    with pytest.raises(ValueError, match=r"^now must be a finite clock reading"):
        dog.seen("imu_info", bad)  # unwatched: its rate would be NaN forever
    assert dog.poll(2.0) == ["gps_info"]  # the refused readings changed nothing: it still fires
    assert events == [("timeout", "gps_info")]
    assert dog.rate("imu_info") is None


CLOCK = st.one_of(
    st.floats(0, 5, allow_nan=False), st.sampled_from([math.nan, math.inf, -math.inf])
)


@given(st.lists(st.tuples(st.sampled_from(["seen", "poll"]), CLOCK), max_size=60))
def test_a_refused_clock_reading_changes_nothing(steps: list[tuple[str, float]]) -> None:
    """Fed the same readings, minus the ones that are not finite, a twin behaves the same."""
    dog, events = recorder()
    twin, twin_events = recorder()
    for each in (dog, twin):
        each.watch("gps_info", period=0.25, timeout=0.5)
    now = 0.0
    for action, value in steps:
        if not math.isfinite(value):
            with pytest.raises(ValueError, match="now must be a finite clock reading"):
                dog.seen("gps_info", value) if action == "seen" else dog.poll(value)
            continue
        now += value
        for each in (dog, twin):
            each.seen("gps_info", now) if action == "seen" else each.poll(now)
        assert dog.state("gps_info") is twin.state("gps_info")
    assert events == twin_events
    assert dog.rate("gps_info") == twin.rate("gps_info")
    dog.seen("gps_info", now)
    assert dog.poll(now + 0.6) == ["gps_info"]  # and it still fires


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


# -- timeouts the sender advertises ------------------------------------------------------------


def test_an_advertised_timeout_watches_a_kind_nobody_configured() -> None:
    timed_out: list[str] = []
    watchdog = Watchdog(on_timeout=timed_out.append)
    watchdog.seen("drive_motor", 0.0, timeout=0.3)
    assert watchdog.state("drive_motor") is Liveness.ACTIVE
    assert watchdog.timeout("drive_motor") == 0.3
    assert watchdog.expected("drive_motor") is None  # no period configured
    assert watchdog.poll(0.3) == []
    assert watchdog.poll(0.31) == ["drive_motor"]
    assert timed_out == ["drive_motor"]


@pytest.mark.parametrize("advertised", [None, 0, 0.0])
def test_no_advertised_timeout_leaves_a_kind_unwatched(advertised: float | None) -> None:
    watchdog = Watchdog()
    watchdog.seen("drive_diag", 0.0, timeout=advertised)
    assert watchdog.state("drive_diag") is Liveness.UNCONFIGURED
    assert watchdog.timeout("drive_diag") is None
    assert watchdog.poll(100.0) == []


def test_a_configured_timeout_wins_over_a_longer_advertised_one() -> None:
    watchdog = Watchdog()
    watchdog.watch("drive_motor", period=0.1, timeout=0.3)
    watchdog.seen("drive_motor", 0.0, timeout=60.0)  # a sender cannot loosen its brake
    assert watchdog.timeout("drive_motor") == 0.3
    assert watchdog.poll(0.31) == ["drive_motor"]
    watchdog.seen("drive_motor", 1.0, timeout=0.2)  # but it may tighten it
    assert watchdog.timeout("drive_motor") == 0.2
    assert watchdog.poll(1.21) == ["drive_motor"]
    watchdog.seen("drive_motor", 2.0, timeout=0)  # nor switch it off with 0
    assert watchdog.timeout("drive_motor") == 0.3
    watchdog.seen("drive_motor", 3.0, timeout=1.0)  # longer again: back to the configured one
    assert watchdog.timeout("drive_motor") == 0.3


@pytest.mark.parametrize("advertised", [None, 0])
def test_a_shortened_timeout_lasts_one_gap(advertised: float | None) -> None:
    """One datagram advertising 1 ms must not leave the brake flapping between later commands
    that advertise nothing: each arrival's promise replaces the last one's."""
    watchdog = Watchdog()
    watchdog.watch("drive_motor", period=0.1, timeout=0.3)
    watchdog.seen("drive_motor", 0.0, timeout=0.001)
    assert watchdog.poll(0.002) == ["drive_motor"]  # the promised gap passed
    watchdog.seen("drive_motor", 0.1, timeout=advertised)
    assert watchdog.timeout("drive_motor") == 0.3
    assert watchdog.poll(0.35) == []
    assert watchdog.poll(0.41) == ["drive_motor"]


def test_an_advertised_timeout_follows_the_sender() -> None:
    watchdog = Watchdog()
    watchdog.seen("arm_ctrl", 0.0, timeout=0.5)
    watchdog.seen("arm_ctrl", 0.1, timeout=2.0)  # nobody configured a ceiling: the latest counts
    assert watchdog.timeout("arm_ctrl") == 2.0
    assert watchdog.poll(2.05) == []
    assert watchdog.poll(2.11) == ["arm_ctrl"]
    watchdog.seen("arm_ctrl", 3.0, timeout=0.5)  # it recovers, watched with its new promise
    assert watchdog.state("arm_ctrl") is Liveness.ACTIVE
    watchdog.seen("arm_ctrl", 3.2)  # an arrival promising nothing ends the watch
    assert watchdog.state("arm_ctrl") is Liveness.UNCONFIGURED
    assert watchdog.timeout("arm_ctrl") is None
    assert watchdog.poll(100.0) == []


@pytest.mark.parametrize("advertised", [-1.0, math.nan, math.inf])
def test_a_bad_advertised_timeout_is_refused_and_changes_nothing(advertised: float) -> None:
    watchdog = Watchdog()
    with pytest.raises(ValueError, match="drive_motor: advertised timeout must be a positive"):
        watchdog.seen("drive_motor", 0.0, timeout=advertised)
    assert watchdog.state("drive_motor") is Liveness.UNCONFIGURED
    assert watchdog.rate("drive_motor") is None


def test_the_rate_falls_to_zero_once_a_kind_stops() -> None:
    """``rate`` (over the last 16 arrivals) stays at 10 Hz after traffic stopped; what listen
    shows, ``recent_rate``, falls to 0."""
    rates = Watchdog()
    for tick in range(50):  # 10 Hz for 5 s
        rates.seen("gps_info", 100.0 + tick / 10)
    assert rates.recent_rate("gps_info", 104.95) == pytest.approx(10.0, rel=0.06)
    assert rates.recent_rate("gps_info", 107.0) == pytest.approx(5.0, rel=0.1)  # half the window
    assert rates.recent_rate("gps_info", 110.0) == 0.0
    assert rates.last_seen("gps_info") == pytest.approx(104.9)
    assert rates.rate("gps_info") == pytest.approx(10.0)
    assert rates.recent_rate("never", 110.0) == 0.0


def test_a_burst_is_what_it_is_not_thousands_of_hertz() -> None:
    """100 datagrams in 7 ms showed as 14623 Hz."""
    rates = Watchdog()
    for i in range(100):
        rates.seen("imu_info", 50.0 + i * 0.00007)
    assert rates.recent_rate("imu_info", 50.01) == 100.0  # 100 arrivals, over at least a second
    assert rates.recent_rate("imu_info", 54.9) == pytest.approx(100 / 4.9)  # since the burst
    assert rates.recent_rate("imu_info", 55.1) == 0.0  # out of the 5 s window


def test_a_recent_rate_asked_at_a_moment_that_is_no_number_is_a_value_error() -> None:
    watchdog = Watchdog()
    watchdog.seen("gps_info", 1.0)
    with pytest.raises(ValueError, match="now"):
        watchdog.recent_rate("gps_info", float("nan"))
