"""Position -> velocity -> acceleration -> thrust-vector control, batched over the fleet.

Follows the structure of PX4's multicopter position controller (mc_pos_control): a P loop on
position produces a velocity setpoint (plus feed-forward), limited per axis and slew-limited by
MPC_ACC_HOR; a PID loop on velocity produces an acceleration setpoint; the acceleration is turned
into a body-z direction (tilt-limited by MPC_TILTMAX_AIR) and a collective thrust scaled by the
hover thrust MPC_THR_HOVER. The attitude setpoint combines that body-z with the yaw setpoint.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from autopilot_emu import quaternion as quat
from autopilot_emu.estimator import GRAVITY_M_S2


@dataclass
class PositionGains:
    """Per-vehicle gains (N,) arrays, refreshed from parameters when they change."""

    xy_p: np.ndarray
    z_p: np.ndarray
    xy_vel_p: np.ndarray
    xy_vel_i: np.ndarray
    xy_vel_d: np.ndarray
    z_vel_p: np.ndarray
    z_vel_i: np.ndarray
    z_vel_d: np.ndarray
    hover_thrust: np.ndarray
    tilt_max_rad: np.ndarray
    acc_hor_max_m_s2: np.ndarray


@dataclass
class PositionSetpoint:
    """What the navigator asks of the position controller, (N, ...) arrays.

    A NaN position component means "velocity control on that axis" (then ``velocity_ff`` is the
    velocity setpoint); finite ones are tracked with the P loop plus ``velocity_ff``.
    """

    position_ned_m: np.ndarray
    velocity_ff_m_s: np.ndarray
    yaw_rad: np.ndarray
    max_speed_xy_m_s: np.ndarray
    max_speed_up_m_s: np.ndarray
    max_speed_down_m_s: np.ndarray

    @classmethod
    def hold(cls, n: int) -> PositionSetpoint:
        """All-NaN position, zero velocity: hover where you are."""
        return cls(
            np.full((n, 3), np.nan),
            np.zeros((n, 3)),
            np.zeros(n),
            np.full(n, 5.0),
            np.full(n, 3.0),
            np.full(n, 1.5),
        )


class PositionController:
    """Cascaded position and velocity control for N vehicles."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.vel_int = np.zeros((n, 3))
        self.vel_sp = np.zeros((n, 3))
        self._prev_vel = np.zeros((n, 3))

    def reset(self, mask: np.ndarray) -> None:
        """Clear integrators and slew state (e.g. on arming)."""
        self.vel_int[mask] = 0.0
        self.vel_sp[mask] = 0.0

    def update(
        self,
        sp: PositionSetpoint,
        gains: PositionGains,
        position: np.ndarray,
        velocity: np.ndarray,
        dt_s: float,
        active: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Return the attitude setpoint quaternions (N, 4) and collective thrust (N,) in 0..1."""
        err = sp.position_ned_m - position
        has_pos = np.isfinite(err)
        vel_cmd = sp.velocity_ff_m_s.copy()
        p = np.stack((gains.xy_p, gains.xy_p, gains.z_p), axis=1)
        vel_cmd += np.where(has_pos, p * np.nan_to_num(err), 0.0)
        # Per-axis limits: horizontal norm, vertical up/down. Horizontally also the speed from
        # which the vehicle can still stop at the target with half of MPC_ACC_HOR (what PX4's
        # jerk-limited trajectory achieves), so goto arrives without overshoot.
        hnorm = np.hypot(vel_cmd[:, 0], vel_cmd[:, 1])
        dist = np.where(has_pos[:, 0], np.hypot(*np.nan_to_num(err[:, :2]).T), np.inf)
        v_stop = np.sqrt(gains.acc_hor_max_m_s2 * dist)
        scale = np.minimum(1.0, np.minimum(sp.max_speed_xy_m_s, v_stop) / np.maximum(hnorm, 1e-9))
        vel_cmd[:, :2] *= scale[:, None]
        vel_cmd[:, 2] = np.clip(vel_cmd[:, 2], -sp.max_speed_up_m_s, sp.max_speed_down_m_s)
        # Horizontal slew limit (acceleration) on the velocity setpoint.
        dv = vel_cmd[:, :2] - self.vel_sp[:, :2]
        dvn = np.hypot(dv[:, 0], dv[:, 1])
        step = gains.acc_hor_max_m_s2 * dt_s
        dv *= np.minimum(1.0, step / np.maximum(dvn, 1e-9))[:, None]
        self.vel_sp[:, :2] += dv
        self.vel_sp[:, 2] = vel_cmd[:, 2]
        self.vel_sp[~active] = velocity[~active]

        # Velocity PID -> acceleration setpoint (NED).
        verr = self.vel_sp - velocity
        kp = np.stack((gains.xy_vel_p, gains.xy_vel_p, gains.z_vel_p), axis=1)
        ki = np.stack((gains.xy_vel_i, gains.xy_vel_i, gains.z_vel_i), axis=1)
        kd = np.stack((gains.xy_vel_d, gains.xy_vel_d, gains.z_vel_d), axis=1)
        dvel = (velocity - self._prev_vel) / dt_s
        self._prev_vel = velocity.copy()
        acc = kp * verr + self.vel_int - kd * dvel
        acc[:, 2] = np.clip(acc[:, 2], -GRAVITY_M_S2 * 0.8, GRAVITY_M_S2 * 0.8)

        # Thrust direction: body z (down) opposes the required specific force.
        force = acc - np.array([0.0, 0.0, GRAVITY_M_S2])
        body_z = -force / np.maximum(np.linalg.norm(force, axis=1, keepdims=True), 1e-6)
        body_z = _limit_tilt(body_z, gains.tilt_max_rad)
        thrust = gains.hover_thrust * (GRAVITY_M_S2 - acc[:, 2]) / (GRAVITY_M_S2 * body_z[:, 2])
        thrust_sat = np.clip(thrust, 0.05, 0.95)

        # Integrate with anti-windup: stop integrating an axis that saturates.
        sat_z = thrust != thrust_sat
        int_step = ki * verr * dt_s
        int_step[sat_z, 2] = 0.0
        self.vel_int += np.where(active[:, None], int_step, 0.0)
        self.vel_int[:, :2] = np.clip(self.vel_int[:, :2], -1.0, 1.0)
        self.vel_int[:, 2] = np.clip(self.vel_int[:, 2], -4.0, 4.0)
        return attitude_from_body_z(body_z, sp.yaw_rad), thrust_sat


def _limit_tilt(body_z: np.ndarray, tilt_max_rad: np.ndarray) -> np.ndarray:
    """Rotate body_z towards vertical so its tilt never exceeds tilt_max."""
    cos_tilt = np.clip(body_z[:, 2], -1.0, 1.0)
    tilt = np.arccos(cos_tilt)
    over = tilt > tilt_max_rad
    if not over.any():
        return body_z
    out = body_z.copy()
    h = body_z[over, :2]
    hn = np.maximum(np.linalg.norm(h, axis=1, keepdims=True), 1e-9)
    t = tilt_max_rad[over]
    out[over, :2] = h / hn * np.sin(t)[:, None]
    out[over, 2] = np.cos(t)
    return out


def attitude_from_body_z(body_z: np.ndarray, yaw_rad: np.ndarray) -> np.ndarray:
    """Attitude quaternion whose body z is ``body_z`` (NED) and whose heading is ``yaw``."""
    y_c = np.stack((-np.sin(yaw_rad), np.cos(yaw_rad), np.zeros_like(yaw_rad)), axis=1)
    body_x = np.cross(y_c, body_z)
    body_x /= np.maximum(np.linalg.norm(body_x, axis=1, keepdims=True), 1e-9)
    body_y = np.cross(body_z, body_x)
    r = np.stack((body_x, body_y, body_z), axis=2)
    return quat.from_rotation_matrix(r)
