"""Compiled jerk-limited trajectory step, one vehicle row at a time.

The law of :mod:`autopilot_emu.control.trajectory`, compiled into the navigation loop's kernel
(:mod:`autopilot_emu.control.nav_kernel`) and run by the navigator's hold-point search
(:func:`hold_point_kernel`).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from autopilot_emu.nan_scalar import fmax, fmin, sign


@numba.njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def max_speed_from_distance_scalar(distance_m: float, acc_m_s2: float, jerk_m_s3: float) -> float:
    """Highest speed from which a jerk-limited stop still fits in ``distance_m``."""
    b = 4.0 * acc_m_s2 * acc_m_s2 / jerk_m_s3
    return 0.5 * (math.sqrt(b * b + 8.0 * acc_m_s2 * fmax(distance_m, 0.0)) - b)


@numba.njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _finite_or_zero(x: float) -> float:
    return x if math.isfinite(x) else 0.0


@numba.njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def trajectory_row(
    i: int,
    target_position: np.ndarray,
    target_velocity: np.ndarray,
    speed_xy: np.ndarray,
    speed_up: np.ndarray,
    speed_down: np.ndarray,
    acc_xy: np.ndarray,
    acc_up: np.ndarray,
    acc_down: np.ndarray,
    jerk: np.ndarray,
    error_max: np.ndarray,
    vehicle_position: np.ndarray,
    dt_s: float,
    pos: np.ndarray,
    vel: np.ndarray,
    acc: np.ndarray,
) -> None:
    """Advance trajectory i by ``dt_s`` towards its target (NaN position: follow velocity)."""
    jmax = jerk[i]
    # Velocity each axis group is asked to reach now.
    e0 = target_position[i, 0] - pos[i, 0]
    e1 = target_position[i, 1] - pos[i, 1]
    e2 = target_position[i, 2] - pos[i, 2]
    has_xy = math.isfinite(e0) and math.isfinite(e1)
    has_z = math.isfinite(e2)
    e0, e1, e2 = _finite_or_zero(e0), _finite_or_zero(e1), _finite_or_zero(e2)
    dist_xy = math.hypot(e0, e1)
    sxy = fmin(speed_xy[i], max_speed_from_distance_scalar(dist_xy, acc_xy[i], jmax))
    if has_xy:
        s = sxy / fmax(dist_xy, 1e-9)
        v0, v1 = e0 * s, e1 * s
    else:
        v0 = _finite_or_zero(target_velocity[i, 0])
        v1 = _finite_or_zero(target_velocity[i, 1])
    s = fmin(1.0, speed_xy[i] / fmax(math.hypot(v0, v1), 1e-9))
    v0 *= s
    v1 *= s
    down = e2 > 0
    acc_brake_z = acc_up[i] if down else acc_down[i]
    speed_z = speed_down[i] if down else speed_up[i]
    speed_z = fmin(speed_z, max_speed_from_distance_scalar(abs(e2), acc_brake_z, jmax))
    v_z = sign(e2) * speed_z if has_z else _finite_or_zero(target_velocity[i, 2])
    v_z = fmin(fmax(v_z, -speed_up[i]), speed_down[i])

    # Time stretch: the trajectory waits for a vehicle that lags behind it (MPC_XY_ERR_MAX);
    # one that is ahead (it overshot a corner) is pulled back, the trajectory runs on.
    b0 = pos[i, 0] - vehicle_position[i, 0]
    b1 = pos[i, 1] - vehicle_position[i, 1]
    lag = math.hypot(b0, b1) if b0 * vel[i, 0] + b1 * vel[i, 1] > 0.0 else 0.0
    stretch = 1.0 - lag / fmax(error_max[i], 1e-6)
    dt = dt_s * fmin(fmax(stretch, 0.0), 1.0)

    # Jerk that steers the acceleration towards the one reaching the target velocity.
    a0, a1, a2 = acc[i, 0], acc[i, 1], acc[i, 2]
    k = math.hypot(a0, a1) / (2.0 * jmax)
    ex0 = v0 - (vel[i, 0] + a0 * k)
    ex1 = v1 - (vel[i, 1] + a1 * k)
    ex_n = math.hypot(ex0, ex1)
    a_mag = fmin(acc_xy[i], math.sqrt(jmax * ex_n))
    s = a_mag / fmax(ex_n, 1e-9)
    ad0, ad1 = ex0 * s, ex1 * s
    e_z = v_z - (vel[i, 2] + a2 * abs(a2) / (2.0 * jmax))
    ad2 = sign(e_z) * math.sqrt(jmax * abs(e_z))
    ad2 = fmin(fmax(ad2, -acc_up[i]), acc_down[i])

    inv_dt = 1.0 / fmax(dt_s, 1e-9)
    j0 = (ad0 - a0) * inv_dt
    j1 = (ad1 - a1) * inv_dt
    s = fmin(1.0, jmax / fmax(math.hypot(j0, j1), 1e-9))
    j0 *= s
    j1 *= s
    j2 = fmin(fmax((ad2 - a2) * inv_dt, -jmax), jmax)

    # Exact integration over dt at constant jerk.
    dt2 = dt * dt / 2.0
    dt3 = dt * dt * dt / 6.0
    jj = (j0, j1, j2)
    for a in range(3):
        p, v, ac, j = pos[i, a], vel[i, a], acc[i, a], jj[a]
        pos[i, a] = p + (v * dt + ac * dt2 + j * dt3)
        vel[i, a] = v + (ac * dt + j * dt2)
        acc[i, a] = ac + j * dt


@numba.njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _brake_row(
    target_xy: np.ndarray,
    direction: np.ndarray,
    limits: np.ndarray,
    dt_s: float,
    max_steps: int,
    pos: np.ndarray,
    vel: np.ndarray,
    acc: np.ndarray,
) -> float:
    """Run a one-row trajectory to rest towards ``target_xy`` (NaN: a zero velocity target).

    Returns the largest distance it ran past the target along ``direction`` (0 for a velocity
    target); ``limits`` holds speed, acceleration and jerk. The state arrays are advanced.
    """
    tp = np.empty((1, 3))
    tp[0, 0], tp[0, 1], tp[0, 2] = target_xy[0], target_xy[1], pos[0, 2]
    tv = np.zeros((1, 3))
    speed = np.full(1, limits[0])
    a_xy = np.full(1, limits[1])
    jerk = np.full(1, limits[2])
    one = np.ones(1)
    err = np.full(1, np.inf)
    past = 0.0
    for _ in range(max_steps):
        trajectory_row(
            0, tp, tv, speed, one, one, a_xy, one, one, jerk, err, pos, dt_s, pos, vel, acc,
        )  # fmt: skip
        if math.isfinite(tp[0, 0]):
            d = (pos[0, 0] - tp[0, 0]) * direction[0] + (pos[0, 1] - tp[0, 1]) * direction[1]
            past = fmax(past, d)
        if math.hypot(vel[0, 0], vel[0, 1]) < 1e-3 and math.hypot(acc[0, 0], acc[0, 1]) < 1e-2:
            break
    return past


@numba.njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _past(
    delta_m: float,
    stop: np.ndarray,
    u: np.ndarray,
    state: tuple[np.ndarray, np.ndarray, np.ndarray],
    limits: np.ndarray,
    dt_s: float,
    steps: int,
) -> float:
    """How far the state runs past a position target ``delta_m`` beyond ``stop`` along u."""
    target = np.array([stop[0] + u[0] * delta_m, stop[1] + u[1] * delta_m])
    p = state[0].reshape(1, 3).copy()
    v = state[1].reshape(1, 3).copy()
    a = state[2].reshape(1, 3).copy()
    return _brake_row(target, u, limits, dt_s, steps, p, v, a)


@numba.njit(cache=True, error_model="numpy")
def hold_point_kernel(
    position: np.ndarray,
    velocity: np.ndarray,
    acceleration: np.ndarray,
    limits: np.ndarray,
    dt_s: float,
    max_s: float,
    tolerance_m: float,
) -> np.ndarray:
    """Nearest horizontal target a trajectory state (3-vectors) reaches without turning back.

    First the point where it comes to rest braking as hard as its law allows (a zero velocity
    target); a position target there is approached more gently and passed, so the target moves
    on along the direction of travel, by doubling and then bisection, until the trajectory runs
    at most ``tolerance_m`` past it. ``limits``: speed, acceleration, jerk.
    """
    steps = max(1, int(max_s / dt_s))
    p = position.reshape(1, 3).copy()
    v = velocity.reshape(1, 3).copy()
    a = acceleration.reshape(1, 3).copy()
    nan_xy = np.full(2, np.nan)
    u = np.zeros(2)
    _brake_row(nan_xy, u, limits, dt_s, steps, p, v, a)
    stop = np.array([p[0, 0], p[0, 1]])
    speed = math.hypot(velocity[0], velocity[1])
    if speed < 1e-6:
        return stop
    u[0], u[1] = velocity[0] / speed, velocity[1] / speed
    state = (position, velocity, acceleration)
    lo, hi = 0.0, 0.25
    while _past(hi, stop, u, state, limits, dt_s, steps) > tolerance_m and hi < 100.0:
        lo, hi = hi, 2.0 * hi
    for _ in range(12):
        if hi - lo < 0.25 * tolerance_m:
            break
        mid = 0.5 * (lo + hi)
        if _past(mid, stop, u, state, limits, dt_s, steps) > tolerance_m:
            lo = mid
        else:
            hi = mid
    return np.array([stop[0] + u[0] * hi, stop[1] + u[1] * hi])
