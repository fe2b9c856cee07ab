"""The navigation filter on synthetic sensor data: bias states, delayed GNSS, checks and gates.

A level vehicle (yaw 0) moves at a constant NED velocity; its ideal IMU, magnetometer, barometer
and GNSS readings are built here from that motion, plus the errors each test is about. Noise is
drawn from a seeded generator, so the runs are repeatable.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from autopilot_emu.estimator import GRAVITY_M_S2, FleetEstimator
from autopilot_emu.estimator_params import EstimatorParams

IMU_HZ, GPS_HZ, BARO_HZ = 250, 10, 50
ORIGIN = np.array([47.397742, 8.545594, 488.0])
DECL_RAD = np.radians(2.6)
B_NED = np.array([0.21 * np.cos(DECL_RAD), 0.21 * np.sin(DECL_RAD), 0.43])
"""Earth field (gauss) with EKF2_MAG_DECL's declination (2.6 deg east)."""


class Flight:
    """Synthetic sensors of n level vehicles flying ``velocity`` (m/s) from the origin."""

    def __init__(
        self,
        est: FleetEstimator,
        velocity: np.ndarray,
        accel_bias: np.ndarray | None = None,
        gyro_bias: np.ndarray | None = None,
        gps_delay_s: float = 0.0,
        seed: int = 1,
    ) -> None:
        self.est = est
        n = est.n
        self.velocity = np.broadcast_to(velocity, (n, 3)).astype(float)
        self.accel_bias = np.zeros((n, 3)) if accel_bias is None else accel_bias
        self.gyro_bias = np.zeros((n, 3)) if gyro_bias is None else gyro_bias
        self.gps_delay_s = gps_delay_s
        self.rng = np.random.default_rng(seed)
        self.tick = 0
        self.eph = np.full(n, 0.8)
        self.epv = np.full(n, 1.2)
        self.sats = np.full(n, 12.0)
        self.gps_offset = np.zeros((n, 3))
        self.mag_body = None
        """Override of the magnetometer reading (n, 3), gauss."""

    def truth(self, t: float) -> np.ndarray:
        return self.velocity * t

    def step(self) -> None:
        est, n, rng = self.est, self.est.n, self.rng
        self.tick += 1
        dt = 1.0 / IMU_HZ
        accel = np.tile([0.0, 0.0, -GRAVITY_M_S2], (n, 1)) + self.accel_bias
        accel += 0.05 * rng.standard_normal((n, 3))
        gyro = self.gyro_bias + 0.003 * rng.standard_normal((n, 3))
        mag = np.tile(B_NED, (n, 1)) if self.mag_body is None else self.mag_body
        mag = mag + 0.002 * rng.standard_normal((n, 3))
        if not est.attitude_ok.all():
            est.align_heading(accel, mag, ~est.attitude_ok)
        est.update_mag(mag, np.ones(n, dtype=bool))
        est.update_imu(accel, gyro, dt)
        t = self.tick * dt
        pos = self.truth(t)
        if self.tick % (IMU_HZ // BARO_HZ) == 0:
            baro = ORIGIN[2] - pos[:, 2] + 0.1 * rng.standard_normal(n)
            est.update_baro(baro, np.ones(n, dtype=bool))
        if self.tick % (IMU_HZ // GPS_HZ) == 0:
            taken = self.truth(t - self.gps_delay_s) + self.gps_offset
            ned = taken + 0.1 * rng.standard_normal((n, 3))
            vel = self.velocity + 0.05 * rng.standard_normal((n, 3))
            lla = np.tile(ORIGIN, (n, 1))
            lla[:, 2] -= ned[:, 2]
            est.update_gps(
                ned, vel, np.full(n, 3), lla, np.full(n, ORIGIN[2]), self.eph, self.epv, self.sats
            )

    def run(self, seconds: float) -> None:
        for _ in range(round(seconds * IMU_HZ)):
            self.step()

    def position_error(self) -> np.ndarray:
        return self.est.position_ned_m - self.truth(self.tick / IMU_HZ)


def estimator(n: int = 1, **changes: float) -> FleetEstimator:
    """A fleet filter with PX4 defaults, with some parameters replaced (same value for all)."""
    prm = EstimatorParams.defaults(n)
    prm = replace(prm, **{k: np.full(n, v) for k, v in changes.items()})
    return FleetEstimator(n, params=prm)


def test_accelerometer_and_gyro_biases_converge_to_the_true_ones():
    """Constant IMU biases (full Typhoon turn-on sigmas) are learned; the estimate stays level."""
    accel_bias = np.array([[0.0, 0.0, 0.25], [0.0, 0.0, -0.3]])
    gyro_bias = np.array([[0.008, -0.006, 0.01], [-0.009, 0.004, -0.008]])
    flight = Flight(estimator(2), np.zeros(3), accel_bias, gyro_bias)
    flight.run(90.0)
    est = flight.est
    assert np.abs(est.accel_bias_m_s2[:, 2] - accel_bias[:, 2]).max() < 0.03
    assert np.abs(est.gyro_bias_rad_s - gyro_bias).max() < 1.5e-3
    assert np.abs(est.velocity_ned_m_s).max() < 0.1
    assert np.abs(flight.position_error()).max() < 0.5


def test_delayed_gnss_is_compared_with_the_delayed_state():
    """GNSS taken 110 ms before it arrives: EKF2_GPS_DELAY = 110 ms removes the lag of v x delay."""
    velocity = np.array([5.0, 0.0, 0.0])
    errors = {}
    for delay_ms in (0.0, 110.0):
        flight = Flight(estimator(1, gps_delay_s=delay_ms * 1e-3), velocity, gps_delay_s=0.11)
        flight.run(20.0)
        north = []
        for _ in range(10 * IMU_HZ):
            flight.step()
            north.append(flight.position_error()[0, 0])
        errors[delay_ms] = float(np.mean(north))
    # Uncompensated the estimate lags by about v x 0.11 s = 0.55 m; compensated it does not.
    assert errors[0.0] < -0.3
    assert abs(errors[110.0]) < 0.1


def test_gnss_checks_need_satellites_and_accuracy():
    """EKF2_REQ_NSATS / EKF2_REQ_EPH / EKF2_REQ_EPV: a failing receiver sets no origin."""
    flight = Flight(estimator(3), np.zeros(3))
    flight.sats[0] = 5.0  # EKF2_REQ_NSATS = 6
    flight.eph[1] = 4.0  # EKF2_REQ_EPH = 3 m
    flight.epv[2] = 6.0  # EKF2_REQ_EPV = 5 m
    flight.run(3.0)
    assert not flight.est.origin_set.any()
    assert not flight.est.position_ok.any()
    flight.sats[:] = 12.0
    flight.eph[:] = 0.8
    flight.epv[:] = 1.2
    flight.run(3.0)
    assert flight.est.origin_set.all() and flight.est.position_ok.all()


def test_reported_accuracy_scales_the_gnss_noise():
    """A receiver reporting eph 2.5 m leaves a larger position variance than one reporting 0.3 m."""
    flight = Flight(estimator(2), np.zeros(3))
    flight.eph[:] = (0.3, 2.5)
    flight.run(10.0)
    var = flight.est.position_variance_m2[:, 0]
    assert var[1] > 3.0 * var[0]


def test_gnss_jump_is_gated_then_reset_after_the_timeout():
    """A 30 m jump fails EKF2_GPS_P_GATE (ratio > 1, GPS glitch); persisting 7 s, it is adopted."""
    flight = Flight(estimator(1), np.zeros(3))
    flight.run(10.0)
    assert flight.est.pos_horiz_ratio[0] < 1.0
    flight.gps_offset[0, 0] = 30.0
    flight.run(2.0)
    est = flight.est
    assert est.pos_horiz_ratio[0] > 1.0 and est.gps_glitch[0]
    assert abs(est.position_ned_m[0, 0]) < 1.0
    flight.run(7.0)
    assert abs(est.position_ned_m[0, 0] - 30.0) < 1.0
    assert est.pos_horiz_ratio[0] < 1.0 and not est.gps_glitch[0]


def test_wrong_magnetometer_fails_the_heading_gate():
    """A magnetometer reading 180 deg off in yaw: mag test ratio > 1 and a heading failure."""
    flight = Flight(estimator(2), np.zeros(3))
    flight.run(5.0)
    est = flight.est
    assert (est.mag_ratio < 1.0).all() and not est.heading_failure.any()
    wrong = np.tile(B_NED, (2, 1))
    wrong[0, :2] *= -1.0
    flight.mag_body = wrong
    flight.run(2.0)
    assert est.mag_ratio[0] > 1.0 and est.mag_ratio[1] < 1.0
    assert est.heading_failure.tolist() == [True, False]
    flight.mag_body = None
    flight.run(1.0)
    assert not est.heading_failure.any()


def test_vision_position_makes_a_local_position_without_gnss():
    """EKF2_EV_CTRL = 1 (horizontal position): no GNSS, yet a valid local (not global) position."""
    est = estimator(2, ev_ctrl=1)
    flight = Flight(est, np.zeros(3))
    flight.sats[:] = 0.0  # GNSS never passes its checks
    rng = np.random.default_rng(5)
    for tick in range(5 * IMU_HZ):
        flight.step()
        if tick % 8 == 0:  # ~30 Hz, vehicle 0 only
            pos = np.array([[2.0, -1.0, 0.0], [np.nan] * 3]) + 0.05 * rng.standard_normal((2, 3))
            est.update_vision(
                np.array([True, False]),
                pos,
                np.full((2, 3), 0.05**2),
                np.full(2, np.nan),
                np.full(2, np.inf),
                np.full((2, 3), np.nan),
                np.zeros((2, 3)),
            )
    assert est.position_ok.tolist() == [True, False]
    assert not est.global_position_ok.any() and not est.origin_set.any()
    assert np.abs(est.position_ned_m[0, :2] - [2.0, -1.0]).max() < 0.1


@pytest.mark.parametrize("n", [1, 4])
def test_fleet_members_do_not_interact(n):
    """A glitch on one vehicle's GNSS leaves the others' estimates untouched (batched filter)."""
    flights = [Flight(estimator(n), np.array([1.0, 0.5, 0.0]), seed=2) for _ in range(2)]
    flights[1].gps_offset[0, 1] = 3.0
    for f in flights:
        f.run(5.0)
    a, b = (f.est.position_ned_m for f in flights)
    assert np.array_equal(a[1:], b[1:])
    assert abs(a[0, 1] - b[0, 1]) > 0.5


def test_delayed_vision_is_compared_with_the_delayed_state():
    """Vision positions 100 ms old: their age plus EKF2_EV_DELAY selects the buffered state."""
    velocity = np.array([0.0, 4.0, 0.0])
    lags = {}
    for age_s in (0.0, 0.1):  # the age the fleet passes on from the sample's timestamp
        est = estimator(1, ev_ctrl=1)
        flight = Flight(est, velocity)
        flight.sats[:] = 0.0  # no GNSS: vision is the only horizontal aiding
        east = []
        for tick in range(15 * IMU_HZ):
            flight.step()
            if tick % 8 == 0:
                taken = flight.truth((flight.tick / IMU_HZ) - 0.1)
                est.update_vision(
                    np.ones(1, dtype=bool),
                    taken,
                    np.full((1, 3), 0.05**2),
                    np.full(1, np.nan),
                    np.full(1, np.inf),
                    np.full((1, 3), np.nan),
                    np.zeros((1, 3)),
                    age_s,
                )
            if tick > 5 * IMU_HZ:
                east.append(flight.position_error()[0, 1])
        lags[age_s] = float(np.mean(east))
    assert lags[0.0] < -0.25  # about v x 0.1 s = 0.4 m behind
    assert abs(lags[0.1]) < 0.05


def test_gnss_arriving_after_vision_keeps_the_local_frame():
    """A vehicle navigating on vision (at (2, -1) m) that gets GNSS keeps its local position; the
    origin is placed so that this position maps to the fix."""
    est = estimator(1, ev_ctrl=1)
    flight = Flight(est, np.zeros(3))
    flight.sats[:] = 0.0
    for tick in range(3 * IMU_HZ):
        flight.step()
        if tick % 8 == 0:
            est.update_vision(
                np.ones(1, dtype=bool),
                np.array([[2.0, -1.0, 0.0]]),
                np.full((1, 3), 0.05**2),
                np.full(1, np.nan),
                np.full(1, np.nan),
                np.full((1, 3), np.nan),
                np.full((1, 3), np.nan),
            )
    before = est.position_ned_m[0].copy()
    flight.sats[:] = 12.0
    while not est.origin_set[0]:
        flight.step()
    assert np.abs(est.position_ned_m[0] - before).max() < 0.05
    fix_north_m = (ORIGIN[0] - est.origin_lla[0, 0]) * 111_200.0
    fix_east_m = (ORIGIN[1] - est.origin_lla[0, 1]) * 111_200.0 * np.cos(np.radians(ORIGIN[0]))
    assert fix_north_m == pytest.approx(before[0], abs=0.05)
    assert fix_east_m == pytest.approx(before[1], abs=0.05)
