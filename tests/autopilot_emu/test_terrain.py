"""Height above ground from the downward range finder: PX4 EKF2's terrain estimate."""

from __future__ import annotations

import math

import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.fleet import AutopilotFleet, FleetConfig
from autopilot_emu.params import ParamStore
from autopilot_emu.terrain import FleetTerrain, TerrainParams

LEVEL = np.eye(3)[None]


def _run(terrain, params, heights_d, ranges, valid=None, rotation=LEVEL, dt=0.05, var=0.01):
    """Feed one vehicle's readings at 20 Hz; return the HAGL estimate after each."""
    out = []
    for k, (d, rng) in enumerate(zip(heights_d, ranges, strict=True)):
        terrain.update(
            k * dt,
            np.array([True]),
            np.array([rng]),
            np.array([True if valid is None else valid[k]]),
            np.array([d]),
            np.array([var]),
            np.zeros((1, 3)),
            rotation,
            params,
        )
        out.append(terrain.terrain_d_m[0] - d)
    return np.array(out)


def test_hagl_tracks_a_hover_and_a_step_onto_a_box():
    """Hover 3 m over the ground, then over a 1 m box: HAGL follows the noisy range to ~cm."""
    rng = np.random.default_rng(0)
    params = TerrainParams.from_params([ParamStore()])
    terrain = FleetTerrain(1)
    d = np.full(200, -3.0)
    truth = np.where(np.arange(200) < 100, 3.0, 2.0)
    hagl = _run(terrain, params, d, truth + rng.normal(0.0, 0.02, 200))
    assert terrain.valid(199 * 0.05)[0]
    assert abs(hagl[90:100].mean() - 3.0) < 0.03
    assert abs(hagl[-10:].mean() - 2.0) < 0.03  # the step passes the gate or resets to it


def test_tilt_is_corrected_and_too_much_tilt_is_not_used():
    params = TerrainParams.from_params([ParamStore()])
    tilt = math.radians(30.0)
    roll = np.array(
        [[[1, 0, 0], [0, math.cos(tilt), -math.sin(tilt)], [0, math.sin(tilt), math.cos(tilt)]]]
    )
    terrain = FleetTerrain(1)
    hagl = _run(terrain, params, [-2.0] * 5, [2.0 / math.cos(tilt)] * 5, rotation=roll)
    assert hagl[-1] == np.float64(hagl[-1]) and abs(hagl[-1] - 2.0) < 1e-6
    steep = math.radians(50.0)
    roll = np.array(
        [[[1, 0, 0], [0, math.cos(steep), -math.sin(steep)], [0, math.sin(steep), math.cos(steep)]]]
    )
    terrain = FleetTerrain(1)
    _run(terrain, params, [-2.0] * 5, [2.0 / math.cos(steep)] * 5, rotation=roll)
    assert not terrain.initialised[0]


def test_invalid_readings_and_rng_ctrl_zero_leave_no_estimate():
    store = ParamStore()
    terrain = FleetTerrain(1)
    _run(terrain, TerrainParams.from_params([store]), [-5.0] * 5, [4.51] * 5, valid=[False] * 5)
    assert not terrain.valid(0.25)[0]
    store.set("EKF2_RNG_CTRL", 0)
    terrain = FleetTerrain(1)
    _run(terrain, TerrainParams.from_params([store]), [-2.0] * 5, [2.0] * 5)
    assert not terrain.valid(0.25)[0]


def test_an_outlier_is_gated():
    params = TerrainParams.from_params([ParamStore()])
    terrain = FleetTerrain(1)
    hagl = _run(terrain, params, [-2.0] * 21, [2.0] * 20 + [4.4])
    assert hagl[-1] == hagl[-2]
    assert terrain.test_ratio[0] > 1.0


def _distance_sensor(time_ms, distance_cm, sensor_id, orientation, quality=100):
    return mavlink2.MAVLink_distance_sensor_message(
        time_ms,
        2,
        450,
        distance_cm,
        1,
        sensor_id,
        orientation,
        1,
        0.26,
        0.26,
        [0, 0, 0, 0],
        quality,
    )


def test_fleet_keeps_the_latest_reading_per_sensor_and_reports_hagl():
    fleet = AutopilotFleet(FleetConfig(n_vehicles=2))
    for k in range(10):
        fleet.handle_distance_sensors(
            [
                [_distance_sensor(50 * k, 150 + k, 0, 0), _distance_sensor(50 * k, 300, 6, 25)],
                [],
            ]
        )
    readings = fleet.vehicle(0).telemetry().distance_sensors
    assert [(r.sensor_id, r.orientation) for r in readings] == [(0, 0), (6, 25)]
    assert readings[0].distance_m == 1.59 and readings[1].message().current_distance == 300
    assert fleet.vehicle(1).telemetry().distance_sensors == ()
    snapshot = fleet.vehicle(0).telemetry()
    estimated_d = float(fleet.estimator.position_ned_m[0, 2])
    assert snapshot.extra["bottom_clearance_m"] == np.float64(snapshot.extra["bottom_clearance_m"])
    assert abs(snapshot.extra["bottom_clearance_m"] - 3.0) < 0.05
    assert fleet.terrain.terrain_d_m[0] - estimated_d == snapshot.extra["bottom_clearance_m"]
    assert "bottom_clearance_m" not in fleet.vehicle(1).telemetry().extra
