"""A navigation loop of n vehicles with PX4's default gains, and its inputs, for the tests."""

from __future__ import annotations

import numpy as np

from autopilot_emu.control.nav import NavGains, NavLoop, PositionSetpoint

DT = 0.02


def px4_gains(n: int, **limits: float) -> NavGains:
    """PX4's multicopter defaults (MPC_*), with the named trajectory limits replaced."""
    f = lambda v: np.full(n, float(v))  # noqa: E731
    t3 = lambda xyz: np.tile(np.asarray(xyz, dtype=float), (n, 1))  # noqa: E731
    values = {
        "tilt_max_deg": 45.0, "acc_hor_max_m_s2": 3.0, "speed_xy_m_s": 12.0, "speed_up_m_s": 3.0,
        "speed_down_m_s": 1.5, "acc_up_m_s2": 4.0, "acc_down_m_s2": 3.0, "jerk_m_s3": 4.0,
        "error_max_m": 2.0,
    } | limits  # fmt: skip
    return NavGains(
        pos_p=t3([0.95, 0.95, 1.0]),
        vel_p=t3([1.8, 1.8, 4.0]),
        vel_i=t3([0.4, 0.4, 2.0]),
        vel_d=t3([0.2, 0.2, 0.0]),
        tilt_max_rad=np.radians(f(values.pop("tilt_max_deg"))),
        **{name: f(v) for name, v in values.items()},
    )


class Nav:
    """A NavLoop of n vehicles hovering at the origin, and its inputs."""

    def __init__(self, n: int = 1, **limits: float) -> None:
        self.n = n
        self.loop = NavLoop(n, px4_gains(n, **limits))
        self.sp = PositionSetpoint.hold(n)
        self.sp.position_ned_m[:] = 0.0
        self.smooth = np.zeros(n, dtype=bool)
        self.hover = np.full(n, 0.5)
        self.position = np.zeros((n, 3))
        self.velocity = np.zeros((n, 3))
        self.active = np.ones(n, dtype=bool)
        self.att_q = np.full((n, 4), np.nan)
        self.att_thrust = np.full(n, np.nan)
        self.rate_integral = np.zeros((n, 3))

    @property
    def state(self):
        return self.loop.state

    def run(self) -> None:
        """One navigation tick."""
        self.loop.step(
            setpoint=self.sp,
            smooth=self.smooth,
            hover_thrust=self.hover,
            position_ned_m=self.position,
            velocity_ned_m_s=self.velocity,
            dt_s=DT,
            active=self.active,
            attitude_target=self.att_q,
            thrust_target=self.att_thrust,
            rate_integral=self.rate_integral,
        )
