"""Body-rate PID control (PX4 mc_rate_control), batched over the fleet."""

from __future__ import annotations

import numpy as np

from autopilot_emu.control.rate_kernel import rate_pid_kernel


class RateController:
    """PID on body rates with derivative on measurement; outputs normalised torque (-1..1)."""

    integrator_limit = 0.3

    def __init__(self, n: int) -> None:
        self.integral = np.zeros((n, 3))
        self._prev_rates = np.zeros((n, 3))

    def reset(self, mask: np.ndarray) -> None:
        """Clear integrators (on arming, on the ground)."""
        self.integral[mask] = 0.0

    def update(
        self,
        rates: np.ndarray,
        rate_sp: np.ndarray,
        kp: np.ndarray,
        ki: np.ndarray,
        kd: np.ndarray,
        dt_s: float,
        integrate: np.ndarray,
    ) -> np.ndarray:
        """Torque command for rates (N, 3) given setpoints; ``integrate`` masks the I term."""
        torque = np.empty_like(self.integral)
        rate_pid_kernel(
            rates, rate_sp, kp, ki, kd, float(dt_s), np.asarray(integrate, dtype=np.bool_),
            float(self.integrator_limit), self.integral, self._prev_rates, torque,
        )  # fmt: skip
        return torque
