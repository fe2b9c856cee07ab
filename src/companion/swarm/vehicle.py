"""What a companion program sees of its vehicle at swarm scale (the kinematic adapter's API).

The full stack hands a program a MAVSDK ``System``; the swarm-scale engine hands it a
``SwarmVehicle``: the same commands a mission-flying companion gives (take off, fly these
waypoints, land) and the same observations (position, progress, what the camera detected), in
the world's ENU frame and simulation time, without MAVLink. ``neighbours()`` stands for the mesh
radio's neighbour table (the nodes whose beacons it hears, nearest first).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np


@dataclass(frozen=True)
class Detection:
    """A target the vehicle's camera saw (a world target or a Poisson event)."""

    name: str
    """The target's name (``spill_3``, ``event_17``)."""
    position_enu_m: tuple[float, float]
    """Where it lies, east and north, m."""
    appear_s: float
    """When it appeared, simulated s."""
    time_s: float
    """When this vehicle first saw it, simulated s."""


class SwarmVehicle(Protocol):
    """One kinematic vehicle, as its companion program commands and observes it."""

    index: int
    """0-based vehicle index in the fleet."""
    node_id: str
    """The vehicle's messaging node id."""

    @property
    def time_s(self) -> float:
        """Simulation time, s."""

    @property
    def position_enu_m(self) -> np.ndarray:
        """(3,) true position, world ENU, m (GNSS and estimator errors are not modelled)."""

    @property
    def home_enu_m(self) -> np.ndarray:
        """(3,) where the vehicle started, world ENU, m."""

    @property
    def airborne(self) -> bool:
        """Off the ground."""

    @property
    def battery_remaining_pct(self) -> float:
        """Charge remaining in the pack, 0..100 % (MAVSDK's ``Battery.remaining_percent``).

        NaN when no battery is modelled.
        """

    @property
    def path_index(self) -> int:
        """Index of the waypoint of the current path the vehicle flies to."""

    @property
    def path_done(self) -> bool:
        """At the last waypoint of its path (or resting)."""

    def takeoff(self, height_m: float, climb_m_s: float | None = None) -> None:
        """Arm and climb to ``height_m`` above the ground where it stands."""

    def fly_path(self, waypoints_enu_m: np.ndarray, speed_m_s: float) -> None:
        """Fly through ``waypoints_enu_m`` ((K, 3), ENU m) at ``speed_m_s``; stop at the last."""

    def land(self) -> None:
        """Descend where it is, touch down, disarm."""

    def neighbours(self) -> list[str]:
        """Node ids of the nearest vehicles within radio range, nearest first."""

    def detections(self) -> list[Detection]:
        """Targets the camera saw since the last call (each target once per vehicle)."""


class SwarmProgram(Protocol):
    """A companion program at swarm scale: decides at the engine's decision rate."""

    def decide(self, now_s: float) -> None:
        """Read messages and observations, command the vehicle (no blocking, no I/O)."""

    error: str | None
    """Why the program gave up (its vehicle then lands); None while it has not."""

    @property
    def done(self) -> bool:
        """The program has finished (its vehicle landed, or it gave up)."""

    def metrics(self) -> dict[str, tuple[Any, str]]:
        """The program's results as ``name: (value, unit)`` (its ``result.json`` metrics)."""
