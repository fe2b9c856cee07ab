"""Flying a waypoint path with offboard velocity setpoints (pure, no I/O).

What a companion streams to fly a path as the swarm engine's kinematic vehicles fly theirs
(``sitl.kinematic_fleet``): fly-through waypoints passed within ``acceptance_m`` horizontally and
``height_tolerance_m`` vertically (PX4's NAV_ACC_RAD default of 2 m, and the kinematic fleet's
rule), at a commanded speed, stopping at the last one. Each leg runs from where the vehicle was
when it took the waypoint to the waypoint (the vehicle heads straight for its next waypoint, as a
kinematic vehicle does; it does not fly back to the corner it cut).

The setpoint (:meth:`PathFollower.velocity`) is a velocity: along the leg at the speed profile,
plus ``gain_1_s`` times the vector from the vehicle to its projection on the leg (back onto the
line, heights included). Velocity setpoints, not position + velocity feed-forward: the autopilot
flies a velocity setpoint as given, whereas a position setpoint's speed is the autopilot's
(swarmsitl's emulator caps it at the speed that stops at the position with MPC_ACC_HOR; PX4
adds the position error's P term to the feed-forward); the follower closes the position loop
itself at the setpoint rate. The speed profile: ``speed_m_s``, no faster than
``sqrt(v_next^2 + 2 a d)`` before a waypoint (``a`` = ``brake_m_s2``, ``d`` the distance left,
``v_next`` the speed for the turn onto the next leg, ``speed cos(turn)``, none for a turn of 90
deg or more), and at the last waypoint also no faster than ``gain_1_s d`` (it settles on it).
Abreast of a waypoint or past it without having reached it (off the leg by more than the
acceptance radius, or the height tolerance), the velocity is ``gain_1_s`` times the way to it.
ENU, m, m/s; the MAVLink adapter converts to NED.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FollowParams:
    """How the path is flown."""

    acceptance_m: float = 2.0
    """Horizontal radius within which a fly-through waypoint is passed, m (PX4's NAV_ACC_RAD)."""
    height_tolerance_m: float = 1.0
    """A waypoint counts as reached only within this height of it, m (the kinematic fleet's)."""
    brake_m_s2: float = 2.0
    """Deceleration the speed profile assumes before a waypoint, m/s^2 (below the autopilot's
    MPC_ACC_HOR, so that it can follow)."""
    gain_1_s: float = 1.0
    """Velocity per metre off the leg (and, at the last waypoint, short of it), 1/s (PX4's
    MPC_XY_P is 0.95)."""

    def __post_init__(self) -> None:
        for name in ("acceptance_m", "height_tolerance_m", "brake_m_s2", "gain_1_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name}: {value!r} must be a positive number")


class PathFollower:
    """One path being flown: which waypoint is current, and the velocity towards it."""

    def __init__(
        self,
        waypoints_enu_m: np.ndarray,
        speed_m_s: float,
        here_enu_m: np.ndarray,
        params: FollowParams = FollowParams(),
    ) -> None:
        self.waypoints = np.asarray(waypoints_enu_m, dtype=float).reshape(-1, 3)
        if not len(self.waypoints):
            raise ValueError("a path needs at least one waypoint")
        if not (math.isfinite(speed_m_s) and speed_m_s > 0):
            raise ValueError(f"speed_m_s: {speed_m_s!r} must be a positive number")
        self.speed_m_s = float(speed_m_s)
        self.params = params
        self.index = 0
        """Index of the waypoint being flown to."""
        self._leg_start = np.asarray(here_enu_m, dtype=float).copy()
        self.see(here_enu_m)

    @property
    def last(self) -> bool:
        """Flying to the last waypoint."""
        return self.index == len(self.waypoints) - 1

    def _reached(self, here: np.ndarray, k: int) -> bool:
        d = self.waypoints[k] - here
        return bool(
            math.hypot(d[0], d[1]) < self.params.acceptance_m
            and abs(d[2]) < self.params.height_tolerance_m
        )

    def see(self, here_enu_m: np.ndarray) -> None:
        """A new position: pass the current waypoint when it is reached (one per call)."""
        here = np.asarray(here_enu_m, dtype=float)
        if not self.last and self._reached(here, self.index):
            self.index += 1
            self._leg_start = here.copy()

    def done(self, here_enu_m: np.ndarray) -> bool:
        """At the last waypoint (within the acceptance radius and height tolerance)."""
        return self.last and self._reached(np.asarray(here_enu_m, dtype=float), self.index)

    def _turn_speed(self) -> float:
        """Speed at which to take the current (not last) waypoint, m/s."""
        k = self.index
        a = self.waypoints[k] - self._leg_start
        b = self.waypoints[k + 1] - self.waypoints[k]
        na, nb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
        if na < 1e-9 or nb < 1e-9:
            return self.speed_m_s
        return self.speed_m_s * max(float(a @ b) / (na * nb), 0.0)

    def velocity(self, here_enu_m: np.ndarray) -> np.ndarray:
        """(3,) the velocity setpoint to fly now from ``here_enu_m``, ENU m/s."""
        here = np.asarray(here_enu_m, dtype=float)
        p = self.params
        wp = self.waypoints[self.index]
        leg = wp - self._leg_start
        length = float(np.linalg.norm(leg))
        if length < 1e-9:
            return p.gain_1_s * (wp - here)
        u = leg / length
        along = float((here - self._leg_start) @ u)
        if along >= length:  # abreast of the waypoint or past it, yet not within reach: to it
            return p.gain_1_s * (wp - here)
        along = max(along, 0.0)
        left = length - along
        if self.last:
            speed = min(self.speed_m_s, math.sqrt(2.0 * p.brake_m_s2 * left), p.gain_1_s * left)
        else:
            v_next = self._turn_speed()
            speed = min(self.speed_m_s, math.sqrt(v_next**2 + 2.0 * p.brake_m_s2 * left))
        back = self._leg_start + u * along - here
        return u * speed + p.gain_1_s * back
