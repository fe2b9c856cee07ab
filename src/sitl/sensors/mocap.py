"""An emulated indoor positioning system (optical motion capture) tracking every vehicle.

Poses are measured in one fixed frame for all vehicles: local NED with its origin at the world
origin (ENU 0, 0, 0 of the scene), attitude body FRD -> NED. Each sample of N vehicles:

- position: truth + white noise, ``position_noise_sigma_m`` per axis;
- attitude: truth rotated by small white Euler-angle errors, ``attitude_noise_sigma_rad`` each;
- latency: released ``latency_ms`` after it was measured (camera exposure, marker fitting and the
  network), stamped with its measurement time.

The defaults are assumptions of the order of commercial optical systems (sub-millimetre to
millimetre jitter, latencies of a few milliseconds); they are not a particular product's figures.
The noise comes from the generator passed in (the world spawns it from its own): one draw of
shape (N, 6) per sample.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from sitl import frames


@dataclass(frozen=True)
class MocapParams:
    """Quality of the motion-capture system."""

    position_noise_sigma_m: float = 0.001
    """White position noise per axis, 1 sigma, m."""
    attitude_noise_sigma_rad: float = 0.005
    """White noise on roll, pitch and yaw, 1 sigma, rad."""
    latency_ms: float = 10.0
    """Time from measurement to release, ms."""

    def __post_init__(self) -> None:
        for name in ("position_noise_sigma_m", "attitude_noise_sigma_rad", "latency_ms"):
            if not getattr(self, name) >= 0.0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")


@dataclass(frozen=True)
class MocapSample:
    """Poses of N vehicles at one instant, in the motion-capture frame (local NED)."""

    time_s: float
    """Measurement time, simulation clock, s."""
    position_ned_m: np.ndarray
    """Position of each vehicle's centre of mass, (N, 3), m."""
    quaternion_wxyz: np.ndarray
    """Attitude body FRD -> NED, (N, 4)."""
    position_sigma_m: float
    """1-sigma position noise per axis of this system, m."""
    attitude_sigma_rad: float
    """1-sigma noise per Euler angle, rad."""


class Mocap:
    """Motion capture of N vehicles.

    :meth:`measure` queues a sample, :meth:`release` returns those whose latency has passed.
    """

    def __init__(self, params: MocapParams, n_vehicles: int, rng: np.random.Generator) -> None:
        self.params = params
        self._n = n_vehicles
        self._rng = rng
        self._sigma = np.array(
            [params.position_noise_sigma_m] * 3 + [params.attitude_noise_sigma_rad] * 3
        )
        self._queue: deque[MocapSample] = deque()

    def measure(
        self, time_s: float, position_enu_m: np.ndarray, quaternion_xyzw: np.ndarray
    ) -> MocapSample:
        """Noisy poses of the true ENU positions (N, 3) and PyBullet attitudes (N, 4); queued."""
        noise = self._sigma * self._rng.standard_normal((self._n, 6))
        position = frames.enu_to_ned(position_enu_m) + noise[:, :3]
        euler = frames.euler_from_quat_ned_frd(frames.quat_enu_flu_to_ned_frd(quaternion_xyzw))
        euler = euler + noise[:, 3:]
        q = frames.quat_from_euler_ned_frd(euler[:, 0], euler[:, 1], euler[:, 2]).T
        q = np.where(q[:, :1] < 0.0, -q, q)
        sample = MocapSample(
            time_s=time_s,
            position_ned_m=position,
            quaternion_wxyz=q,
            position_sigma_m=self.params.position_noise_sigma_m,
            attitude_sigma_rad=self.params.attitude_noise_sigma_rad,
        )
        self._queue.append(sample)
        return sample

    def release(self, time_s: float, latency_s: float) -> list[MocapSample]:
        """Queued samples at least ``latency_s`` old at ``time_s``, oldest first."""
        out = []
        queue = self._queue
        while queue and queue[0].time_s <= time_s - latency_s + 1e-9:
            out.append(queue.popleft())
        return out
