"""Accelerometer and gyroscope of N vehicles, body FRD, as HIL_SENSOR reports them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sitl.physics.earth import GRAVITY_M_S2
from sitl.sensors.noise import BiasedWhiteNoise
from sitl.sensors.noise_kernel import imu_sample


@dataclass(frozen=True)
class ImuParams:
    """Noise of one IMU (PX4 Gazebo ``gazebo_imu_plugin`` parameters)."""

    gyro_noise_density_rad_s_sqrt_hz: float
    """Gyroscope white-noise density, rad/s/sqrt(Hz)."""
    gyro_random_walk_rad_s2_sqrt_hz: float
    """Gyroscope bias random-walk density, rad/s^2/sqrt(Hz)."""
    gyro_bias_correlation_time_s: float
    """Gyroscope bias correlation time, s."""
    gyro_turn_on_bias_sigma_rad_s: float
    """Gyroscope turn-on bias standard deviation before ``turn_on_bias_scale``, rad/s."""
    accel_noise_density_m_s2_sqrt_hz: float
    """Accelerometer white-noise density, m/s^2/sqrt(Hz)."""
    accel_random_walk_m_s3_sqrt_hz: float
    """Accelerometer bias random-walk density, m/s^3/sqrt(Hz)."""
    accel_bias_correlation_time_s: float
    """Accelerometer bias correlation time, s."""
    accel_turn_on_bias_sigma_m_s2: float
    """Accelerometer turn-on bias standard deviation before ``turn_on_bias_scale``, m/s^2."""
    turn_on_bias_scale: float
    """Factor on both turn-on bias sigmas: the residual after PX4's sensor calibration, 1."""


class Imu:
    """IMUs of N vehicles at the centre of mass.

    The specific force is the mean acceleration over the interval since the previous sample (the
    velocity difference, which is what an integrating accelerometer with anti-aliasing sees) minus
    gravity, rotated into body FRD with the attitude at the sample time. The first sample, having
    no interval, reports zero acceleration (at rest: the reaction to gravity only).
    """

    def __init__(self, params: ImuParams, n_vehicles: int, rng: np.random.Generator) -> None:
        self.params = params
        scale = params.turn_on_bias_scale
        # Channel 0: accelerometer, channel 1: gyroscope; each on three axes.
        self.noise = BiasedWhiteNoise(
            (n_vehicles, 2, 3),
            np.array(
                [
                    [params.accel_noise_density_m_s2_sqrt_hz],
                    [params.gyro_noise_density_rad_s_sqrt_hz],
                ]
            ),
            np.array(
                [[params.accel_random_walk_m_s3_sqrt_hz], [params.gyro_random_walk_rad_s2_sqrt_hz]]
            ),
            np.array(
                [[params.accel_bias_correlation_time_s], [params.gyro_bias_correlation_time_s]]
            ),
            scale
            * np.array(
                [[params.accel_turn_on_bias_sigma_m_s2], [params.gyro_turn_on_bias_sigma_rad_s]]
            ),
            rng,
        )
        self._last_velocity_enu = np.zeros((n_vehicles, 3))
        self._first = True

    def sample(
        self,
        rotation_flu_to_enu: np.ndarray,
        velocity_enu_m_s: np.ndarray,
        angular_velocity_enu_rad_s: np.ndarray,
        dt_s: float,
        out: np.ndarray,
    ) -> None:
        """Measure specific force (m/s^2) and angular rate (rad/s) in body FRD into ``out``.

        Args:
            rotation_flu_to_enu: body attitudes, (N, 3, 3).
            velocity_enu_m_s: centre-of-mass velocities now, (N, 3).
            angular_velocity_enu_rad_s: angular velocities in world axes now, (N, 3).
            dt_s: time since the previous sample, s.
            out: ``(N, 2, 3)``: ``[:, 0]`` specific force, ``[:, 1]`` angular rate.
        """
        imu_sample(
            rotation_flu_to_enu,
            velocity_enu_m_s,
            self._last_velocity_enu,
            angular_velocity_enu_rad_s,
            dt_s,
            self._first,
            GRAVITY_M_S2,
            self.noise.sample(dt_s),
            out,
        )
        self._first = False
