"""Closed loop on the simulated airframe: an attitude step settles without large overshoot.

The autopilot's attitude and rate controllers fly the PyBullet Typhoon H480 (in lockstep, no
sockets) on an offboard attitude setpoint, fed to the vehicle as its MAVLink endpoint would;
the response is read from the simulator's ground truth, not from the estimator.
"""

import numpy as np
import pytest

from autopilot_emu import quaternion as quat
from autopilot_emu.modes import AutoSubMode, MainMode
from autopilot_emu.modes.offboard import LocalFrame, OffboardSetpoint
from harness.sim.simulation import Simulation, SimulationConfig

STEP_DEG = 10.0
OVERSHOOT_BOUND = 0.20
"""Stated bound: the true roll may exceed the step by at most 20 % of the step."""


@pytest.fixture(scope="module")
def hovering():
    sim = Simulation(SimulationConfig(n_vehicles=1, mavlink=False, record_hz=0, seed=3))
    sim.run_lockstep(3.0)
    v = sim.fleet.vehicle(0)
    assert v.arm(False) == 0 and v.takeoff(None) == 0
    sim.run_lockstep(8.0)
    # The attitude the autopilot tracks is its estimate's: with the full IMU turn-on biases a
    # horizontal accelerometer bias and a tilt are indistinguishable until the vehicle yaws
    # (as for PX4's EKF2), so estimated and true roll differ by up to a few degrees. The step
    # is judged in the true roll, corrected by that offset measured in the hover before it.
    sim.hover_roll_deg = _true_roll_deg(sim)
    est_roll = float(np.degrees(quat.euler_of(sim.fleet.estimator.r)[0, 0]))
    sim.roll_offset_deg = sim.hover_roll_deg - est_roll
    yield sim
    sim.close()


def _true_roll_deg(sim):
    return float(np.degrees(sim.world.truth.euler_ned_frd_rad[0, 0]))


def test_roll_step_settles_within_overshoot_bound(hovering):
    sim = hovering
    fleet = sim.fleet
    yaw = float(quat.yaw_of(fleet.estimator.r)[0])
    q = quat.from_euler(np.array([[np.radians(STEP_DEG), 0.0, yaw]]))[0]
    hover = float(fleet.hover_thrust[0])  # learned by the hover-thrust estimator
    setpoint = OffboardSetpoint(attitude_wxyz=q, thrust=hover / np.cos(np.radians(STEP_DEG)))
    vehicle = fleet.vehicle(0)
    vehicle.offboard_setpoint(setpoint, LocalFrame.LOCAL_NED)
    assert vehicle.set_mode(MainMode.OFFBOARD, 0) == 0
    rolls, times = [], []
    t0 = sim.time_s
    while sim.time_s - t0 < 1.0:
        vehicle.offboard_setpoint(setpoint, LocalFrame.LOCAL_NED)
        sim.step()
        rolls.append(_true_roll_deg(sim))
        times.append(sim.time_s - t0)
    assert vehicle.set_mode(MainMode.AUTO, AutoSubMode.LOITER) == 0
    rolls, times = np.array(rolls), np.array(times)
    rolls -= sim.roll_offset_deg
    assert rolls.max() <= STEP_DEG * (1 + OVERSHOOT_BOUND)
    settled = rolls[times >= 0.5]
    assert np.all(np.abs(settled - STEP_DEG) < 1.5), settled.min()
    # Rise: it actually got there quickly (90 % of the way within 0.4 s).
    start = rolls[0]
    assert rolls[times <= 0.4].max() - start >= 0.9 * (STEP_DEG - start)


def test_releasing_the_target_returns_to_level_hover(hovering):
    sim = hovering
    sim.run_lockstep(4.0)
    assert abs(_true_roll_deg(sim) - sim.hover_roll_deg) < 3.0
    assert sim.fleet.commanders[0].in_air
