"""Emulated motion capture: rate, latency, frame, noise and independence from other sensors."""

from __future__ import annotations

import numpy as np
import pytest
from sitl_test_helpers import make_world

from sitl import frames
from sitl.sensors.mocap import MocapParams


def _poll_for(world, seconds: float) -> list:
    """Poll now, then step ``seconds`` polling after every step; return (release time, sample)."""
    out = [(world.time_s, s) for s in world.poll_mocap()]
    for _ in range(round(seconds * world.config.physics_hz)):
        world.step()
        out += [(world.time_s, s) for s in world.poll_mocap()]
    return out


def test_rate_latency_and_frame():
    """100 Hz, released 10 ms after measurement; vehicle i's ENU (5 i, 0, h) is NED (0, 5 i, -h)."""
    world = make_world(n_vehicles=2, mocap_hz=100.0)
    released = _poll_for(world, 1.0)
    world.close()
    assert len(released) == 100  # measured at 0, 0.01, ..., 0.99 s
    latency = [t - s.time_s for t, s in released]
    assert latency == pytest.approx([0.010] * 100, abs=1e-9)
    assert [s.time_s for _, s in released[:3]] == pytest.approx([0.0, 0.01, 0.02])
    h = world.airframe.ground_clearance_m
    mean = np.mean([s.position_ned_m for _, s in released], axis=0)
    np.testing.assert_allclose(mean, [[0.0, 0.0, -h], [0.0, 5.0, -h]], atol=0.002)


def test_noise_has_the_configured_spread():
    """At rest facing north: position error std = 1 mm per axis, Euler error std = 5 mrad."""
    params = MocapParams(position_noise_sigma_m=0.001, attitude_noise_sigma_rad=0.005)
    world = make_world(n_vehicles=4, mocap_hz=250.0, mocap=params)
    released = _poll_for(world, 2.0)
    truth = world.truth
    world.close()
    pos = np.array([s.position_ned_m for _, s in released])
    err = pos - frames.enu_to_ned(truth.position_enu_m)
    assert err.std() == pytest.approx(0.001, rel=0.1)
    euler = frames.euler_from_quat_ned_frd(np.array([s.quaternion_wxyz for _, s in released]))
    assert euler.std(axis=(0, 1)) == pytest.approx([0.005] * 3, rel=0.1)
    assert np.abs(euler.mean(axis=(0, 1))).max() < 0.001


def _sensor_run(world) -> tuple[list, list, list]:
    """One second of step + poll_sensors + poll_mocap: (HIL_SENSOR xacc, HIL_GPS lat, mocap)."""
    acc, lat, mocap = [], [], []
    for _ in range(500):
        world.step()
        s, g = world.poll_sensors()
        mocap += world.poll_mocap()
        acc += [m.xacc for m in s or []]
        lat += [m.lat for m in g or []]
    world.close()
    return acc, lat, mocap


def test_off_by_default_and_without_effect_on_other_sensors():
    """Default: no samples. Switching mocap on does not change a single IMU or GPS value."""
    acc_a, lat_a, mocap_a = _sensor_run(make_world(seed=4))
    acc_b, lat_b, mocap_b = _sensor_run(make_world(seed=4, mocap_hz=100.0))
    assert mocap_a == [] and len(mocap_b) == 99
    assert acc_a == acc_b and lat_a == lat_b
    assert len(acc_a) == 250


def test_rate_must_divide_the_physics_rate():
    """A mocap rate that does not divide physics_hz fails at configuration."""
    with pytest.raises(ValueError, match="mocap_hz"):
        make_world(mocap_hz=300.0)
