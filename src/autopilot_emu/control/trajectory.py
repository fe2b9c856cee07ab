"""Jerk-limited setpoint trajectory of the auto modes, batched over the fleet.

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

Units: SI, local NED; arrays are (N, 3) or (N,).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def _clip(x: np.ndarray, lo: np.ndarray | float, hi: np.ndarray | float) -> np.ndarray:
    """np.clip without its per-call overhead (it dominates on (N,) arrays of a few vehicles)."""
    return np.minimum(np.maximum(x, lo), hi)


def _finite_or_zero(x: np.ndarray) -> np.ndarray:
    """NaN (not controlled) as 0."""
    return np.where(np.isfinite(x), x, 0.0)


@dataclass
class TrajectoryLimits:
    """Per-vehicle constraints of the trajectory, (N,) arrays."""

    speed_xy_m_s: np.ndarray
    speed_up_m_s: np.ndarray
    speed_down_m_s: np.ndarray
    acc_xy_m_s2: np.ndarray
    """MPC_ACC_HOR."""
    acc_up_m_s2: np.ndarray
    """MPC_ACC_UP_MAX."""
    acc_down_m_s2: np.ndarray
    """MPC_ACC_DOWN_MAX."""
    jerk_m_s3: np.ndarray
    """MPC_JERK_AUTO."""
    error_max_m: np.ndarray
    """MPC_XY_ERR_MAX: horizontal vehicle-to-trajectory distance at which the trajectory stops."""


def max_speed_from_distance(
    distance_m: np.ndarray, acc_m_s2: np.ndarray, jerk_m_s3: np.ndarray
) -> np.ndarray:
    """Highest speed from which a jerk-limited stop still fits in ``distance_m``.

    Solves d = (v² + b v) / (2 a) for v, with b = 4 a² / j: the braking distance at constant
    deceleration a plus the margin PX4 keeps for ramping the acceleration at jerk j
    (math::trajectory::computeMaxSpeedFromDistance with a final speed of 0).
    """
    b = 4.0 * acc_m_s2 * acc_m_s2 / jerk_m_s3
    return 0.5 * (np.sqrt(b * b + 8.0 * acc_m_s2 * np.maximum(distance_m, 0.0)) - b)


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


class JerkLimitedTrajectory:
    """Trajectory states of N vehicles, each driven towards its target with bounded jerk."""

    def __init__(self, n: int) -> None:
        self.position_m = np.zeros((n, 3))
        self.velocity_m_s = np.zeros((n, 3))
        self.acceleration_m_s2 = np.zeros((n, 3))

    def reset(self, mask: np.ndarray, position: np.ndarray, velocity: np.ndarray) -> None:
        """Restart the masked trajectories at the vehicles' position and velocity, at rest."""
        self.position_m[mask] = position[mask]
        self.velocity_m_s[mask] = velocity[mask]
        self.acceleration_m_s2[mask] = 0.0

    def update(
        self,
        target_position: np.ndarray,
        target_velocity: np.ndarray,
        limits: TrajectoryLimits,
        vehicle_position: np.ndarray,
        dt_s: float,
    ) -> None:
        """Advance all trajectories by ``dt_s`` towards their targets.

        ``target_position`` NaN on an axis means that axis follows ``target_velocity`` instead
        (the horizontal axes go together: both north and east positions must be finite).
        """
        pos, vel, acc = self.position_m, self.velocity_m_s, self.acceleration_m_s2
        jerk_max = limits.jerk_m_s3
        # Velocity each axis group is asked to reach now.
        err = target_position - pos
        has_xy = np.isfinite(err[:, 0]) & np.isfinite(err[:, 1])
        has_z = np.isfinite(err[:, 2])
        err = _finite_or_zero(err)
        dist_xy = np.hypot(err[:, 0], err[:, 1])
        speed_xy = np.minimum(
            limits.speed_xy_m_s, max_speed_from_distance(dist_xy, limits.acc_xy_m_s2, jerk_max)
        )
        v_xy = err[:, :2] * (speed_xy / np.maximum(dist_xy, 1e-9))[:, None]
        v_xy = np.where(has_xy[:, None], v_xy, _finite_or_zero(target_velocity[:, :2]))
        v_xy_n = np.hypot(v_xy[:, 0], v_xy[:, 1])
        v_xy *= np.minimum(1.0, limits.speed_xy_m_s / np.maximum(v_xy_n, 1e-9))[:, None]
        down = err[:, 2] > 0
        acc_brake_z = np.where(down, limits.acc_up_m_s2, limits.acc_down_m_s2)
        speed_z = np.where(down, limits.speed_down_m_s, limits.speed_up_m_s)
        speed_z = np.minimum(
            speed_z, max_speed_from_distance(np.abs(err[:, 2]), acc_brake_z, jerk_max)
        )
        v_z = np.where(has_z, np.sign(err[:, 2]) * speed_z, _finite_or_zero(target_velocity[:, 2]))
        v_z = np.minimum(np.maximum(v_z, -limits.speed_up_m_s), limits.speed_down_m_s)

        # Time stretch: the trajectory waits for a vehicle that lags behind it (MPC_XY_ERR_MAX);
        # one that is ahead (it overshot a corner) is pulled back, the trajectory runs on.
        behind = pos[:, :2] - vehicle_position[:, :2]
        lagging = (behind * vel[:, :2]).sum(axis=1) > 0.0
        lag = np.where(lagging, np.hypot(behind[:, 0], behind[:, 1]), 0.0)
        dt = dt_s * _clip(1.0 - lag / np.maximum(limits.error_max_m, 1e-6), 0.0, 1.0)

        # Jerk that steers the acceleration towards the one reaching the target velocity: the
        # velocity error left once the present acceleration is ramped out at the jerk limit
        # (v + a|a|/2j) asks for the acceleration sqrt(j |e|) of a triangular profile, capped.
        e_xy = v_xy - (
            vel[:, :2] + acc[:, :2] * (np.hypot(acc[:, 0], acc[:, 1]) / (2.0 * jerk_max))[:, None]
        )
        e_xy_n = np.hypot(e_xy[:, 0], e_xy[:, 1])
        a_mag = np.minimum(limits.acc_xy_m_s2, np.sqrt(jerk_max * e_xy_n))
        a_des_xy = e_xy * (a_mag / np.maximum(e_xy_n, 1e-9))[:, None]
        e_z = v_z - (vel[:, 2] + acc[:, 2] * np.abs(acc[:, 2]) / (2.0 * jerk_max))
        a_des_z = np.sign(e_z) * np.sqrt(jerk_max * np.abs(e_z))
        a_des_z = np.minimum(np.maximum(a_des_z, -limits.acc_up_m_s2), limits.acc_down_m_s2)

        inv_dt = 1.0 / max(dt_s, 1e-9)
        j_xy = (a_des_xy - acc[:, :2]) * inv_dt
        j_xy_n = np.hypot(j_xy[:, 0], j_xy[:, 1])
        j_xy *= np.minimum(1.0, jerk_max / np.maximum(j_xy_n, 1e-9))[:, None]
        j_z = _clip((a_des_z - acc[:, 2]) * inv_dt, -jerk_max, jerk_max)
        jerk = np.empty_like(acc)
        jerk[:, :2] = j_xy
        jerk[:, 2] = j_z

        # Exact integration over dt at constant jerk.
        dt_c = dt[:, None]
        pos += vel * dt_c + acc * (dt_c**2 / 2.0) + jerk * (dt_c**3 / 6.0)
        vel += acc * dt_c + jerk * (dt_c**2 / 2.0)
        acc += jerk * dt_c
