"""A linear model of PX4's roll loop on a rigid body: the oracle of the attitude step test.

Written from PX4's documented loop structure, not from the emulator's code: mc_att_control's
P law (rate setpoint = MC_ROLL_P x 2 sin(error / 2), clamped to MC_ROLLRATE_MAX),
mc_rate_control's PID (P and I on the rate filtered by a 2nd-order Butterworth at
IMU_GYRO_CUTOFF, D on the derivative of that filtered rate through a 2nd-order Butterworth at
IMU_DGYRO_CUTOFF, torque clamped to ±1, integrator ±0.3), run at the IMU rate and held between
samples; the allocator turns a normalised roll torque c into rotor thrust changes, and the
plant is linearised about hover:

- rotor thrust T = k ω², ω ∝ output u (PX4's default THR_MDL_FAC 0 passes thrust commands
  straight to outputs), so about hover dT_r = 2 T_h du_r / u_h with T_h = m g / n;
- roll torque (FRD) -Σ y_r dT_r, with du_r = M_r c from PX4's normalised allocation;
- motor speed lags its command by first order, time constant up when speeding up and down when
  slowing down: in a roll step half the torque comes from rotors speeding up and half from rotors
  slowing down, so the torque is the sum of two lags, each carrying half;
- the body: I_xx dp/dt = torque, dφ/dt = p.

What it leaves out, on purpose: sensor noise, the estimator (it reads the true attitude and
rate), rotor drag, gyroscopic coupling, thrust loss with pack voltage. Those are what the full
simulation adds; the test's tolerance is what they may cost.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import signal

G_M_S2 = 9.80665


@dataclass(frozen=True)
class RollLoop:
    """Parameters of the loop (PX4 names in the docstrings; SI units)."""

    inertia_kg_m2: float
    """Roll moment of inertia about the centre of mass."""
    torque_per_command_n_m: float
    """Roll torque per unit normalised roll torque command, about hover (steady state)."""
    time_constant_up_s: float
    time_constant_down_s: float
    attitude_p: float
    """MC_ROLL_P, 1/s."""
    rate_max_rad_s: float
    """MC_ROLLRATE_MAX."""
    rate_p: float
    rate_i: float
    rate_d: float
    gyro_cutoff_hz: float
    """IMU_GYRO_CUTOFF."""
    dgyro_cutoff_hz: float
    """IMU_DGYRO_CUTOFF."""
    control_hz: float = 250.0
    plant_hz: float = 500.0


def roll_torque_per_command(
    mass_kg: float, rotor_y_m: np.ndarray, roll_mix: np.ndarray, hover_output: float
) -> float:
    """dτ/dc: rotor y positions (FRD, m) and the allocation's roll column, in output order."""
    hover_thrust_n = mass_kg * G_M_S2 / len(rotor_y_m)
    d_thrust_per_output = 2.0 * hover_thrust_n / hover_output
    return float(np.sum(-np.asarray(rotor_y_m) * d_thrust_per_output * np.asarray(roll_mix)))


def roll_loop_of(spec: Any, params: Any, allocation: np.ndarray, hover_output: float) -> RollLoop:
    """The loop of an airframe ``spec`` (sitl MultirotorSpec) flying PX4 parameters ``params``
    (a ParamStore), with the allocation matrix (M, 4) PX4 builds from its CA_ROTOR* parameters,
    linearised about ``hover_output``. MC_ROLLRATE_K scales P, I and D, as in PX4."""
    y = np.array([r.position_frd_m[1] for r in sorted(spec.rotors, key=lambda r: r.output)])
    k = float(params.get("MC_ROLLRATE_K"))
    return RollLoop(
        inertia_kg_m2=spec.inertia_diag_kg_m2[0],
        torque_per_command_n_m=roll_torque_per_command(
            spec.mass_kg, y, allocation[:, 0], hover_output
        ),
        time_constant_up_s=spec.motor.time_constant_up_s,
        time_constant_down_s=spec.motor.time_constant_down_s,
        attitude_p=float(params.get("MC_ROLL_P")),
        rate_max_rad_s=math.radians(float(params.get("MC_ROLLRATE_MAX"))),
        rate_p=k * float(params.get("MC_ROLLRATE_P")),
        rate_i=k * float(params.get("MC_ROLLRATE_I")),
        rate_d=k * float(params.get("MC_ROLLRATE_D")),
        gyro_cutoff_hz=float(params.get("IMU_GYRO_CUTOFF")),
        dgyro_cutoff_hz=float(params.get("IMU_DGYRO_CUTOFF")),
    )


def _lowpass(cutoff_hz: float, fs_hz: float) -> tuple[np.ndarray, np.ndarray]:
    if cutoff_hz <= 0.0 or cutoff_hz >= fs_hz / 2.0:
        return np.array([1.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])
    b, a = signal.butter(2, cutoff_hz, fs=fs_hz)
    return b, a


def roll_step_response(
    loop: RollLoop, step_rad: float, duration_s: float, rate_step_rad_s: float | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times (s), roll angles (rad) and roll rates (rad/s) after a step from level hover at rest:
    of the roll setpoint, or with ``rate_step_rad_s`` of the roll-rate setpoint (the attitude
    loop bypassed, as an offboard body-rate setpoint does)."""
    dt = 1.0 / loop.plant_hz
    every = round(loop.plant_hz / loop.control_hz)
    dt_c = every * dt
    bv, av = _lowpass(loop.gyro_cutoff_hz, loop.control_hz)
    ba, aa = _lowpass(loop.dgyro_cutoff_hz, loop.control_hz)
    zv, za = np.zeros(2), np.zeros(2)
    roll = rate = integral = command = 0.0
    torque_up = torque_down = 0.0
    prev_filtered = 0.0
    k_up = 1.0 - math.exp(-dt / loop.time_constant_up_s)
    k_down = 1.0 - math.exp(-dt / loop.time_constant_down_s)
    steps = round(duration_s * loop.plant_hz)
    times, rolls, rates = np.empty(steps), np.empty(steps), np.empty(steps)
    for k in range(steps):
        if k % every == 0:
            filtered, zv = signal.lfilter(bv, av, [rate], zi=zv)
            filtered = float(filtered[0])
            accel, za = signal.lfilter(ba, aa, [(filtered - prev_filtered) / dt_c], zi=za)
            prev_filtered = filtered
            rate_sp = loop.attitude_p * 2.0 * math.sin((step_rad - roll) / 2.0)
            if rate_step_rad_s is not None:
                rate_sp = rate_step_rad_s
            rate_sp = min(max(rate_sp, -loop.rate_max_rad_s), loop.rate_max_rad_s)
            error = rate_sp - filtered
            command = loop.rate_p * error + integral - loop.rate_d * float(accel[0])
            command = min(max(command, -1.0), 1.0)
            integral = min(max(integral + loop.rate_i * error * dt_c, -0.3), 0.3)
        target = 0.5 * loop.torque_per_command_n_m * command
        torque_up += k_up * (target - torque_up)
        torque_down += k_down * (target - torque_down)
        rate += (torque_up + torque_down) / loop.inertia_kg_m2 * dt
        roll += rate * dt
        times[k], rolls[k], rates[k] = (k + 1) * dt, roll, rate
    return times, rolls, rates


@dataclass(frozen=True)
class StepMetrics:
    """Rise time (10 % to 90 % of the step) and overshoot (fraction of the step)."""

    rise_time_s: float
    overshoot: float


def step_metrics(times: np.ndarray, values: np.ndarray, start: float, step: float) -> StepMetrics:
    """Metrics of a response ``values`` going from ``start`` to ``start + step``."""
    progress = (np.asarray(values) - start) / step
    t10 = float(times[np.argmax(progress >= 0.1)])
    t90 = float(times[np.argmax(progress >= 0.9)])
    return StepMetrics(t90 - t10, max(float(progress.max()) - 1.0, 0.0))
