"""Vehicles of one fleet filter are independent: the fleet's size changes no vehicle's estimate.

The kernels work on scratch arrays sized by the fleet; a scratch row indexed by vehicle but sized
by the 15 error states once corrupted vehicles 0 and 15 of fleets larger than 15 (magnetometer,
barometer, GNSS and fake-position fusion).
"""

from __future__ import annotations

import numpy as np
import pytest

from autopilot_emu.estimator import GRAVITY_M_S2, FleetEstimator


def fly(n: int, ticks: int = 1500) -> FleetEstimator:
    """Feed n vehicles the same IMU, magnetometer, barometer and (from 2 s) GNSS samples."""
    rng = np.random.default_rng(0)
    est = FleetEstimator(n)
    ones = np.ones((n, 1))
    lla = ones * np.array([[47.397742, 8.545594, 488.0]])
    for t in range(ticks):
        acc = ones * (rng.normal(0.0, 0.05, 3) + np.array([0.0, 0.0, -GRAVITY_M_S2]))
        gyro = ones * rng.normal(0.0, 0.01, 3)
        mag = ones * (np.array([0.21, 0.01, 0.42]) + rng.normal(0.0, 0.001, 3))
        palt = np.full(n, 488.0 + rng.normal(0.0, 0.1))
        has_mag = np.full(n, t % 2 == 0)
        has_baro = np.full(n, t % 5 == 0)
        if not est.attitude_ok.all():
            est.align_heading(acc, mag, has_mag & ~est.attitude_ok)
        est.update_sensors(acc, gyro, 0.004, mag, has_mag, palt, has_baro)
        if t % 5 == 0:
            est.update_acceleration(0.02)
        if t >= 500 and t % 25 == 0:
            est.update_gps(
                ones * rng.normal(0.0, 0.3, 3),
                ones * rng.normal(0.0, 0.05, 3),
                np.full(n, 3),
                lla,
                palt,
                np.full(n, 0.5),
                np.full(n, 0.8),
                np.full(n, 12),
            )
    return est


@pytest.mark.parametrize("n", [16, 40])
def test_every_vehicle_of_a_large_fleet_matches_a_fleet_of_one(n: int) -> None:
    """Same inputs, same estimate and covariance, whatever the fleet size."""
    one = fly(1)
    many = fly(n)
    assert one.attitude_ok.all() and one.P.diagonal(0, 1, 2).min() > 0.0
    np.testing.assert_allclose(many.P, np.broadcast_to(one.P, many.P.shape), rtol=0, atol=1e-12)
    np.testing.assert_allclose(
        many.position_ned_m, np.broadcast_to(one.position_ned_m, (n, 3)), rtol=0, atol=1e-12
    )
    np.testing.assert_allclose(many.q, np.broadcast_to(one.q, (n, 4)), rtol=0, atol=1e-12)
