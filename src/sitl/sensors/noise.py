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

from sitl.sensors.noise_kernel import biased_white_noise


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
        tau = np.broadcast_to(np.asarray(bias_correlation_time_s, dtype=float), shape)
        if not np.all(tau > 0.0):
            raise ValueError(f"bias correlation time must be positive, got {tau}")
        # Parameters expanded to the full shape: same-shape ufuncs are ~3x cheaper than
        # broadcasting ones on small arrays.
        self._shape = shape
        self._density = np.broadcast_to(np.asarray(noise_density, dtype=float), shape).copy()
        self._random_walk = np.broadcast_to(np.asarray(random_walk, dtype=float), shape).copy()
        self._tau = tau.copy()
        self._rng = rng
        self.turn_on_bias = np.asarray(turn_on_bias_sigma) * rng.standard_normal(shape)
        """Constant bias drawn at start-up, sensor units."""
        self.bias = np.zeros(shape)
        """Slowly varying (Gauss-Markov) bias, sensor units."""
        self._dt_s = -1.0
        self._phi = self._sigma_bias = self._sigma_white = np.zeros(shape)
        self._z = np.zeros((2, *shape))
        self._error = np.zeros(shape)
        # Flat views for the compiled kernel (same memory).
        self._flat = (
            self._z.reshape(-1),
            self.bias.reshape(-1),
            self.turn_on_bias.reshape(-1),
            self._error.reshape(-1),
        )
        self._coefficients: tuple[np.ndarray, np.ndarray, np.ndarray] = ()  # set with dt

    def sample(self, dt_s: float) -> np.ndarray:
        """Advance the bias by ``dt_s``; return the total error of one sample (reused buffer)."""
        if dt_s != self._dt_s:
            self._dt_s = dt_s
            self._phi = np.exp(-dt_s / self._tau)
            self._sigma_bias = self._random_walk * np.sqrt(
                self._tau / 2.0 * -np.expm1(-2.0 * dt_s / self._tau)
            )
            self._sigma_white = self._density / np.sqrt(dt_s)
            self._coefficients = (
                self._phi.reshape(-1),
                self._sigma_bias.reshape(-1),
                self._sigma_white.reshape(-1),
            )
        self._rng.standard_normal(out=self._z)
        z, bias, turn_on, error = self._flat
        phi, sigma_bias, sigma_white = self._coefficients
        biased_white_noise(z, bias, phi, sigma_bias, sigma_white, turn_on, error)
        return self._error


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
