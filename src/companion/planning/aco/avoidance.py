"""Seed 001's collision avoidance (Sec. 3.2, Alg. 2; Eqs. 14-15): keep course or divert to a point.

Pure: one call per decision with what the UAV knows now; no I/O, randomness from the
``numpy.random.Generator`` passed in. The paper leaves the geometry open (digest 004_001 §6
items 4-6); the choices:

* **Sensed** (Eq. 14): an object counts when ``R_s - D_ij >= 0`` with D_ij the surface gap
  (``companion.swarm.vehicle.Sensed.distance_m``); the caller passes what its sensor returned
  within R_s (default 5 m).
* **Potential collision**: the predicted closest approach within the horizon ``T_h = R_s / v``
  (the time to cross the sensing range at the commanded speed v, 0.833 s at 5 m and 6 m/s, the
  right-hand side of Eqs. 11-12) is below D_min (Eq. 15 unsafe: ``D_min - D_ij >= 0``). Motion
  is linear: this UAV at its *intended* velocity (v towards its current aim point), the object
  at its sensed velocity. The gap at time t is ``|r + v_rel t| - offset`` with ``r`` the vector to
  the object's reported point and ``offset = |r| - gap_now`` (the radii the gap already
  subtracts: both spheres for a vehicle, this UAV's for a solid's nearest surface point).
* **Priority**: a *smaller* number is a *higher* priority (the scenario default gives vehicle 1
  priority 1: the ground station's rank order). The UAV keeps its course only if every object in
  conflict is a vehicle of known, strictly lower priority (a larger number); a solid, or a vehicle
  whose priority it has not heard, makes it divert (conservative: unknown is not outranked).
* **Avoidance point**: ``points`` (25, Sec. 4.1) uniform samples in the ball of radius R_s around
  the current position, z clipped to ``[z_min, z_max]`` (above a minimum altitude). Score
  ``|p - x| + |target - p|`` (the paper's "nearest point with minimum distance" read as the
  shortest detour to the target through p; ``|target - p|`` alone would prefer points far
  ahead). A point is *feasible* when (a) flying straight ``x -> p`` at v never brings any sensed
  object closer than ``min(D_min, gap now)`` (not worse than now when already too close) and
  (b) from p, on course to the target again, the closest approach within ``T_h`` clears D_min
  (objects predicted at the arrival time): the point removes the conflict. Up to ``attempts``
  draws (3) of ``points`` each; none feasible: **hold** (brake in place and decide again).
* **Divergence** (Sec. 3.5): one per adopted avoidance point (:attr:`Decision.diverge`), not per
  tick off the path; the caller counts them (:class:`AvoidanceCounter`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum
from typing import Literal

import numpy as np

R_S_M = 5.0
"""Detection range R_s, m (Sec. 4.1, Eq. 14)."""
D_MIN_M = 1.0
"""Default safe distance D_min, m (Sec. 4.2, Eq. 15)."""
POINTS = 25
"""Random points per resampling (Sec. 4.1)."""


@dataclass(frozen=True)
class Obstacle:
    """One sensed object, as Alg. 2 sees it."""

    position_enu_m: np.ndarray
    """(3,) the object's reported point (a vehicle's centre, a solid's nearest point), ENU m."""
    velocity_enu_m_s: np.ndarray
    """(3,) its velocity, ENU m/s."""
    distance_m: float
    """Surface gap now, m (negative: contact)."""
    kind: Literal["solid", "vehicle"] = "solid"
    name: str = ""
    priority: int | None = None
    """The other vehicle's priority when heard in its messages (smaller = higher); None: unknown
    or a solid."""
    offset_m: float = 0.0
    """Distance to the reported point minus the gap, m: the radii the gap subtracts (both
    spheres for a vehicle, this UAV's for a solid's surface point); :func:`obstacle`."""


def obstacle(
    here: np.ndarray,
    position_enu_m: np.ndarray,
    velocity_enu_m_s: np.ndarray,
    distance_m: float,
    kind: Literal["solid", "vehicle"] = "solid",
    name: str = "",
    priority: int | None = None,
) -> Obstacle:
    """An :class:`Obstacle` as sensed from ``here`` (its ``offset_m`` from the distance now)."""
    p = np.asarray(position_enu_m, float)
    offset = max(float(np.linalg.norm(p - np.asarray(here, float))) - float(distance_m), 0.0)
    return Obstacle(
        p, np.asarray(velocity_enu_m_s, float), float(distance_m), kind, name, priority, offset
    )


@dataclass(frozen=True)
class AvoidanceParams:
    """Alg. 2's parameters."""

    sense_m: float = R_S_M
    """R_s, m: sensing range, the sampling ball's radius, and (over the speed) the horizon."""
    d_min_m: float = D_MIN_M
    """D_min, m: the gap that counts as safe."""
    points: int = POINTS
    """Random points per draw."""
    attempts: int = 3
    """Draws before holding."""
    z_min_m: float = 2.0
    """Lowest altitude of an avoidance point (ENU up), m."""
    z_max_m: float = math.inf
    """Highest altitude of an avoidance point, m."""

    def __post_init__(self) -> None:
        for name in ("sense_m", "d_min_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name}: {value!r} must be a positive number")
        if self.points < 1 or self.attempts < 1:
            raise ValueError(f"points, attempts: {self.points}, {self.attempts} must be >= 1")
        if not self.z_max_m >= self.z_min_m:
            raise ValueError(f"z_max_m {self.z_max_m} must be >= z_min_m {self.z_min_m}")


class Action(StrEnum):
    """What Alg. 2 decided."""

    KEEP = "keep"
    """No conflict, or this UAV outranks every vehicle in conflict: keep its course."""
    DIVERT = "divert"
    """Fly to :attr:`Decision.point`, then restore the path (one divergence)."""
    HOLD = "hold"
    """Conflict and no feasible point: brake and hold in place."""


@dataclass(frozen=True)
class Decision:
    """Alg. 2's answer for one tick."""

    action: Action
    point: np.ndarray | None = None
    """(3,) the avoidance point (DIVERT), ENU m."""
    conflicts: tuple[str, ...] = ()
    """Names of the objects in potential collision."""

    @property
    def diverge(self) -> bool:
        """An avoidance point is adopted (one divergence)."""
        return self.action is Action.DIVERT


def potential_collisions(
    here: np.ndarray,
    aim: np.ndarray,
    speed_m_s: float,
    sensed: list[Obstacle],
    params: AvoidanceParams,
) -> list[Obstacle]:
    """The sensed objects whose closest approach within ``T_h = R_s / v`` is below D_min."""
    u = course(here, aim, speed_m_s)
    horizon = params.sense_m / speed_m_s
    return [ob for ob in sensed if min_gap(here, u, ob, 0.0, horizon) < params.d_min_m]


def outranks(priority: int, conflicts: list[Obstacle]) -> bool:
    """This UAV keeps its course: every conflict is a vehicle of known, larger priority number."""
    return bool(conflicts) and all(
        ob.kind == "vehicle" and ob.priority is not None and ob.priority > priority
        for ob in conflicts
    )


def sample_ball(
    here: np.ndarray, radius_m: float, n: int, rng: np.random.Generator, z_min: float, z_max: float
) -> np.ndarray:
    """(n, 3) points uniform in the ball of ``radius_m`` around ``here``, z clipped to the band."""
    d = rng.normal(size=(n, 3))
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    pts = np.asarray(here, float) + d * (radius_m * rng.uniform(size=(n, 1)) ** (1.0 / 3.0))
    pts[:, 2] = np.clip(pts[:, 2], z_min, z_max)
    return pts


def feasible(
    here: np.ndarray,
    point: np.ndarray,
    target: np.ndarray,
    speed_m_s: float,
    sensed: list[Obstacle],
    params: AvoidanceParams,
) -> bool:
    """Does ``point`` clear every sensed object on the way and remove the conflict (a), (b)?"""
    leg = float(np.linalg.norm(point - here))
    t_a = leg / speed_m_s
    u = course(here, point, speed_m_s)
    u2 = course(point, target, speed_m_s)
    horizon = params.sense_m / speed_m_s
    for ob in sensed:
        if min_gap(here, u, ob, 0.0, t_a) < min(params.d_min_m, ob.distance_m):
            return False
        if min_gap(point, u2, ob, t_a, t_a + horizon) < params.d_min_m:
            return False
    return True


def avoid(
    here: np.ndarray,
    aim: np.ndarray,
    target: np.ndarray,
    priority: int,
    sensed: list[Obstacle],
    speed_m_s: float,
    rng: np.random.Generator,
    params: AvoidanceParams = AvoidanceParams(),
) -> Decision:
    """Alg. 2 for one tick: keep the course to ``aim``, or divert towards ``target``, or hold.

    ``aim`` is where the UAV flies now (its current waypoint, or the avoidance point it flies
    to), ``target`` what the avoidance point is scored against (its current path waypoint).
    """
    here, aim, target = (np.asarray(a, float) for a in (here, aim, target))
    conflicts = potential_collisions(here, aim, speed_m_s, sensed, params)
    names = tuple(ob.name for ob in conflicts)
    if not conflicts or outranks(priority, conflicts):
        return Decision(Action.KEEP, None, names)
    point = best_point(
        here, target, speed_m_s, sensed, rng, params, lambda p: _detour(here, p, target)
    )
    if point is None:
        return Decision(Action.HOLD, None, names)
    return Decision(Action.DIVERT, point, names)


def best_point(
    here: np.ndarray,
    target: np.ndarray,
    speed_m_s: float,
    sensed: list[Obstacle],
    rng: np.random.Generator,
    params: AvoidanceParams,
    score: Callable[[np.ndarray], float],
) -> np.ndarray | None:
    """The lowest-``score`` feasible sample of up to ``attempts`` draws (None: none feasible)."""
    for _ in range(params.attempts):
        pts = sample_ball(here, params.sense_m, params.points, rng, params.z_min_m, params.z_max_m)
        scores = np.array([score(p) for p in pts])
        for k in np.argsort(scores, kind="stable"):
            if feasible(here, pts[k], target, speed_m_s, sensed, params):
                return pts[k]
    return None


def _detour(here: np.ndarray, p: np.ndarray, target: np.ndarray) -> float:
    return float(np.linalg.norm(p - here) + np.linalg.norm(target - p))


def course(a: np.ndarray, b: np.ndarray, speed_m_s: float) -> np.ndarray:
    """(3,) the velocity flying straight from ``a`` to ``b`` at ``speed_m_s`` (zero at b)."""
    d = np.asarray(b, float) - np.asarray(a, float)
    n = float(np.linalg.norm(d))
    return np.zeros(3) if n < 1e-9 else d * (speed_m_s / n)


def min_gap(here: np.ndarray, u: np.ndarray, ob: Obstacle, t0: float, t1: float) -> float:
    """Least gap to ``ob`` for t in [t0, t1] s from now, this UAV at ``here + u (t - t0)``."""
    r0 = ob.position_enu_m + ob.velocity_enu_m_s * t0 - here
    vr = ob.velocity_enu_m_s - u
    vv = float(vr @ vr)
    t = 0.0 if vv == 0.0 else min(max(-float(r0 @ vr) / vv, 0.0), max(t1 - t0, 0.0))
    return float(np.linalg.norm(r0 + vr * t)) - ob.offset_m
