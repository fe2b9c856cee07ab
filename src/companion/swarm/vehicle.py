"""What a companion program sees of its vehicle at swarm scale (the kinematic adapter's API).

The full stack hands a program a MAVSDK ``System``; the swarm-scale engine hands it a
``SwarmVehicle``: the same commands a mission-flying companion gives (take off, fly these
waypoints, land) and the same observations (position, progress, what the camera detected), in
the world's ENU frame and simulation time, without MAVLink. ``neighbours()`` stands for the mesh
radio's neighbour table (the nodes whose beacons it hears, nearest first); ``sense(radius)`` for an
obstacle sensor that sees solids and other vehicles around it (seed 001's R_s); ``set_velocity``
and ``goto`` for MAVSDK's offboard velocity and position setpoints.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal, Protocol

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


@dataclass(frozen=True)
class Sensed:
    """Something near the vehicle (``SwarmVehicle.sense``): a world solid or another vehicle."""

    kind: Literal["solid", "vehicle"]
    name: str
    """The solid's name (``obstacle_3``, ``mover_0``) or the vehicle's node id."""
    position_enu_m: tuple[float, float, float]
    """A solid's point nearest to this vehicle, or the other vehicle's centre, ENU m."""
    velocity_enu_m_s: tuple[float, float, float]
    """Its velocity, ENU m/s (zeros for a static solid)."""
    distance_m: float
    """Clearance between the bodies, m: from this vehicle's sphere (its airframe's diameter) to
    the solid's surface, or to the other vehicle's sphere (centre distance minus both radii).
    Negative: in contact (a collision, as the report counts them)."""


class SwarmVehicle(Protocol):
    """One kinematic vehicle, as its companion program commands and observes it."""

    index: int
    """0-based vehicle index in the fleet."""
    node_id: str
    """The vehicle's messaging node id."""
    priority: int
    """The scenario's priority of the vehicle (``fleet[].priority``; default its vehicle number,
    1-based, so that every vehicle has a distinct one); the harness does not interpret it."""

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

    def set_velocity(self, velocity_enu_m_s: np.ndarray) -> None:
        """Hold this ENU velocity (m/s) until another command, within the vehicle's limits.

        As an offboard velocity setpoint: the speed and course change at most as the kinematic
        limits allow; a horizontal speed above the limit is scaled down, the vertical speed is
        clipped to the climb and descent rates. ``path_done`` is False meanwhile.
        """

    def goto(self, position_enu_m: np.ndarray, speed_m_s: float) -> None:
        """Fly straight to ``position_enu_m`` (ENU m) at ``speed_m_s`` and hold there.

        As an offboard position setpoint; the same as ``fly_path`` with one waypoint.
        """

    def land(self) -> None:
        """Descend where it is, touch down, disarm."""

    def sense(self, radius_m: float) -> list[Sensed]:
        """The world's solids and the airborne vehicles within ``radius_m`` of its body, now.

        Within: ``Sensed.distance_m <= radius_m`` (clearance between the bodies); nearest first.
        Solids where they are at the current simulated time (moving ones too), heights
        included (a vehicle above a solid's top sees it only within ``radius_m`` of the top).
        """

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
