"""The fleet's navigation-rate control step as one compiled call: trajectory -> position control.

What :meth:`autopilot_emu.control.nav.NavLoop.step` runs after the commanders: restart the
idle vehicles' controllers, smooth the auto-mode targets with the jerk-limited trajectory, run
the position controller, and let offboard attitude / thrust setpoints replace its output. Built
from the row functions of :mod:`trajectory_kernel` and :mod:`position_kernel`.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from autopilot_emu.control.position_kernel import position_row
from autopilot_emu.control.trajectory_kernel import trajectory_row
from autopilot_emu.nan_scalar import fmax, fmin


@numba.njit(cache=True, error_model="numpy")
def nav_kernel(
    # commander setpoint (N, 3) / (N,)
    sp_pos: np.ndarray, sp_vel: np.ndarray, sp_yaw: np.ndarray, sp_max_xy: np.ndarray,
    sp_max_up: np.ndarray, sp_max_down: np.ndarray, sp_acc_ff: np.ndarray,
    sp_smoothed: np.ndarray,
    # trajectory limits (8, N) and state
    limits: np.ndarray, traj_pos: np.ndarray, traj_vel: np.ndarray, traj_acc: np.ndarray,
    smooth_request: np.ndarray, smoothing: np.ndarray,
    # position gains (4, N, 3) and (3, N), hover thrust, controller states
    gains_axes: np.ndarray, gains_vehicle: np.ndarray, hover: np.ndarray,
    vel_int: np.ndarray, vel_sp: np.ndarray, prev_vel: np.ndarray, rate_integral: np.ndarray,
    # vehicle
    position: np.ndarray, velocity: np.ndarray, dt_s: float, active: np.ndarray,
    # offboard overrides
    att_target_q: np.ndarray, att_target_thrust: np.ndarray,
    # outputs
    q_sp: np.ndarray, thrust: np.ndarray, overridden: np.ndarray,
) -> None:  # fmt: skip
    """One navigation step of every vehicle (see the module docstring).

    Auto-mode vehicles (``smooth_request`` and active) track the trajectory's position (on the
    axes the commander gives one), velocity and acceleration with the controller's own speed
    limits (``speed_*``); a vehicle that just started smoothing restarts the trajectory at its
    own position and velocity. Writes ``q_sp``, ``thrust`` (0 when inactive; offboard thrust
    clipped to 0..1) and ``overridden`` (the offboard attitude / rate setpoints apply).

    ``limits`` rows: speed xy, up, down (the controller's own), acceleration xy, up, down,
    jerk, MPC_XY_ERR_MAX. ``gains_axes``: MPC_*_P, MPC_*_VEL_P_ACC, _I_ACC, _D_ACC per axis;
    ``gains_vehicle``: MPC_TILTMAX_AIR (rad), its cosine, MPC_ACC_HOR.
    """
    n = position.shape[0]
    speed_xy, speed_up, speed_down = limits[0], limits[1], limits[2]
    acc_xy, acc_up, acc_down, jerk, error_max = (
        limits[3],
        limits[4],
        limits[5],
        limits[6],
        limits[7],
    )
    pos_p, vel_p, vel_i, vel_d = gains_axes[0], gains_axes[1], gains_axes[2], gains_axes[3]
    tilt_max_rad, cos_tilt_max, acc_hor_max = gains_vehicle[0], gains_vehicle[1], gains_vehicle[2]
    # What the position controller tracks.
    c_pos, c_vel, c_acc_ff = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
    c_max_xy, c_max_up, c_max_down = np.empty(n), np.empty(n), np.empty(n)
    c_smoothed = np.empty(n, dtype=np.bool_)
    any_smooth = False
    for i in range(n):
        if not active[i]:  # idle: controllers restart from the vehicle's state
            for a in range(3):
                vel_int[i, a] = 0.0
                vel_sp[i, a] = velocity[i, a]
                rate_integral[i, a] = 0.0
        smooth = smooth_request[i] and active[i]
        if smooth and not smoothing[i]:
            for a in range(3):
                traj_pos[i, a] = position[i, a]
                traj_vel[i, a] = velocity[i, a]
                traj_acc[i, a] = 0.0
        smoothing[i] = smooth
        any_smooth = any_smooth or smooth
    for i in range(n):
        smooth = smoothing[i] and any_smooth
        if any_smooth:
            trajectory_row(
                i, sp_pos, sp_vel, sp_max_xy, sp_max_up, sp_max_down, acc_xy, acc_up, acc_down,
                jerk, error_max, position, dt_s, traj_pos, traj_vel, traj_acc,
            )  # fmt: skip
        for a in range(3):
            p = sp_pos[i, a]
            c_pos[i, a] = traj_pos[i, a] if (smooth and math.isfinite(p)) else p
            c_vel[i, a] = traj_vel[i, a] if smooth else sp_vel[i, a]
            c_acc_ff[i, a] = traj_acc[i, a] if smooth else sp_acc_ff[i, a]
        c_max_xy[i] = speed_xy[i] if smooth else sp_max_xy[i]
        c_max_up[i] = speed_up[i] if smooth else sp_max_up[i]
        c_max_down[i] = speed_down[i] if smooth else sp_max_down[i]
        c_smoothed[i] = smooth if any_smooth else sp_smoothed[i]
        position_row(
            i, c_pos, c_vel, sp_yaw, c_max_xy, c_max_up, c_max_down, c_acc_ff, c_smoothed,
            pos_p, vel_p, vel_i, vel_d, hover, tilt_max_rad, cos_tilt_max, acc_hor_max,
            position, velocity, dt_s, active, vel_int, vel_sp, prev_vel, q_sp, thrust,
        )  # fmt: skip
        if not active[i]:
            thrust[i] = 0.0
        # Offboard attitude / rate setpoints replace the position controller's output. Not
        # flying the position loop, it restarts from the vehicle's state afterwards, as PX4
        # initialises its position controller when a mode starts using it.
        override = active[i] and math.isfinite(att_target_thrust[i])
        overridden[i] = override
        if override:
            for a in range(3):
                vel_int[i, a] = 0.0
                vel_sp[i, a] = velocity[i, a]
            if math.isfinite(att_target_q[i, 0]):
                for a in range(4):
                    q_sp[i, a] = att_target_q[i, a]
            thrust[i] = fmin(fmax(att_target_thrust[i], 0.0), 1.0)
