"""StreamScheduler: simulation-time intervals, SET_MESSAGE_INTERVAL semantics."""

from __future__ import annotations

import pytest

from autopilot_emu.mavlink.streams import (
    MAX_STREAM_RATE_HZ,
    MIN_INTERVAL_US,
    PROFILES,
    StreamProfile,
    StreamScheduler,
    StreamSpec,
    profile_streams,
    rate_to_interval_us,
)

SPECS = (StreamSpec("A", 1, 10.0), StreamSpec("B", 2, 1.0), StreamSpec("C", 3, 0.0))


def _names(specs):
    return [s.name for s in specs]


def test_everything_enabled_is_due_at_start_then_at_its_rate():
    scheduler = StreamScheduler(SPECS)
    assert _names(scheduler.pop_due(0)) == ["A", "B"]
    assert scheduler.next_due_us == 100_000
    assert scheduler.pop_due(99_999) == []
    assert _names(scheduler.pop_due(100_000)) == ["A"]
    counts = {"A": 0, "B": 0}
    for now_us in range(101_000, 10_000_001, 1000):
        for spec in scheduler.pop_due(now_us):
            counts[spec.name] += 1
    assert counts == {"A": 99, "B": 10}


def test_a_late_poll_does_not_burst():
    scheduler = StreamScheduler(SPECS)
    scheduler.pop_due(0)
    assert _names(scheduler.pop_due(1_000_000)) == ["A", "B"]
    assert _names(scheduler.pop_due(1_000_000)) == []
    assert scheduler.next_due_us == 1_100_000


def test_set_interval_semantics():
    scheduler = StreamScheduler(SPECS)
    scheduler.pop_due(0)
    assert scheduler.set_interval(1, 500_000, 0)
    assert scheduler.interval_us(1) == 500_000
    assert scheduler.set_interval(1, -1, 0)
    assert scheduler.interval_us(1) == -1
    assert scheduler.set_interval(1, 0, 0)
    assert scheduler.interval_us(1) == 100_000
    assert scheduler.set_interval(3, 250_000, 0)  # off by default, switched on
    assert _names(scheduler.pop_due(250_000)) == ["A", "C"]
    assert not scheduler.set_interval(99, 1000, 0)
    assert not scheduler.set_interval(1, -2, 0)
    assert not scheduler.knows(99)


def test_rate_overrides_and_validation():
    scheduler = StreamScheduler(SPECS, {"A": 0.0, "C": 2.0})
    assert _names(scheduler.pop_due(0)) == ["B", "C"]
    with pytest.raises(ValueError, match="D"):
        StreamScheduler(SPECS, {"D": 1.0})


def test_restart_makes_every_enabled_stream_due():
    scheduler = StreamScheduler(SPECS)
    scheduler.pop_due(5_000_000)
    scheduler.restart(0)
    assert _names(scheduler.pop_due(0)) == ["A", "B"]


def test_rate_to_interval():
    assert rate_to_interval_us(20.0) == 50_000
    assert rate_to_interval_us(0.0) == -1
    assert rate_to_interval_us(-3.0) == -1


@pytest.mark.parametrize("profile", list(StreamProfile))
def test_every_profile_starts_with_heartbeat_at_1_hz_and_names_each_message_once(profile):
    specs = profile_streams(profile, unlimited_rate_hz=10.0)
    assert (specs[0].name, specs[0].default_rate_hz) == ("HEARTBEAT", 1.0)
    assert len({s.msg_id for s in specs}) == len(specs)


def test_unlimited_rate_streams_run_at_the_rate_of_their_source():
    """PX4's onboard GPS_RAW_INT goes out on every fix: here at the GPS rate asked for."""
    specs = {s.name: s for s in profile_streams(StreamProfile.ONBOARD, unlimited_rate_hz=8.0)}
    assert specs["GPS_RAW_INT"].default_rate_hz == 8.0
    normal = {s.name: s for s in profile_streams(StreamProfile.NORMAL, unlimited_rate_hz=8.0)}
    assert normal["GPS_RAW_INT"].default_rate_hz == PROFILES[StreamProfile.NORMAL]["GPS_RAW_INT"]


def test_messages_outside_a_profile_are_streamable_but_off():
    """PX4 can stream any message on any link: HIGHRES_IMU is off on the GCS link by default."""
    specs = {s.name: s for s in profile_streams(StreamProfile.NORMAL, unlimited_rate_hz=10.0)}
    assert specs["HIGHRES_IMU"].default_rate_hz == 0.0


@pytest.mark.parametrize("requested_us", [1, 5_000, MIN_INTERVAL_US - 1])
def test_requested_interval_is_clamped_to_the_max_stream_rate(requested_us):
    """A request for 1 us (or anything faster than MAX_STREAM_RATE_HZ) gets the fastest rate."""
    scheduler = StreamScheduler(SPECS)
    scheduler.pop_due(0)
    assert scheduler.set_interval(1, requested_us, 0)
    assert scheduler.interval_us(1) == MIN_INTERVAL_US
    sent = sum(
        spec.name == "A"
        for now_us in range(1000, 1_000_001, 1000)
        for spec in scheduler.pop_due(now_us)
    )
    assert sent == MAX_STREAM_RATE_HZ  # one simulated second


def test_max_stream_rate_is_within_the_default_poll_rate():
    """The cap is PX4's fastest onboard stream and the endpoint poll can serve it."""
    from harness.sim.simulation import SimulationConfig

    assert SimulationConfig().mavlink_poll_hz >= MAX_STREAM_RATE_HZ
    for profile in StreamProfile:
        assert max(PROFILES[profile].values()) <= MAX_STREAM_RATE_HZ


def test_rate_mult_scales_every_stream_but_heartbeat():
    """PX4's rate multiplier: 0.5 halves every rate but HEARTBEAT's; intervals report as set."""
    specs = (StreamSpec("HEARTBEAT", 0, 1.0), StreamSpec("ATTITUDE", 30, 10.0))
    scheduler = StreamScheduler(specs)
    scheduler.pop_due(0)
    scheduler.set_rate_mult(0.5, 0)
    due = []
    for t_us in range(0, 10_000_001, 10_000):
        due += _names(scheduler.pop_due(t_us))
    assert due.count("HEARTBEAT") == 10  # 1 Hz, unscaled
    assert due.count("ATTITUDE") == 50  # 10 Hz x 0.5
    assert scheduler.interval_us(30) == 100_000  # MESSAGE_INTERVAL reports the set interval
    assert scheduler.rate_mult == 0.5
    scheduler.set_rate_mult(7.0, 0)
    assert scheduler.rate_mult == 1.0  # never above 1
    scheduler.set_rate_mult(0.0, 0)
    assert scheduler.rate_mult > 0.0  # never stops a stream


def test_bytes_per_s_splits_constant_and_scaled_streams():
    specs = (StreamSpec("HEARTBEAT", 0, 1.0), StreamSpec("ATTITUDE", 30, 10.0))
    scheduler = StreamScheduler(specs)
    assert scheduler.bytes_per_s({0: 21.0, 30: 40.0}) == pytest.approx((21.0, 400.0))
