"""Hold (PX4's Loiter) and Reposition (goto): where the vehicle stops, or the point it flies to.

Both are AUTO_LOITER in PX4: Hold stops at the braking point, Reposition (MAV_CMD_DO_REPOSITION,
MAVSDK's goto_location) moves the loiter point. The commander keeps the point; these functions
say where it is.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from autopilot_emu.commander_params import CommanderParams
from autopilot_emu.control.trajectory import braking_distance, hold_point
from autopilot_emu.modes.nav_types import NavInput, TrajectoryState


def braking_point(
    nav: NavInput,
    params: CommanderParams,
    trajectory_state: Callable[[], TrajectoryState | None] | None,
    cruise_m_s: float,
    dt_s: float,
) -> np.ndarray:
    """Hold at the braking point: the current position plus the distance it takes to stop, NED.

    As PX4's Loiter (Navigator::calculate_breaking_stop), so that a Hold commanded at speed
    does not fly back to where it was asked; the distance is the jerk-limited trajectory's
    stopping distance with MPC_ACC_HOR and MPC_JERK_AUTO. PX4's estimate assumes a steady
    speed; when the smoothed setpoint (``trajectory_state``, None while not smoothing) is still
    speeding up or runs ahead of the vehicle it stops further out, and the hold point is then
    where it stops, so the vehicle does not turn back after braking. For a vehicle in the air;
    ``cruise_m_s`` is the speed limit in force, ``dt_s`` the navigation period.
    """
    target = nav.position_ned_m.copy()
    vel = nav.velocity_ned_m_s[:2]
    speed = float(np.hypot(vel[0], vel[1]))
    if speed <= 1e-6:
        return target
    acc = params.acc_hor_m_s2
    jerk = params.jerk_auto_m_s3
    target[:2] += vel * (float(braking_distance(speed, acc, jerk)) / speed)
    state = trajectory_state() if trajectory_state is not None else None
    if state is not None:
        stop = hold_point(*state, cruise_m_s, acc, jerk, dt_s)
        here = nav.position_ned_m[:2]
        if np.dot(stop - here, vel) > np.dot(target[:2] - here, vel):
            target[:2] = stop
    return target


def reposition_target(
    current: np.ndarray, position_ned_m: np.ndarray, requested: np.ndarray
) -> np.ndarray:
    """The new loiter point: ``requested`` where finite, else the current target (NED, m).

    A current target with a NaN component (a landing's) gives way to the vehicle's position.
    """
    base = current if np.isfinite(current).all() else position_ned_m
    return np.where(np.isfinite(requested), requested, base)
