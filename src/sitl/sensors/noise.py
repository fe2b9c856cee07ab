"""Additive sensor error processes, vectorised over the fleet.

The biased white-noise model is the one of PX4's Gazebo IMU plugin (after Maybeck): white noise of
spectral density ``sigma_w`` sampled by an integrating sensor over ``dt`` (standard deviation
``sigma_w / sqrt(dt)``), plus a first-order Gauss-Markov bias with random-walk density ``sigma_b``
and correlation time ``tau``, discretised exactly,

    b_k+1 = exp(-dt / tau) b_k + sigma_b sqrt(tau / 2 (1 - exp(-2 dt / tau))) n_k,

plus a constant turn-on bias drawn once from N(0, sigma_on^2).
"""

from __future__ import annotations

import numpy as np


class BiasedWhiteNoise:
    """White noise + Gauss-Markov bias + turn-on bias on an array of sensor channels.

    Parameters are scalars or arrays that broadcast against ``shape`` (e.g. shape ``(N, 2, 3)``
    with parameters of shape ``(2, 1)`` for an accelerometer and a gyroscope on three axes).
    """

    def __init__(
        self,
        shape: tuple[int, ...],
        noise_density: float | np.ndarray,
        random_walk: float | np.ndarray,
        bias_correlation_time_s: float | np.ndarray,
        turn_on_bias_sigma: float | np.ndarray,
        rng: np.random.Generator,
    ) -> None:
        tau = np.asarray(bias_correlation_time_s, dtype=float)
        if not np.all(tau > 0.0):
            raise ValueError(f"bias correlation time must be positive, got {tau}")
        self._shape = shape
        self._density = np.asarray(noise_density, dtype=float)
        self._random_walk = np.asarray(random_walk, dtype=float)
        self._tau = tau
        self._rng = rng
        self.turn_on_bias = np.asarray(turn_on_bias_sigma) * rng.standard_normal(shape)
        """Constant bias drawn at start-up, sensor units."""
        self.bias = np.zeros(shape)
        """Slowly varying (Gauss-Markov) bias, sensor units."""
        self._dt_s = -1.0
        self._phi = self._sigma_bias = self._sigma_white = np.zeros(())

    def sample(self, dt_s: float) -> np.ndarray:
        """Advance the bias by ``dt_s`` and return the total error of one sample (a new array)."""
        if dt_s != self._dt_s:
            self._dt_s = dt_s
            self._phi = np.exp(-dt_s / self._tau)
            self._sigma_bias = self._random_walk * np.sqrt(
                self._tau / 2.0 * -np.expm1(-2.0 * dt_s / self._tau)
            )
            self._sigma_white = self._density / np.sqrt(dt_s)
        z = self._rng.standard_normal((2, *self._shape))
        bias = self.bias
        bias *= self._phi
        z[0] *= self._sigma_bias
        bias += z[0]
        error = z[1]
        error *= self._sigma_white
        error += bias
        error += self.turn_on_bias
        return error


class GaussMarkov:
    """First-order Gauss-Markov process with a given stationary standard deviation per element.

    Starts from its stationary distribution, so its magnitude is right from the first sample.
    """

    def __init__(
        self, sigma: np.ndarray, correlation_time_s: float, rng: np.random.Generator
    ) -> None:
        if not correlation_time_s > 0.0:
            raise ValueError(f"correlation time must be positive, got {correlation_time_s}")
        self._sigma = np.asarray(sigma, dtype=float)
        self._tau = correlation_time_s
        self._rng = rng
        self.value = self._sigma * rng.standard_normal(self._sigma.shape)
        """Current value, same shape as ``sigma``."""

    def advance(self, dt_s: float) -> np.ndarray:
        """Advance by ``dt_s`` (exact discretisation) and return the new value."""
        phi = np.exp(-dt_s / self._tau)
        self.value *= phi
        self.value += (
            self._sigma * np.sqrt(-np.expm1(-2.0 * dt_s / self._tau))
        ) * self._rng.standard_normal(self._sigma.shape)
        return self.value
