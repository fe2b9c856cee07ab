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

from autopilot_emu.control.position_kernel import position_kernel


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
        """Return the attitude setpoint quaternions (N, 4) and collective thrust (N,) in 0..1.

        Compiled (``position_kernel``); the velocity setpoint, integrator and previous velocity
        are updated in place.
        """
        n = self.n
        smoothed = sp.smoothed if sp.smoothed is not None else np.zeros(n, dtype=bool)
        q = np.empty((n, 4))
        thrust = np.empty(n)
        position_kernel(
            _f64(sp.position_ned_m), _f64(sp.velocity_ff_m_s), _f64(sp.yaw_rad),
            _f64(sp.max_speed_xy_m_s), _f64(sp.max_speed_up_m_s), _f64(sp.max_speed_down_m_s),
            _f64(sp.acceleration_ff_m_s2), np.asarray(smoothed, dtype=np.bool_),
            _f64(gains.pos_p), _f64(gains.vel_p), _f64(gains.vel_i), _f64(gains.vel_d),
            _f64(gains.hover_thrust), _f64(gains.tilt_max_rad), _f64(gains.cos_tilt_max),
            _f64(gains.acc_hor_max_m_s2), _f64(position), _f64(velocity), float(dt_s),
            np.asarray(active, dtype=np.bool_), self.vel_int, self.vel_sp, self._prev_vel, q,
            thrust,
        )  # fmt: skip
        return q, thrust


def _f64(a: np.ndarray) -> np.ndarray:
    """C-contiguous float64 (one compiled signature for the kernels)."""
    return np.ascontiguousarray(a, dtype=np.float64)
