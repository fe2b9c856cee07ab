"""Body-rate PID control (PX4 mc_rate_control), batched over the fleet."""

from __future__ import annotations

import numpy as np


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
        err = rate_sp - rates
        torque = kp * err + self.integral - kd * ((rates - self._prev_rates) * (1.0 / dt_s))
        self._prev_rates = rates
        step = (ki * dt_s) * err
        if not integrate.all():
            step *= integrate[:, None]
        lim = self.integrator_limit
        self.integral = np.minimum(np.maximum(self.integral + step, -lim), lim)
        return np.minimum(np.maximum(torque, -1.0), 1.0)
