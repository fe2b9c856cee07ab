"""PX4's gyro low-pass filters for the rate controller: IMU_GYRO_CUTOFF and IMU_DGYRO_CUTOFF.

PX4's vehicle_angular_velocity (src/modules/sensors/vehicle_angular_velocity) gives the rate
controller two signals: the angular velocity through a second-order Butterworth low-pass at
IMU_GYRO_CUTOFF (default 40 Hz), and the angular acceleration, the time derivative of that
filtered velocity through a second-order Butterworth at IMU_DGYRO_CUTOFF (default 20 Hz), which
the D term acts on. Both only feed the controllers, never the estimator. A cutoff of 0 (or at or
above half the sample rate, where a Butterworth cannot be built) passes the signal through
unfiltered, as PX4 disables the filter.

Coefficients here (scipy's bilinear-transform Butterworth, with the cutoff pre-warped as PX4's
LowPassFilter2p does); the per-sample filtering is compiled in ``gyro_filter_kernel``.
"""

from __future__ import annotations

import numpy as np
from scipy import signal

PASS_THROUGH = np.array([1.0, 0.0, 0.0, 0.0, 0.0])
"""Coefficients (b0, b1, b2, a1, a2) of a filter that returns its input."""


def butterworth2(cutoff_hz: float, sample_rate_hz: float) -> np.ndarray:
    """(b0, b1, b2, a1, a2) of a second-order Butterworth low-pass, a0 = 1.

    Pass-through for a cutoff <= 0 or >= half the sample rate (PX4: filter disabled).
    """
    if not (sample_rate_hz > 0.0):
        raise ValueError(f"sample rate must be positive, got {sample_rate_hz} Hz")
    if not (0.0 < cutoff_hz < 0.5 * sample_rate_hz):
        return PASS_THROUGH.copy()
    b, a = signal.butter(2, cutoff_hz, btype="low", fs=sample_rate_hz)
    return np.array([b[0], b[1], b[2], a[1], a[2]], dtype=float)


def rate_filter_coefficients(
    gyro_cutoff_hz: np.ndarray, dgyro_cutoff_hz: np.ndarray, sample_rate_hz: float
) -> np.ndarray:
    """(2, N, 5) coefficients of N vehicles: [0] angular velocity, [1] angular acceleration."""
    gyro = np.array([butterworth2(float(c), sample_rate_hz) for c in gyro_cutoff_hz])
    dgyro = np.array([butterworth2(float(c), sample_rate_hz) for c in dgyro_cutoff_hz])
    return np.stack((gyro.reshape(-1, 5), dgyro.reshape(-1, 5)))


def pass_through(n: int) -> np.ndarray:
    """(2, N, 5) coefficients that leave both signals unfiltered."""
    return np.tile(PASS_THROUGH, (2, n, 1))
