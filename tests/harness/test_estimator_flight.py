"""The autopilot's navigation filter against the simulator's ground truth, in lockstep.

Five Typhoon H480s fly the same pattern side by side in one simulation, each with its own IMU
turn-on biases (the SDF's full sigmas, turn_on_bias_scale 1.0: accelerometer 0.196 m/s², gyro
0.0087 rad/s per axis) and its own GNSS receiver (u-blox NEO-M9N class, 1.5 m CEP50). Five bias
draws instead of one seed whose bias sits at EKF2_ABL_LIM: seed 8 draws accelerometer biases up
to 0.33 m/s² on some vehicles and under 0.12 m/s² on others.

Errors are measured in the frame that does not flatter the filter: horizontally the absolute
error (the estimate placed on the globe through its EKF origin, minus the truth), which contains
the GNSS error the filter cannot know; vertically the height above the take-off point (EKF2's
height is barometric, relative to where the origin was set).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu import geodesy
from autopilot_emu import quaternion as quat
from autopilot_emu.mavlink import messages
from autopilot_emu.modes import AutoSubMode, MainMode
from harness.sim.simulation import Simulation, SimulationConfig

SEED = 8
N_VEHICLES = 5
SAMPLE_EVERY_STEPS = 50
"""Error samples every 50 physics steps (0.1 s)."""
CONVERGED_S = 20.0
"""Errors are judged from here on (the filter has seen the turns that separate bias and tilt)."""

# Bounds: about 1.5 x the worst of the five vehicles (seed 8; the worst measured in brackets).
ATTITUDE_TILT_BOUND_DEG = 0.75
"""Roll and pitch error (0.51 deg)."""
ATTITUDE_YAW_BOUND_DEG = 1.7
"""Yaw error (1.12 deg)."""
VELOCITY_BOUND_M_S = 0.16
"""Norm of the velocity error (0.105 m/s)."""
HORIZONTAL_PER_EPH_BOUND = 2.9
"""Absolute horizontal error over the receiver's reported eph (1.92 in flight, 2.16 after the GNSS
outage; the filter follows a GNSS error of per-axis spread eph, whose radius exceeds 2.45 eph 5 %
of the time)."""
VERTICAL_BOUND_M = 0.23
"""Height error above the take-off point (0.15 m; barometric, 1 Pa noise)."""
ACCEL_BIAS_BOUND_M_S2 = 0.07
"""Accelerometer-bias state minus the simulated bias, any axis (0.048 m/s²)."""
GYRO_BIAS_BOUND_RAD_S = 0.0009
"""Gyro-bias state minus the simulated bias, any axis (0.0006 rad/s)."""
DEAD_RECKONING_BOUND_M = 3.5
"""Horizontal drift over 10 s without GNSS in a hover (2.32 m; 0.79-2.32 m over the five)."""
LEG_YAW_BOUND_DEG = 0.4
"""Estimated heading minus each commanded one, 4 s after it (0.24 deg; a 90 deg turn at
MPC_YAWRAUTO_MAX takes 2 s plus the yaw loop's lag)."""
LEG_ARRIVAL_BOUND_M = 0.5
"""Estimated position minus each leg's target, 10 s after it (0.32 m; a 20 m leg at
MPC_XY_CRUISE 5 m/s with the jerk-limited approach takes ~7 s)."""


class Errors:
    """Estimate-minus-truth samples of every vehicle: (time, vehicle, quantity)."""

    def __init__(self, sim: Simulation) -> None:
        self.sim = sim
        self.rows: list[np.ndarray] = []
        self.truth_down0_m = sim.world.truth.position_ned_m[:, 2].copy()
        self.legs: list[tuple[str, object, np.ndarray]] = []
        """Each commanded heading and goto with where every vehicle's estimate was at its end."""

    def origin_ned_m(self) -> np.ndarray:
        """Each vehicle's EKF origin in the world's NED frame (N, 2), m."""
        cfg = self.sim.world.config
        world = np.array([[cfg.origin_lat_deg, cfg.origin_lon_deg, cfg.origin_alt_amsl_m]])
        origin = self.sim.fleet.estimator.origin_lla
        return geodesy.geodetic_to_ned(origin, np.repeat(world, len(origin), axis=0))[:, :2]

    def sample(self) -> None:
        sim = self.sim
        est, truth = sim.fleet.estimator, sim.world.truth
        att = np.degrees(quat.wrap_pi(quat.euler_of(est.r) - truth.euler_ned_frd_rad))
        vel = est.velocity_ned_m_s - truth.velocity_ned_m_s
        horizontal = est.position_ned_m[:, :2] + self.origin_ned_m() - truth.position_ned_m[:, :2]
        vertical = est.position_ned_m[:, 2] - (truth.position_ned_m[:, 2] - self.truth_down0_m)
        eph = np.array([m.eph / 100.0 if m is not None else np.nan for m in sim.fleet.last_gps])
        time = np.full(len(eph), sim.time_s)
        self.rows.append(np.column_stack((time, att, vel, horizontal, vertical, eph)))

    def run(self, seconds: float) -> None:
        sim = self.sim
        steps = round(seconds * sim.world.config.physics_hz)
        for k in range(steps):
            sim.step()
            if k % SAMPLE_EVERY_STEPS == 0:
                self.sample()

    def since(self, t0_s: float) -> np.ndarray:
        """Samples at or after ``t0_s``: (samples, vehicles, 10) = att(3), vel(3), horizontal(2),
        vertical, eph."""
        rows = np.array(self.rows)
        return rows[rows[:, 0, 0] >= t0_s, :, 1:]


def true_imu_biases(sim: Simulation) -> tuple[np.ndarray, np.ndarray]:
    """The simulated IMUs' total biases (turn-on + Gauss-Markov), body FRD, (N, 3) each.

    Read from the world's private sensor state: one IMU for the fleet, or (multi-airframe
    worlds) one per airframe group; all vehicles here are of one airframe.
    """
    world = sim.world
    imu = world._groups[0].imu if hasattr(world, "_groups") else world._imu
    total = imu.noise.turn_on_bias + imu.noise.bias
    return total[:, 0], total[:, 1]


def geodetic_of(sim: Simulation, i: int, north_m: float, east_m: float) -> tuple[float, float]:
    """Latitude/longitude of a point of vehicle i's EKF frame."""
    fleet = sim.fleet
    lat0, lon0, _ = fleet.estimator.origin_lla[i]
    m_lat, m_lon = fleet.metres_per_degree[i]
    return lat0 + north_m / m_lat, lon0 + east_m / m_lon


@pytest.fixture(scope="module")
def flight():
    """All vehicles take off, turn through four headings (the yaw motion that separates
    accelerometer bias from tilt), fly two 20 m legs and come back."""
    cfg = SimulationConfig(n_vehicles=N_VEHICLES, mavlink=False, record_hz=0, seed=SEED)
    sim = Simulation(cfg)
    errors = Errors(sim)
    errors.run(3.0)
    vehicles = [sim.fleet.vehicle(i) for i in range(N_VEHICLES)]
    for vehicle in vehicles:
        assert vehicle.arm(False) == 0 and vehicle.takeoff(None) == 0
    errors.run(8.0)
    nan = math.nan
    est = sim.fleet.estimator
    for yaw_deg in (90, 180, 270, 0):
        for vehicle in vehicles:
            assert vehicle.reposition(nan, nan, nan, math.radians(yaw_deg), nan) == 0
        errors.run(4.0)
        errors.legs.append(("yaw", float(yaw_deg), np.degrees(quat.yaw_of(est.r))))
    for north, east in ((20.0, 0.0), (20.0, 20.0), (0.0, 0.0)):
        for i, vehicle in enumerate(vehicles):
            lat, lon = geodetic_of(sim, i, north, east)
            assert vehicle.reposition(lat, lon, nan, nan, nan) == 0
        errors.run(10.0)
        errors.legs.append(("goto", (north, east), est.position_ned_m[:, :2].copy()))
    errors.run(5.0)  # hover back over the start
    yield sim, errors
    sim.close()


def test_estimate_tracks_truth_within_stated_bounds(flight):
    """Attitude, velocity and position errors of every vehicle stay inside the stated bounds
    after convergence; the horizontal one relative to what the vehicle's receiver reports."""
    sim, errors = flight
    e = errors.since(CONVERGED_S)
    att, vel, hor, ver, eph = e[..., 0:3], e[..., 3:6], e[..., 6:8], e[..., 8], e[..., 9]
    assert np.abs(att[..., :2]).max() < ATTITUDE_TILT_BOUND_DEG
    assert np.abs(att[..., 2]).max() < ATTITUDE_YAW_BOUND_DEG
    assert np.linalg.norm(vel, axis=2).max() < VELOCITY_BOUND_M_S
    assert (np.linalg.norm(hor, axis=2) / eph).max() < HORIZONTAL_PER_EPH_BOUND
    assert np.abs(ver).max() < VERTICAL_BOUND_M
    assert all(c.in_air for c in sim.fleet.commanders)


def test_every_heading_and_leg_was_flown(flight):
    """The bounds above were tested under motion: each of the four headings was reached (the
    estimate within LEG_YAW_BOUND_DEG of it 4 s after the command) and each of the three 20 m
    legs ended at its target (the estimate within LEG_ARRIVAL_BOUND_M after 10 s)."""
    _, errors = flight
    kinds = [kind for kind, _, _ in errors.legs]
    assert kinds == ["yaw"] * 4 + ["goto"] * 3
    for kind, target, reached in errors.legs:
        if kind == "yaw":
            off = (reached - target + 180.0) % 360.0 - 180.0
            assert np.abs(off).max() < LEG_YAW_BOUND_DEG, (target, off)
        else:
            miss = np.linalg.norm(reached - np.asarray(target), axis=1)
            assert miss.max() < LEG_ARRIVAL_BOUND_M, (target, miss)


def test_imu_biases_converge_to_the_simulated_ones(flight):
    """Every vehicle's accelerometer- and gyro-bias states approach its simulator's biases."""
    sim, _ = flight
    accel_true, gyro_true = true_imu_biases(sim)
    est = sim.fleet.estimator
    assert np.abs(accel_true).max() > 0.3  # large biases among the draws: the test means something
    assert np.abs(est.accel_bias_m_s2 - accel_true).max() < ACCEL_BIAS_BOUND_M_S2
    assert np.abs(est.gyro_bias_rad_s - gyro_true).max() < GYRO_BIAS_BOUND_RAD_S


def test_ten_seconds_without_gnss_drift_bounded_and_recover(flight):
    """GNSS off for 10 s in a hover: bounded horizontal drift; back on, the estimate recovers."""
    sim, errors = flight
    fleet = sim.fleet
    unit = mavlink2.FAILURE_UNIT_SENSOR_GPS
    t_loss = sim.time_s
    before = errors.since(t_loss - 5.0)[..., 6:8].mean(axis=0)
    for i in range(N_VEHICLES):
        fleet.params[i].set("SYS_FAILURE_EN", 1)
        assert fleet.vehicle(i).inject_failure(unit, mavlink2.FAILURE_TYPE_OFF, 0) == 0
    errors.run(10.0)
    during = errors.since(t_loss)[..., 6:8]
    drift = np.linalg.norm(during - before, axis=2).max(axis=0)
    assert drift.max() < DEAD_RECKONING_BOUND_M
    # After EKF2_NOAID_TOUT (5 s) the position is no longer valid (PX4: failsafe).
    assert not fleet.estimator.position_ok.any()
    for i in range(N_VEHICLES):
        assert fleet.vehicle(i).inject_failure(unit, mavlink2.FAILURE_TYPE_OK, 0) == 0
    t_back = sim.time_s
    errors.run(5.0)
    after = errors.since(t_back + 2.0)
    ratio = (np.linalg.norm(after[..., 6:8], axis=2) / after[..., 9]).max(axis=0)
    assert ratio.max() < HORIZONTAL_PER_EPH_BOUND
    assert fleet.estimator.global_position_ok.all()
    for i in range(N_VEHICLES):
        snap = fleet.vehicle(i).telemetry()
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
