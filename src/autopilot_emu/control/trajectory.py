"""Jerk-limited setpoint trajectory of the auto modes: the law, and what the navigator asks of it.

What PX4's FlightTaskAuto does with PositionSmoothing / VelocitySmoothing, in its own form: the
navigator's target (a position, or a velocity on an axis without one) is not handed to the
position controller directly; a trajectory state (position, velocity, acceleration) is driven
towards it with the jerk bounded by MPC_JERK_AUTO, the acceleration by MPC_ACC_HOR (horizontal)
and MPC_ACC_UP_MAX / MPC_ACC_DOWN_MAX (vertical), the speed by the cruise speed (MPC_XY_CRUISE or
a speed override, MPC_Z_V_AUTO_UP / _DN). Approaching a position target, the speed is capped at
the speed from which a jerk-limited stop fits in the remaining distance (PX4's
``computeMaxSpeedFromDistance``), so the trajectory arrives without overshoot. As PX4
(MPC_XY_ERR_MAX), the trajectory's clock slows linearly with the horizontal distance of a vehicle
lagging behind it and stops at MPC_XY_ERR_MAX, so it never runs away from a vehicle that cannot
follow.
The position controller tracks the trajectory's position with its velocity and acceleration as
feed-forward. Offboard setpoints bypass it (PX4's FlightTaskOffboard does not smooth).

The trajectory state of every vehicle is part of the navigation loop's state
(:class:`~autopilot_emu.control.nav.NavState`), and its step is compiled into that loop
(``trajectory_kernel.trajectory_row``). Here: the navigator's questions to the same law, the
braking distance and the hold point.

Units: SI, local NED.
"""

from __future__ import annotations

import numpy as np

from autopilot_emu.control.trajectory_kernel import hold_point_kernel


def _f64(a: np.ndarray) -> np.ndarray:
    """C-contiguous float64 (one compiled signature for the kernel)."""
    return np.ascontiguousarray(a, dtype=np.float64)


def braking_distance(
    speed_m_s: np.ndarray | float, acc_m_s2: np.ndarray | float, jerk_m_s3: np.ndarray | float
) -> np.ndarray | float:
    """Distance to stop from a steady ``speed_m_s``, m, as PX4's navigator estimates it.

    v² / (2 a) at constant deceleration plus v times the delay before the deceleration is built
    up, taken as 0.6 j / j = 0.6 s (Navigator::calculate_breaking_stop with
    computeBrakingDistanceFromVelocity and an acceleration delay of 0.6 MPC_JERK_AUTO).
    """
    delay_s = 0.6 * jerk_m_s3 / jerk_m_s3
    return speed_m_s * speed_m_s / (2.0 * acc_m_s2) + speed_m_s * delay_s


def hold_point(
    position_m: np.ndarray,
    velocity_m_s: np.ndarray,
    acceleration_m_s2: np.ndarray,
    speed_m_s: float,
    acc_m_s2: float,
    jerk_m_s3: float,
    dt_s: float,
    max_s: float = 30.0,
    tolerance_m: float = 0.02,
) -> np.ndarray:
    """Nearest horizontal target (north, east) a trajectory state reaches without turning back.

    ``speed_m_s`` is the speed limit in force (the state's own speed, if higher, is kept).
    The state is the smoothed setpoint's position, velocity and acceleration (3-vectors, NED);
    the search runs the trajectory's own law at ``dt_s`` (compiled: ``hold_point_kernel``). A
    state that is still speeding up, or that runs ahead of its vehicle, needs a target further
    out than the steady-speed estimate of :func:`braking_distance`.
    """
    speed = max(speed_m_s, float(np.hypot(velocity_m_s[0], velocity_m_s[1])), 0.1)
    limits = np.array([speed, acc_m_s2, jerk_m_s3], dtype=np.float64)
    return hold_point_kernel(
        _f64(position_m), _f64(velocity_m_s), _f64(acceleration_m_s2), limits, float(dt_s),
        float(max_s), float(tolerance_m),
    )  # fmt: skip


def load_hold_point_kernel() -> None:
    """Compile :func:`hold_point`'s kernel now, or load it from numba's cache.

    The first switch to Hold mid-flight would otherwise pay for it: 5 to 7 s of compiling in a
    fresh install, about half a second to load the cache in a fresh process. The simulation stood
    still that long, and a MAVSDK ``hold()`` waiting for its COMMAND_ACK timed out (a CI run).
    """
    zero = np.zeros(3)
    hold_point(zero, zero, zero, 1.0, 1.0, 1.0, 0.01)
