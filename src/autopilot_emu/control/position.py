"""Position -> velocity -> acceleration -> thrust-vector control, batched over the fleet.

Follows the structure of PX4's multicopter position controller (mc_pos_control): a P loop on
position produces a velocity setpoint (plus feed-forward), limited per axis and slew-limited by
MPC_ACC_HOR; a PID loop on velocity produces an acceleration setpoint; the acceleration is turned
into a body-z direction (tilt-limited by MPC_TILTMAX_AIR) and a collective thrust scaled by the
hover thrust (the hover-thrust estimate; MPC_THR_HOVER until it is valid). The attitude setpoint
combines that body-z with the yaw setpoint.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from autopilot_emu import quaternion as quat
from autopilot_emu.estimator import GRAVITY_M_S2


@dataclass
class PositionGains:
    """Per-vehicle gains, refreshed from parameters when they change.

    Per-axis gains are (N, 3) arrays (north, east, down: MPC_XY_* twice, then MPC_Z_*); the rest
    are (N,).
    """

    pos_p: np.ndarray
    vel_p: np.ndarray
    vel_i: np.ndarray
    vel_d: np.ndarray
    hover_thrust: np.ndarray
    tilt_max_rad: np.ndarray
    acc_hor_max_m_s2: np.ndarray
    cos_tilt_max: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.cos_tilt_max = np.cos(self.tilt_max_rad)


@dataclass
class PositionSetpoint:
    """What the navigator asks of the position controller, (N, ...) arrays.

    A NaN position component means "velocity control on that axis" (then ``velocity_ff`` is the
    velocity setpoint); finite ones are tracked with the P loop plus ``velocity_ff``. An axis
    whose position and velocity are both NaN is acceleration-controlled: ``acceleration_ff``
    alone is the acceleration setpoint there (offboard acceleration setpoints).
    """

    position_ned_m: np.ndarray
    velocity_ff_m_s: np.ndarray
    yaw_rad: np.ndarray
    max_speed_xy_m_s: np.ndarray
    max_speed_up_m_s: np.ndarray
    max_speed_down_m_s: np.ndarray
    acceleration_ff_m_s2: np.ndarray
    """Acceleration feed-forward (NED, m/s²), added to the velocity loop's output."""
    smoothed: np.ndarray | None = None
    """(N,) rows that come from the jerk-limited trajectory (auto modes): tracked as given. Other
    rows (offboard, or no trajectory) keep the controller's own approach-speed and slew limits."""

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
            np.zeros((n, 3)),
            np.zeros(n, dtype=bool),
        )


_G_NED = np.array([0.0, 0.0, GRAVITY_M_S2])
_ACC_Z_MAX = 0.8 * GRAVITY_M_S2
"""Vertical acceleration demand limit, m/s²."""
_INT_MAX = np.array([GRAVITY_M_S2, GRAVITY_M_S2, 4.0])
"""Velocity-integrator limits (north, east, down), m/s². Horizontally PX4 has no fixed cap (its
anti-windup is the tilt limit, below); one g is as far as MPC_TILTMAX_AIR = 45 deg can go."""


class PositionController:
    """Cascaded position and velocity control for N vehicles."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.vel_int = np.zeros((n, 3))
        self.vel_sp = np.zeros((n, 3))
        self._prev_vel = np.zeros((n, 3))

    def reset(self, mask: np.ndarray, velocity: np.ndarray) -> None:
        """Restart the masked vehicles from their current velocity (integrators cleared)."""
        self.vel_int[mask] = 0.0
        self.vel_sp[mask] = velocity[mask]

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
        err = np.where(has_pos, err, 0.0)
        vel_ff = sp.velocity_ff_m_s
        has_vel = np.isfinite(vel_ff)
        all_vel = has_vel.all()
        if not all_vel:
            has_vel |= has_pos
            vel_ff = np.where(has_vel, vel_ff, 0.0)
        vel_cmd = vel_ff + gains.pos_p * err
        # Per-axis limits: horizontal norm, vertical up/down. Setpoints that do not come from
        # the trajectory are also capped at the speed from which the vehicle can still stop at
        # the target with MPC_ACC_HOR, and slew-limited by it.
        raw = ~sp.smoothed if sp.smoothed is not None else np.ones(self.n, dtype=bool)
        hnorm = np.hypot(vel_cmd[:, 0], vel_cmd[:, 1])
        dist = np.where(has_pos[:, 0] & raw, np.hypot(err[:, 0], err[:, 1]), np.inf)
        v_max = np.minimum(sp.max_speed_xy_m_s, np.sqrt(gains.acc_hor_max_m_s2 * dist))
        vel_cmd[:, :2] *= np.minimum(1.0, v_max / np.maximum(hnorm, 1e-9))[:, None]
        vel_cmd[:, 2] = np.minimum(
            np.maximum(vel_cmd[:, 2], -sp.max_speed_up_m_s), sp.max_speed_down_m_s
        )
        # Horizontal slew limit (acceleration) on the velocity setpoint.
        dv = vel_cmd[:, :2] - self.vel_sp[:, :2]
        dvn = np.hypot(dv[:, 0], dv[:, 1])
        dv *= np.minimum(1.0, (gains.acc_hor_max_m_s2 * dt_s) / np.maximum(dvn, 1e-9))[:, None]
        dv = np.where(raw[:, None], dv, vel_cmd[:, :2] - self.vel_sp[:, :2])
        self.vel_sp[:, :2] += dv
        self.vel_sp[:, 2] = vel_cmd[:, 2]
        if not active.all():
            self.vel_sp[~active] = velocity[~active]
        if not all_vel:  # acceleration-controlled axes follow the vehicle's velocity
            self.vel_sp = np.where(has_vel, self.vel_sp, velocity)

        # Velocity PID -> acceleration setpoint (NED).
        verr = self.vel_sp - velocity
        dvel = (velocity - self._prev_vel) * (1.0 / dt_s)
        self._prev_vel = velocity.copy()
        acc = gains.vel_p * verr + self.vel_int - gains.vel_d * dvel
        if not all_vel:
            acc = np.where(has_vel, acc, 0.0)
        acc += sp.acceleration_ff_m_s2
        acc[:, 2] = np.minimum(np.maximum(acc[:, 2], -_ACC_Z_MAX), _ACC_Z_MAX)

        # Thrust direction: body z (down) opposes the required specific force.
        force = acc - _G_NED
        body_z = force * (-1.0 / np.maximum(quat.row_norm(force), 1e-6))[:, None]
        body_z = _limit_tilt(body_z, gains.tilt_max_rad, gains.cos_tilt_max)
        thrust = gains.hover_thrust * (GRAVITY_M_S2 - acc[:, 2]) / (GRAVITY_M_S2 * body_z[:, 2])
        thrust_sat = np.minimum(np.maximum(thrust, 0.05), 0.95)

        # Integrate with anti-windup: stop integrating the vertical axis while thrust saturates;
        # horizontally, as PX4's PositionControl, feed back what the tilt limit cut off the
        # acceleration demand (gain 2 / vel_p).
        acc_xy = acc[:, :2]
        acc_xy_done = -body_z[:, :2] * (thrust_sat * GRAVITY_M_S2 / gains.hover_thrust)[:, None]
        cut = (acc_xy * acc_xy).sum(axis=1) > (acc_xy_done * acc_xy_done).sum(axis=1)
        acc_xy_limited = np.where(cut[:, None], acc_xy_done, acc_xy)
        verr[:, :2] -= (2.0 / np.maximum(gains.vel_p[:, :2], 1e-6)) * (acc_xy - acc_xy_limited)
        int_step = gains.vel_i * verr * dt_s
        int_step[:, 2] *= thrust == thrust_sat
        int_step *= active[:, None]
        if not all_vel:
            int_step *= has_vel
            self.vel_int = np.where(has_vel, self.vel_int, 0.0)
        self.vel_int = np.minimum(np.maximum(self.vel_int + int_step, -_INT_MAX), _INT_MAX)
        return attitude_from_body_z(body_z, sp.yaw_rad), thrust_sat


def _limit_tilt(body_z: np.ndarray, tilt_max_rad: np.ndarray, cos_max: np.ndarray) -> np.ndarray:
    """Rotate body_z towards vertical so its tilt never exceeds tilt_max."""
    over = body_z[:, 2] < cos_max
    if not over.any():
        return body_z
    out = body_z.copy()
    h = body_z[over, :2]
    hn = np.maximum(np.hypot(h[:, 0], h[:, 1]), 1e-9)[:, None]
    out[over, :2] = h / hn * np.sin(tilt_max_rad[over])[:, None]
    out[over, 2] = cos_max[over]
    return out


def attitude_from_body_z(body_z: np.ndarray, yaw_rad: np.ndarray) -> np.ndarray:
    """Attitude quaternion whose body z is ``body_z`` (NED) and whose heading is ``yaw``.

    As PX4's bodyzToAttitude: body x is the horizontal heading direction made orthogonal to
    body z (y_C x body_z), body y completes the frame.
    """
    y_c = np.zeros_like(body_z)
    y_c[:, 0] = -np.sin(yaw_rad)
    y_c[:, 1] = np.cos(yaw_rad)
    body_x = quat.cross(y_c, body_z)
    body_x /= np.maximum(quat.row_norm(body_x), 1e-9)[:, None]
    body_y = quat.cross(body_z, body_x)
    return quat.from_rotation_matrix(np.stack((body_x, body_y, body_z), axis=2))
