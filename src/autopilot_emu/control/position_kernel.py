"""Compiled position -> velocity -> acceleration -> attitude and thrust control, one row each.

Follows the structure of PX4's multicopter position controller (mc_pos_control): a P loop on
position produces a velocity setpoint (plus feed-forward), limited per axis and slew-limited by
MPC_ACC_HOR; a PID loop on velocity produces an acceleration setpoint; the acceleration is turned
into a body-z direction (tilt-limited by MPC_TILTMAX_AIR) and a collective thrust scaled by the
hover thrust (the hover-thrust estimate; MPC_THR_HOVER until it is valid). The attitude setpoint
combines that body-z with the yaw setpoint.

Compiled into the navigation loop's kernel (:mod:`autopilot_emu.control.nav_kernel`). NaN
handling is numpy's: NaN propagates through ``np.maximum`` / ``np.minimum``, a NaN position axis
is velocity-controlled, an axis with neither position nor velocity is acceleration-controlled
(its velocity setpoint follows the vehicle).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from autopilot_emu.nan_scalar import clamp, fmax, fmin

GRAVITY_M_S2 = 9.80665
"""Same value as ``autopilot_emu.estimator.GRAVITY_M_S2`` (kept here: kernels take constants)."""
ACC_Z_MAX = 0.8 * GRAVITY_M_S2
"""Vertical acceleration demand limit, m/s²."""
INT_MAX_XY, INT_MAX_Z = GRAVITY_M_S2, 4.0
"""Velocity-integrator limits, horizontal and vertical, m/s². Horizontally PX4 has no fixed cap
(its anti-windup is the tilt limit); one g is as far as MPC_TILTMAX_AIR = 45 deg can go."""


@numba.njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def position_row(
    i: int,
    sp_pos: np.ndarray,
    sp_vel: np.ndarray,
    sp_yaw: np.ndarray,
    sp_max_xy: np.ndarray,
    sp_max_up: np.ndarray,
    sp_max_down: np.ndarray,
    sp_acc_ff: np.ndarray,
    smoothed: np.ndarray,
    pos_p: np.ndarray,
    vel_p: np.ndarray,
    vel_i: np.ndarray,
    vel_d: np.ndarray,
    hover: np.ndarray,
    tilt_max_rad: np.ndarray,
    cos_tilt_max: np.ndarray,
    acc_hor_max: np.ndarray,
    position: np.ndarray,
    velocity: np.ndarray,
    dt_s: float,
    active: np.ndarray,
    vel_int: np.ndarray,
    vel_sp: np.ndarray,
    prev_vel: np.ndarray,
    q_out: np.ndarray,
    thrust_out: np.ndarray,
) -> None:
    """Attitude setpoint ``q_out[i]`` and thrust ``thrust_out[i]`` (0.05..0.95) of vehicle i.

    Updates the vehicle's velocity setpoint, velocity integrator and previous velocity.
    """
    g = GRAVITY_M_S2
    err = np.empty(3)
    has_pos = np.empty(3, dtype=np.bool_)
    has_vel = np.empty(3, dtype=np.bool_)
    vel_cmd = np.empty(3)
    for a in range(3):
        e = sp_pos[i, a] - position[i, a]
        has_pos[a] = math.isfinite(e)
        err[a] = e if has_pos[a] else 0.0
        vf = sp_vel[i, a]
        has_vel[a] = math.isfinite(vf) or has_pos[a]
        if not has_vel[a]:
            vf = 0.0
        vel_cmd[a] = vf + pos_p[i, a] * err[a]
    # Per-axis limits: horizontal norm, vertical up/down. Setpoints that do not come from the
    # trajectory are also capped at the speed from which the vehicle can still stop at the
    # target with MPC_ACC_HOR, and slew-limited by it.
    raw = not smoothed[i]
    acc_hor = acc_hor_max[i]
    hnorm = math.hypot(vel_cmd[0], vel_cmd[1])
    dist = math.hypot(err[0], err[1]) if (has_pos[0] and raw) else np.inf
    v_max = fmin(sp_max_xy[i], math.sqrt(acc_hor * dist))
    s = fmin(1.0, v_max / fmax(hnorm, 1e-9))
    vel_cmd[0] *= s
    vel_cmd[1] *= s
    vel_cmd[2] = clamp(vel_cmd[2], -sp_max_up[i], sp_max_down[i])
    dv0 = vel_cmd[0] - vel_sp[i, 0]
    dv1 = vel_cmd[1] - vel_sp[i, 1]
    if raw:  # horizontal slew limit (acceleration) on the velocity setpoint
        s = fmin(1.0, (acc_hor * dt_s) / fmax(math.hypot(dv0, dv1), 1e-9))
        dv0 *= s
        dv1 *= s
    vel_sp[i, 0] += dv0
    vel_sp[i, 1] += dv1
    vel_sp[i, 2] = vel_cmd[2]
    for a in range(3):
        if not (active[i] and has_vel[a]):  # acceleration-controlled axes follow the vehicle
            vel_sp[i, a] = velocity[i, a]

    # Velocity PID -> acceleration setpoint (NED).
    verr = np.empty(3)
    acc = np.empty(3)
    inv_dt = 1.0 / dt_s
    for a in range(3):
        v = velocity[i, a]
        verr[a] = vel_sp[i, a] - v
        dvel = (v - prev_vel[i, a]) * inv_dt
        prev_vel[i, a] = v
        acc_a = vel_p[i, a] * verr[a] + vel_int[i, a] - vel_d[i, a] * dvel
        if not has_vel[a]:
            acc_a = 0.0
        acc[a] = acc_a + sp_acc_ff[i, a]
    acc[2] = clamp(acc[2], -ACC_Z_MAX, ACC_Z_MAX)

    # Thrust direction: body z (down) opposes the required specific force.
    f0, f1, f2 = acc[0], acc[1], acc[2] - g
    scale = -1.0 / fmax(math.sqrt(f0 * f0 + f1 * f1 + f2 * f2), 1e-6)
    bz0, bz1, bz2 = f0 * scale, f1 * scale, f2 * scale
    cos_max = cos_tilt_max[i]
    if bz2 < cos_max:  # rotate towards vertical so the tilt never exceeds tilt_max
        hn = fmax(math.hypot(bz0, bz1), 1e-9)
        st = math.sin(tilt_max_rad[i])
        bz0 = bz0 / hn * st
        bz1 = bz1 / hn * st
        bz2 = cos_max
    h = hover[i]
    thrust = h * (g - acc[2]) / (g * bz2)
    thrust_sat = clamp(thrust, 0.05, 0.95)

    # Integrate with anti-windup: stop integrating the vertical axis while thrust saturates;
    # horizontally, as PX4's PositionControl, feed back what the tilt limit cut off the
    # acceleration demand (gain 2 / vel_p).
    k = thrust_sat * g / h
    done0, done1 = -bz0 * k, -bz1 * k
    cut = acc[0] * acc[0] + acc[1] * acc[1] > done0 * done0 + done1 * done1
    lim0, lim1 = (done0, done1) if cut else (acc[0], acc[1])
    verr[0] -= (2.0 / fmax(vel_p[i, 0], 1e-6)) * (acc[0] - lim0)
    verr[1] -= (2.0 / fmax(vel_p[i, 1], 1e-6)) * (acc[1] - lim1)
    on = 1.0 if active[i] else 0.0
    for a in range(3):
        step = vel_i[i, a] * verr[a] * dt_s
        if a == 2 and thrust != thrust_sat:  # NaN too, as numpy's (thrust == thrust_sat)
            step *= 0.0
        step *= on
        vi = vel_int[i, a]
        if not has_vel[a]:
            step *= 0.0
            vi = 0.0
        lim = INT_MAX_Z if a == 2 else INT_MAX_XY
        vel_int[i, a] = clamp(vi + step, -lim, lim)
    attitude_from_body_z_row(i, bz0, bz1, bz2, sp_yaw[i], q_out)
    thrust_out[i] = thrust_sat


@numba.njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def attitude_from_body_z_row(
    i: int, bz0: float, bz1: float, bz2: float, yaw_rad: float, q_out: np.ndarray
) -> None:
    """Quaternion (w >= 0) into ``q_out[i]`` whose body z is ``bz`` and whose heading is yaw.

    As PX4's bodyzToAttitude: body x is the horizontal heading direction made orthogonal to
    body z (y_C x body_z), body y completes the frame.
    """
    yc0, yc1 = -math.sin(yaw_rad), math.cos(yaw_rad)
    bx0 = yc1 * bz2 - 0.0 * bz1
    bx1 = 0.0 * bz0 - yc0 * bz2
    bx2 = yc0 * bz1 - yc1 * bz0
    n = fmax(math.sqrt(bx0 * bx0 + bx1 * bx1 + bx2 * bx2), 1e-9)
    bx0, bx1, bx2 = bx0 / n, bx1 / n, bx2 / n
    by0 = bz1 * bx2 - bz2 * bx1
    by1 = bz2 * bx0 - bz0 * bx2
    by2 = bz0 * bx1 - bz1 * bx0
    # Rotation matrix with columns (body_x, body_y, body_z) -> quaternion (branch-free).
    d0, d1, d2 = bx0, by1, bz2
    w = 0.5 * math.sqrt(fmax(1.0 + d0 + d1 + d2, 0.0))
    x = 0.5 * math.sqrt(fmax(1.0 + d0 - d1 - d2, 0.0))
    y = 0.5 * math.sqrt(fmax(1.0 - d0 + d1 - d2, 0.0))
    z = 0.5 * math.sqrt(fmax(1.0 - d0 - d1 + d2, 0.0))
    q_out[i, 0] = w
    q_out[i, 1] = math.copysign(x, by2 - bz1)
    q_out[i, 2] = math.copysign(y, bz0 - bx2)
    q_out[i, 3] = math.copysign(z, bx1 - by0)
