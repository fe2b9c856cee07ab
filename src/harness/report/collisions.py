"""Collisions: vehicles touching each other or a world solid, counted as events, both fidelities.

A vehicle is a sphere of its airframe's diameter (:func:`airframe_diameter_m`: rotor tip to rotor
tip). Two vehicles touch when their centres are closer than the sum of their radii; a vehicle
touches a solid when the solid's nearest point (3-D, heights included: a vehicle above a box's top
is clear of it) is closer than its radius. Only airborne vehicles touch anything: a vehicle
resting on the ground (at its start, landed, crashed) is not a collision.

:class:`CollisionCounter` counts *events*: a pair entering contact counts once, until it separates
(then a new contact counts again). The swarm engine feeds it every kinematic step; the full stack
feeds it the truth tracks (:func:`count_from_tracks`), at the truth's sample rate; the same
contact test (:func:`contacts`) serves both.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from worlds.solid_set import SolidSet

MAX_EVENTS = 100
"""Collision events the report lists (the counts include every one)."""


@functools.lru_cache(maxsize=16)
def airframe_diameter_m(airframe: str) -> float:
    """Rotor tip to rotor tip of an airframe: 2 x the farthest hub + a rotor's diameter, m.

    The hubs are the airframe YAML's ``rotors`` (horizontal distance from the centre of mass),
    the rotor diameter its ``power.propulsion.rotor_diameter_m``.
    """
    from sitl.power.propulsion import load_power_spec
    from sitl.vehicles.multirotor import load_airframe

    spec = load_airframe(airframe)
    hubs = max(math.hypot(*r.position_frd_m[:2]) for r in spec.rotors)
    return 2.0 * hubs + load_power_spec(spec.yaml_path).propulsion.rotor_diameter_m


def contacts(
    pos: np.ndarray,
    airborne: np.ndarray,
    radius_m: np.ndarray,
    solids: SolidSet | None,
    t_s: float,
) -> tuple[set[tuple[int, int]], set[tuple[int, int]]]:
    """The pairs in contact at one instant: ``({(i, j) vehicles, i < j}, {(i, k) vehicle, solid})``.

    Args:
        pos: (N, 3) vehicle centres, ENU m (NaN rows: not sampled, never in contact).
        airborne: (N,) bool: only airborne vehicles touch anything.
        radius_m: (N,) vehicle radii, m.
        solids: the world's solids (None: none).
        t_s: simulated time, s (where the moving solids are).
    """
    up = np.flatnonzero(np.asarray(airborne, dtype=bool) & np.isfinite(pos).all(axis=1))
    vv: set[tuple[int, int]] = set()
    vs: set[tuple[int, int]] = set()
    if len(up) == 0:
        return vv, vs
    p, r = pos[up], radius_m[up]
    if len(up) >= 2:
        pairs = cKDTree(p).query_pairs(2.0 * float(r.max()), output_type="ndarray")
        if len(pairs):
            a, b = pairs[:, 0], pairs[:, 1]
            hit = np.linalg.norm(p[a] - p[b], axis=1) < r[a] + r[b]
            ia, ib = up[a[hit]], up[b[hit]]
            vv = {(int(min(x, y)), int(max(x, y))) for x, y in zip(ia, ib, strict=True)}
    if solids is not None and len(solids):
        q, k, closest = solids.near(p, r, t_s)
        hit = np.linalg.norm(closest - p[q], axis=1) < r[q]
        vs = {(int(up[i]), int(j)) for i, j in zip(q[hit], k[hit], strict=True)}
    return vv, vs


@dataclass
class CollisionCounter:
    """Contact events over a run (see the module docstring)."""

    n: int
    """Vehicles."""
    solid_names: list[str] = field(default_factory=list)
    vehicle_names: list[str] = field(default_factory=list)
    """Names in the events (default ``vehicle{i + 1}``)."""
    vehicle_events: int = 0
    solid_events: int = 0
    per_vehicle: np.ndarray = field(init=False)
    """(N,) events each vehicle took part in."""
    events: list[dict[str, Any]] = field(default_factory=list)
    """The first ``MAX_EVENTS`` events: ``{"time_s", "a", "b"}`` (b a vehicle or a solid)."""
    _vv: set[tuple[int, int]] = field(default_factory=set)
    _vs: set[tuple[int, int]] = field(default_factory=set)

    def __post_init__(self) -> None:
        self.per_vehicle = np.zeros(self.n, dtype=np.int64)
        if not self.vehicle_names:
            self.vehicle_names = [f"vehicle{i + 1}" for i in range(self.n)]

    @property
    def total(self) -> int:
        """Events of both kinds."""
        return self.vehicle_events + self.solid_events

    def update(self, t_s: float, vv: set[tuple[int, int]], vs: set[tuple[int, int]]) -> None:
        """Count the contacts at ``t_s`` that were not in contact at the previous update."""
        new_vv = sorted(vv - self._vv)
        new_vs = sorted(vs - self._vs)
        self._vv, self._vs = vv, vs
        for i, j in new_vv:
            self.vehicle_events += 1
            self.per_vehicle[[i, j]] += 1
            self._event(t_s, self.vehicle_names[i], self.vehicle_names[j])
        for i, k in new_vs:
            self.solid_events += 1
            self.per_vehicle[i] += 1
            self._event(t_s, self.vehicle_names[i], self.solid_names[k])

    def _event(self, t_s: float, a: str, b: str) -> None:
        if len(self.events) < MAX_EVENTS:
            self.events.append({"time_s": float(t_s), "a": a, "b": b})

    def fleet_metrics(self) -> dict[str, Any]:
        """The report's ``fleet.collisions*`` entries."""
        return {
            "collisions": {"value": self.total, "unit": "count"},
            "collisions_vehicle": {"value": self.vehicle_events, "unit": "count"},
            "collisions_solid": {"value": self.solid_events, "unit": "count"},
            "collision_events": {
                "value": self.events,
                "unit": "",
                "message": f"the first {MAX_EVENTS} of {self.total}"
                if self.total > MAX_EVENTS
                else f"all {self.total}",
            },
        }

    def check(self, at_most: int) -> dict[str, Any]:
        """The ``max_collisions`` check: at most ``at_most`` events."""
        first = self.events[0] if self.events else None
        where = (
            f"; first: {first['a']} and {first['b']} at {first['time_s']:.1f} s" if first else ""
        )
        return {
            "ok": self.total <= at_most,
            "value": self.total,
            "message": f"{self.total} collisions ({self.vehicle_events} vehicle-vehicle, "
            f"{self.solid_events} vehicle-solid), at most {at_most}{where}",
        }


def count_from_tracks(
    time_s: np.ndarray,
    pos: np.ndarray,
    airborne: np.ndarray,
    radius_m: np.ndarray,
    solids: SolidSet | None,
    vehicle_names: list[str] | None = None,
) -> CollisionCounter:
    """Contact events of sampled tracks (the full stack's truth).

    Args:
        time_s: (T,) sample times, s, increasing.
        pos: (T, N, 3) positions, ENU m (NaN: vehicle not sampled then).
        airborne: (T, N) bool.
        radius_m: (N,) vehicle radii, m.
        solids: the world's solids (None: none).
        vehicle_names: names in the events (default ``vehicle{i + 1}``).
    """
    n = pos.shape[1]
    counter = CollisionCounter(
        n, solids.names if solids is not None else [], list(vehicle_names or [])
    )
    radius = np.asarray(radius_m, dtype=float)
    for t, p, up in zip(time_s, pos, airborne, strict=True):
        counter.update(float(t), *contacts(p, up, radius, solids, float(t)))
    return counter


def tracks_on_grid(log: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A :class:`harness.report.flight_log.FlightLog`'s truth on one time grid.

    Returns ``(time_s (T,), pos (T, N, 3), airborne (T, N))``; NaN / False where a vehicle has no
    sample at a grid time (the recorder samples all vehicles at the same instants).
    """
    grid = np.unique(np.concatenate([v.track.time_s for v in log.vehicles] or [np.zeros(0)]))
    n = len(log.vehicles)
    pos = np.full((len(grid), n, 3), np.nan)
    up = np.zeros((len(grid), n), dtype=bool)
    for v in log.vehicles:
        tr = v.track
        at = np.searchsorted(grid, tr.time_s)
        pos[at, v.index] = tr.enu_m
        up[at, v.index] = tr.airborne
    return grid, pos, up


def scenario_collisions(log: Any, scenario: Any) -> CollisionCounter:
    """A full-stack run's contact events, from its truth (a ``FlightLog``).

    The scenario gives the airframes (radii) and the world (solids); the test is fidelity
    swarm's, at the truth's sample rate.
    """
    time_s, pos, up = tracks_on_grid(log)
    airframes = [v.group.airframe for v in scenario.vehicles]
    radius = np.array([airframe_diameter_m(a) / 2.0 for a in airframes[: pos.shape[1]]])
    world = scenario.world
    solids = SolidSet(world.solids) if world is not None and world.solids else None
    return count_from_tracks(time_s, pos, up, radius, solids)
