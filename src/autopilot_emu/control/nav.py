"""The navigation-rate control loop of the fleet: trajectory smoothing -> position control.

After the commanders, each navigation tick restarts the idle vehicles' controllers, smooths the
auto-mode targets with the jerk-limited trajectory (:mod:`autopilot_emu.control.trajectory`),
runs the position controller (``position_kernel``: PX4's mc_pos_control, P on position -> PID on
velocity -> tilt-limited thrust vector scaled by the hover thrust) and lets offboard attitude /
thrust setpoints replace its output: one compiled call, ``nav_kernel``, behind one entry point,
:meth:`NavLoop.step`.

Auto-mode targets are replaced by the trajectory's state (position on the axes the commander
controls by position, velocity and acceleration as feed-forward), and the controller's own
limits become MPC_XY_VEL_MAX / MPC_Z_VEL_MAX_UP / _DN, as in PX4, so that it can catch up with
the trajectory. Units: SI, local NED; arrays are (N, 3) or (N,).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from autopilot_emu.control.nav_kernel import nav_kernel
from autopilot_emu.params import ParamStore, param_column


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
    smoothed: np.ndarray
    """(N,) rows that come from a trajectory: tracked as given. Other rows keep the controller's
    own approach-speed and slew limits. Ignored while any vehicle of the fleet is smoothed by
    the nav loop, which then decides it per vehicle."""

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


@dataclass(frozen=True)
class NavGains:
    """MPC_* gains and limits of every vehicle.

    Per-axis arrays are (N, 3) (north, east, down: MPC_XY_* twice, then MPC_Z_*), the rest (N,).
    Frozen: a parameter change builds new gains (:meth:`from_params`).
    """

    pos_p: np.ndarray
    """MPC_XY_P, MPC_Z_P: velocity per position error, 1/s."""
    vel_p: np.ndarray
    """MPC_XY_VEL_P_ACC, MPC_Z_VEL_P_ACC: acceleration per velocity error, 1/s."""
    vel_i: np.ndarray
    """MPC_XY_VEL_I_ACC, MPC_Z_VEL_I_ACC: acceleration per integrated velocity error, 1/s²."""
    vel_d: np.ndarray
    """MPC_XY_VEL_D_ACC, MPC_Z_VEL_D_ACC: acceleration per velocity change, dimensionless."""
    tilt_max_rad: np.ndarray
    """MPC_TILTMAX_AIR, rad."""
    acc_hor_max_m_s2: np.ndarray
    """MPC_ACC_HOR: the controller's slew limit and the trajectory's acceleration, m/s²."""
    speed_xy_m_s: np.ndarray
    """MPC_XY_VEL_MAX: the controller's own speed limit while it tracks the trajectory, m/s."""
    speed_up_m_s: np.ndarray
    """MPC_Z_VEL_MAX_UP, m/s."""
    speed_down_m_s: np.ndarray
    """MPC_Z_VEL_MAX_DN, m/s."""
    acc_up_m_s2: np.ndarray
    """MPC_ACC_UP_MAX: the trajectory's upward acceleration limit, m/s²."""
    acc_down_m_s2: np.ndarray
    """MPC_ACC_DOWN_MAX, m/s²."""
    jerk_m_s3: np.ndarray
    """MPC_JERK_AUTO: the trajectory's jerk limit, m/s³."""
    error_max_m: np.ndarray
    """MPC_XY_ERR_MAX: vehicle-to-trajectory horizontal distance that stops the trajectory, m."""
    yaw_rate_auto_rad_s: np.ndarray | None = None
    """MPC_YAWRAUTO_MAX: how fast auto modes turn the heading setpoint, rad/s (None: no limit)."""
    axes: np.ndarray = field(init=False)
    """(4, N, 3) pos_p, vel_p, vel_i, vel_d stacked for ``nav_kernel``."""
    vehicle: np.ndarray = field(init=False)
    """(3, N) tilt_max_rad, its cosine, acc_hor_max_m_s2 stacked for ``nav_kernel``."""
    limits: np.ndarray = field(init=False)
    """(8, N) the trajectory's limits stacked for ``nav_kernel``: speed xy, up, down (the
    controller's own), acceleration xy, up, down, jerk, error_max."""

    def __post_init__(self) -> None:
        # Kernel arguments cost per array: stack what only changes with the parameters.
        axes = np.stack((self.pos_p, self.vel_p, self.vel_i, self.vel_d))
        tilt = self.tilt_max_rad
        vehicle = np.stack((tilt, np.cos(tilt), self.acc_hor_max_m_s2))
        limits = np.stack(
            (
                self.speed_xy_m_s, self.speed_up_m_s, self.speed_down_m_s, self.acc_hor_max_m_s2,
                self.acc_up_m_s2, self.acc_down_m_s2, self.jerk_m_s3, self.error_max_m,
            )
        )  # fmt: skip
        object.__setattr__(self, "axes", axes)
        object.__setattr__(self, "vehicle", vehicle)
        object.__setattr__(self, "limits", limits)

    @classmethod
    def from_params(cls, params: list[ParamStore]) -> NavGains:
        """Read the parameters of every vehicle."""

        def col(name: str) -> np.ndarray:
            return param_column(params, name)

        def axes(suffix: str) -> np.ndarray:
            names = (f"MPC_XY_{suffix}", f"MPC_XY_{suffix}", f"MPC_Z_{suffix}")
            return np.stack([col(name) for name in names], axis=1)

        return cls(
            pos_p=axes("P"),
            vel_p=axes("VEL_P_ACC"),
            vel_i=axes("VEL_I_ACC"),
            vel_d=axes("VEL_D_ACC"),
            tilt_max_rad=np.radians(col("MPC_TILTMAX_AIR")),
            acc_hor_max_m_s2=col("MPC_ACC_HOR"),
            speed_xy_m_s=col("MPC_XY_VEL_MAX"),
            speed_up_m_s=col("MPC_Z_VEL_MAX_UP"),
            speed_down_m_s=col("MPC_Z_VEL_MAX_DN"),
            acc_up_m_s2=col("MPC_ACC_UP_MAX"),
            acc_down_m_s2=col("MPC_ACC_DOWN_MAX"),
            jerk_m_s3=col("MPC_JERK_AUTO"),
            error_max_m=col("MPC_XY_ERR_MAX"),
            yaw_rate_auto_rad_s=np.radians(col("MPC_YAWRAUTO_MAX")),
        )


@dataclass
class NavState:
    """What the navigation loop keeps between ticks and writes, (N, ...) arrays, local NED."""

    velocity_integral: np.ndarray
    """(N, 3) velocity-loop integrators, m/s²."""
    velocity_sp_m_s: np.ndarray
    """(N, 3) velocity setpoints of the last tick, m/s."""
    prev_velocity_m_s: np.ndarray
    """(N, 3) velocity of the last tick (derivative on measurement), m/s."""
    trajectory_position_m: np.ndarray
    """(N, 3) smoothed setpoint: position, m."""
    trajectory_velocity_m_s: np.ndarray
    """(N, 3) smoothed setpoint: velocity, m/s."""
    trajectory_acceleration_m_s2: np.ndarray
    """(N, 3) smoothed setpoint: acceleration, m/s²."""
    smoothing: np.ndarray
    """(N,) vehicles whose controller tracked the trajectory at the last tick."""
    q_sp: np.ndarray
    """(N, 4) attitude setpoints, wxyz."""
    thrust: np.ndarray
    """(N,) collective thrust setpoints, 0..1 (0 while inactive)."""
    overridden: np.ndarray
    """(N,) offboard attitude / rate setpoints replaced the position loop's output."""
    yaw_sp_rad: np.ndarray
    """(N,) heading setpoint flown at the last tick, rad (auto modes: rate-limited)."""

    @classmethod
    def zeros(cls, n: int) -> NavState:
        """State of n vehicles at rest, level."""
        return cls(
            velocity_integral=np.zeros((n, 3)),
            velocity_sp_m_s=np.zeros((n, 3)),
            prev_velocity_m_s=np.zeros((n, 3)),
            trajectory_position_m=np.zeros((n, 3)),
            trajectory_velocity_m_s=np.zeros((n, 3)),
            trajectory_acceleration_m_s2=np.zeros((n, 3)),
            smoothing=np.zeros(n, dtype=bool),
            q_sp=np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)),
            thrust=np.zeros(n),
            overridden=np.zeros(n, dtype=bool),
            yaw_sp_rad=np.full(n, np.nan),
        )


def limit_yaw_rate(
    target_rad: np.ndarray,
    previous_rad: np.ndarray,
    heading_rad: np.ndarray,
    rate_max_rad_s: np.ndarray,
    dt_s: float,
    limit: np.ndarray,
) -> np.ndarray:
    """Heading setpoints moved towards ``target_rad`` by at most ``rate_max_rad_s`` dt.

    PX4's FlightTaskAuto::_limitYawRate (MPC_YAWRAUTO_MAX): where ``limit``, the setpoint turns
    from the one flown last (from the vehicle's ``heading_rad`` when there is none) the short
    way round; elsewhere, and for a NaN target (hold the heading), the target passes unchanged.
    """
    previous = np.where(np.isfinite(previous_rad), previous_rad, heading_rad)
    step = np.angle(np.exp(1j * (target_rad - previous)))
    bound = rate_max_rad_s * dt_s
    limited = np.angle(np.exp(1j * (previous + np.clip(step, -bound, bound))))
    use = limit & np.isfinite(target_rad) & np.isfinite(previous)
    return np.where(use, limited, target_rad)


class NavLoop:
    """Trajectory smoothing and position control of N vehicles, one compiled call per tick."""

    def __init__(self, n: int, gains: NavGains) -> None:
        self.gains = gains
        self.state = NavState.zeros(n)

    def step(
        self,
        *,
        setpoint: PositionSetpoint,
        smooth: np.ndarray,
        hover_thrust: np.ndarray,
        position_ned_m: np.ndarray,
        velocity_ned_m_s: np.ndarray,
        dt_s: float,
        active: np.ndarray,
        attitude_target: np.ndarray,
        thrust_target: np.ndarray,
        rate_integral: np.ndarray,
        heading_rad: np.ndarray | None = None,
    ) -> None:
        """One navigation tick of every vehicle: writes ``state`` (q_sp, thrust, overridden).

        ``smooth`` (N,): the commander asks for a smoothed target (auto modes); a vehicle that
        starts smoothing restarts the trajectory at its own position and velocity.
        ``hover_thrust`` (N,) 0..1 scales the thrust. Inactive vehicles get no thrust and restart
        their position controller and their rate integrators (``rate_integral``, the inner
        loop's, (N, 3)). Where ``thrust_target`` (N,) is finite (offboard attitude or rate
        setpoints) it replaces the thrust (clipped to 0..1), a finite ``attitude_target`` (N, 4)
        wxyz the attitude setpoint, and the position controller restarts. In auto modes the
        heading setpoint turns at most MPC_YAWRAUTO_MAX, starting from the vehicle's estimated
        ``heading_rad`` (N,) when a vehicle enters an auto mode (no limit without headings).
        """
        s, g, sp = self.state, self.gains, setpoint
        yaw = sp.yaw_rad
        if heading_rad is not None and g.yaw_rate_auto_rad_s is not None:
            auto = smooth & active
            previous = np.where(s.smoothing & auto, s.yaw_sp_rad, np.nan)
            yaw = limit_yaw_rate(yaw, previous, heading_rad, g.yaw_rate_auto_rad_s, dt_s, auto)
        s.yaw_sp_rad[:] = yaw
        nav_kernel(
            sp.position_ned_m, sp.velocity_ff_m_s, yaw, sp.max_speed_xy_m_s,
            sp.max_speed_up_m_s, sp.max_speed_down_m_s, sp.acceleration_ff_m_s2, sp.smoothed,
            g.limits, s.trajectory_position_m, s.trajectory_velocity_m_s,
            s.trajectory_acceleration_m_s2, smooth, s.smoothing, g.axes, g.vehicle,
            hover_thrust, s.velocity_integral, s.velocity_sp_m_s, s.prev_velocity_m_s,
            rate_integral, position_ned_m, velocity_ned_m_s, dt_s, active, attitude_target,
            thrust_target, s.q_sp, s.thrust, s.overridden,
        )  # fmt: skip

    def trajectory_state(self, i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """Vehicle i's smoothed setpoint (position, velocity, acceleration), None if unsmoothed."""
        s = self.state
        if not s.smoothing[i]:
            return None
        pos, vel = s.trajectory_position_m, s.trajectory_velocity_m_s
        return pos[i], vel[i], s.trajectory_acceleration_m_s2[i]
