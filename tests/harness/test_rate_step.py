"""The closed loop answers a roll-rate step as a linear model of PX4's loop says it should.

Three vehicles of one airframe hover in a lockstep Simulation (no sockets); each is given an
offboard roll-rate step of 60 deg/s. The response is the simulator's true body rate, timed from
the inner-loop tick where the new rate setpoint took effect. The oracle is
``px4_roll_loop_model``: PX4's loop structure (gyro and D-term Butterworths, rate PID, the
allocator's normalisation, THR_MDL_FAC 0) on a rigid body linearised about the hover the vehicle
really flies, with the airframe's inertia, rotor positions and motor lags. Of the emulator's
code it uses only the allocation matrix (``normalised_mix``, itself checked against PX4's
normalisation worked by hand in ``tests/autopilot_emu/control/test_mixer.py``). Rise time
(10 % to 90 %) must agree within 15 %, and where the model
overshoots by 5 % or more (the x500: ~6 %) the overshoot too. The Typhoons' model overshoot is
2.5 % of the step, below the run-to-run spread their full IMU turn-on biases leave (0 to 3 %
over seeds), so theirs is held to the model's within 1.5 % of the step instead.

Measured (seed 3, mean of the three vehicles; ``pytest -s tests/harness/test_rate_step.py``
prints them): x500 rise 0.078 s against the model's 0.084 s (7 % short), overshoot 5.8 %
against 6.2 %; SDF Typhoon rise 0.071 s against 0.074 s, overshoot 1.7 % against 2.5 %;
calibrated Typhoon rise 0.112 s against 0.108 s, overshoot 2.9 % against 2.5 %.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from px4_roll_loop_model import RollLoop, roll_loop_of, roll_step_response, step_metrics

from autopilot_emu.control.mixer import RotorGeometry, normalised_mix
from autopilot_emu.modes import MainMode
from autopilot_emu.modes.offboard import LocalFrame, OffboardSetpoint
from harness.sim.simulation import Simulation, SimulationConfig

N_VEHICLES = 3
RATE_STEP_RAD_S = math.radians(60.0)
WINDOW_S = 0.25
RELATIVE_TOLERANCE = 0.15
"""The issue's bound: rise time (and a visible overshoot) within 15 % of the model's."""
SMALL_OVERSHOOT = 0.05
"""Below this model overshoot (fraction of the step) it is compared in absolute terms."""
ABSOLUTE_OVERSHOOT_TOLERANCE = 0.015


def _hover(frame: str) -> Simulation:
    sim = Simulation(
        SimulationConfig(n_vehicles=N_VEHICLES, frames=(frame,), mavlink=False, record_hz=0, seed=3)
    )
    sim.run_lockstep(3.0)
    for i in range(N_VEHICLES):
        v = sim.fleet.vehicle(i)
        assert v.arm(False) == 0 and v.takeoff(None) == 0
    sim.run_lockstep(8.0)
    return sim


def _model(sim: Simulation, hover_outputs: np.ndarray) -> RollLoop:
    """The linear loop of vehicle 0's airframe about the hover output the fleet flies."""
    params = sim.fleet.params[0]
    allocation = normalised_mix(RotorGeometry.from_params(params))
    return roll_loop_of(sim.world.airframe, params, allocation, float(hover_outputs.mean()))


def _rate_steps(sim: Simulation) -> list:
    """Per vehicle: StepMetrics of its true roll rate after the step took effect."""
    fleet = sim.fleet
    setpoint = OffboardSetpoint(
        body_rates_rad_s=np.array([RATE_STEP_RAD_S, 0.0, 0.0]),
        thrust=float(fleet.hover_thrust.mean()),
    )
    vehicles = [fleet.vehicle(i) for i in range(N_VEHICLES)]
    for v in vehicles:
        v.offboard_setpoint(setpoint, LocalFrame.LOCAL_NED)
        assert v.set_mode(MainMode.OFFBOARD, 0) == 0
    start = np.full(N_VEHICLES, np.nan)
    start_rate = np.zeros(N_VEHICLES)
    samples: list[list[tuple[float, float]]] = [[] for _ in range(N_VEHICLES)]
    while np.isnan(start).any() or sim.time_s - np.nanmin(start) < 2 * WINDOW_S:
        for v in vehicles:
            v.offboard_setpoint(setpoint, LocalFrame.LOCAL_NED)
        before = sim.world.truth.angular_velocity_body_frd_rad_s[:, 0].copy()
        sim.step()
        rate = sim.world.truth.angular_velocity_body_frd_rad_s[:, 0]
        took = np.isnan(start) & (fleet.inner_loop.state.rate_sp_rad_s[:, 0] == RATE_STEP_RAD_S)
        start[took] = sim.time_s
        start_rate[took] = before[took]
        for i in range(N_VEHICLES):
            if not np.isnan(start[i]) and sim.time_s > start[i]:
                samples[i].append((sim.time_s - start[i], float(rate[i])))
    metrics = []
    for i in range(N_VEHICLES):
        t, w = np.array(samples[i]).T
        keep = t <= WINDOW_S + 1e-9
        metrics.append(
            step_metrics(t[keep], w[keep], start_rate[i], RATE_STEP_RAD_S - start_rate[i])
        )
    return metrics


@pytest.mark.parametrize("frame", ["x500", "typhoon_h480", "typhoon_h480_yuneec"])
def test_a_roll_rate_step_matches_the_linear_model_of_px4s_loop(frame):
    sim = _hover(frame)
    try:
        outputs = []
        for _ in range(250):  # 0.5 s of hover: the operating point the model is linearised at
            sim.step()
            n_rotors = len(sim.world.airframe.rotors)
            outputs.append(sim.fleet.inner_loop.state.outputs[:, :n_rotors].copy())
        loop = _model(sim, np.array(outputs))
        t, _, w = roll_step_response(loop, 0.0, WINDOW_S, rate_step_rad_s=RATE_STEP_RAD_S)
        model = step_metrics(t, w, 0.0, RATE_STEP_RAD_S)
        flown = _rate_steps(sim)
    finally:
        sim.close()
    rise = float(np.mean([m.rise_time_s for m in flown]))
    overshoot = float(np.mean([m.overshoot for m in flown]))
    report = f"{frame}: model {model}, flown rise {rise:.4f} s overshoot {overshoot:.4f}"
    print(report)
    assert rise == pytest.approx(model.rise_time_s, rel=RELATIVE_TOLERANCE), report
    if model.overshoot >= SMALL_OVERSHOOT:
        assert overshoot == pytest.approx(model.overshoot, rel=RELATIVE_TOLERANCE), report
    else:
        assert abs(overshoot - model.overshoot) <= ABSOLUTE_OVERSHOOT_TOLERANCE, report
