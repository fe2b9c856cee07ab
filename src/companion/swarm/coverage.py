"""The coverage role (``companion.scripts.coverage``) behind the kinematic adapter.

The same decisions as the MAVSDK program, in the same order: plan this vehicle's strip with
``companion.planning.coverage_role.plan`` and the same time budget, take off to its own height, wait
until the whole role is up, fly the lanes and the way home as one path (the mission), return
early when the rest of the path no longer fits the run (the same rule), settle above home and
land. Each decision it also tells its radio neighbours where it is and what its camera found
(node messaging through the link model), and keeps what they tell it.

Coverage is measured as the MAVSDK program measures it, from the track: the area the camera's
footprint swept while surveying (here the surveyed track at the decision rate, buffered by half
the footprint width at the flown height) over the vehicle's strip.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path
from typing import Any

import numpy as np
import shapely

from companion.net.envelope import Envelope
from companion.net.node import Node
from companion.planning.coverage import Router
from companion.planning.coverage_role import (
    CoverageParams,
    climb_and_landing_s,
    finish_time_s,
    plan,
    world_spills,
)
from companion.scenario_env import ScenarioEnv
from companion.swarm.vehicle import SwarmVehicle


@functools.lru_cache(maxsize=4)
def _world(path: str) -> Any:
    """The run's world, built once per process (every vehicle of a run shares the file)."""
    import worlds

    return worlds.build(worlds.load_world(Path(path)))


class CoverageProgram:
    """One vehicle's coverage flight at swarm scale (see the module docstring).

    Args:
        env: the vehicle's place in the run (``SWARMSITL_*`` as a full-stack program gets it).
        vehicle: the kinematic adapter.
        node: its messaging node, or None without node messaging.
    """

    def __init__(self, env: ScenarioEnv, vehicle: SwarmVehicle, node: Node | None) -> None:
        self.env = env
        self.vehicle = vehicle
        self.node = node
        self.shared = CoverageParams.from_mapping(env.params)
        self.params = self.shared.own(env.role_index)
        self.world = _world(str(env.world)) if env.world is not None else None
        self.duration_s = env.duration_s if env.duration_s is not None else math.inf
        self.phase = "plan"
        self.error: str | None = None
        self.path: Any = None
        self.mission_xy = np.zeros((0, 2))
        self.to_go_m = np.zeros(0)
        self.armed_at_s = math.nan
        self.all_up_s = math.nan
        self.land_s = 0.0
        self.samples: list[tuple[float, float, float, float]] = []
        """(time, east, north, up) while armed, one per decision."""
        self.surveyed: list[tuple[float, float, float, float]] = []
        """The samples taken while flying the lanes."""
        self.found: dict[str, tuple[float, float]] = {}
        """Targets this vehicle's camera saw, name -> (east, north)."""
        self.heard: dict[str, tuple[float, float]] = {}
        """Targets its neighbours reported, name -> (east, north)."""
        self.neighbour_positions: dict[str, tuple[float, float, float]] = {}
        self.closest_neighbour_m = math.inf
        """Nearest neighbour by the positions they reported, m."""
        self.returned_early = False
        if node is not None:
            node.on("state", self._on_state)
            node.on("target", self._on_target)

    # -- messaging --------------------------------------------------------------------------

    def _on_state(self, env: Envelope) -> None:
        x, y, z = (float(v) for v in env.body["p"])
        self.neighbour_positions[env.src] = (x, y, z)

    def _on_target(self, env: Envelope) -> None:
        name = str(env.body["name"])
        self.heard.setdefault(name, (float(env.body["e"]), float(env.body["n"])))

    def _share(self, here: np.ndarray, new: list) -> None:
        node = self.node
        if node is None:
            return
        node.poll()
        neighbours = self.vehicle.neighbours()
        state = {"p": [round(float(v), 2) for v in here]}
        for peer in neighbours:
            node.send(peer, "state", state, category="control")
            for d in new:
                body = {"name": d.name, "e": d.position_enu_m[0], "n": d.position_enu_m[1]}
                node.send(peer, "target", body)
        if self.neighbour_positions:
            near = np.array(list(self.neighbour_positions.values()))
            self.closest_neighbour_m = min(
                self.closest_neighbour_m, float(np.min(np.linalg.norm(near - here, axis=1)))
            )
            self.neighbour_positions.clear()

    # -- decisions --------------------------------------------------------------------------

    @property
    def done(self) -> bool:
        """Landed after the flight, or failed."""
        return self.phase in ("done", "failed")

    def decide(self, now_s: float) -> None:
        """One decision: messages, observations, then the flight phase's next step."""
        v = self.vehicle
        here = v.position_enu_m
        new = v.detections()
        for d in new:
            self.found.setdefault(d.name, d.position_enu_m)
        self._share(here, new)
        if v.airborne:
            self.samples.append((now_s, *map(float, here)))
            if self.phase == "survey":
                self.surveyed.append((now_s, *map(float, here)))
        step = getattr(self, f"_{self.phase}", None)
        if step is not None:
            step(now_s, here)

    def _fail(self, message: str) -> None:
        self.error = message
        self.phase = "failed"
        if self.vehicle.airborne:
            self.vehicle.land()

    def _plan(self, now_s: float, here: np.ndarray) -> None:
        home = self.vehicle.home_enu_m
        climb_s = climb_and_landing_s(self.shared.own(self.env.role_count - 1))[0]
        self.land_s = climb_and_landing_s(self.params)[1]
        budget = self.duration_s - now_s - climb_s - self.land_s - self.params.reserve_s
        if budget <= 0:
            self._fail(f"no time to fly: {self.duration_s - now_s:.0f} s left of the run")
            return
        path = plan(self.env, self.shared, self.world, home, budget)
        if len(path.waypoints_enu_m) == 0:
            self._fail(f"the {budget:.0f} s budget leaves no part of the strip to fly")
            return
        way_home = np.vstack([path.return_route_enu_m, [[*home[:2], 0.0]]])
        self.mission_xy = np.vstack([path.waypoints_enu_m, way_home])[:, :2]
        legs = np.hypot(*np.diff(self.mission_xy, axis=0).T)
        self.to_go_m = np.concatenate((np.cumsum(legs[::-1])[::-1], [0.0]))
        self.path = path
        self.vehicle.takeoff(self.params.altitude_m, self.params.climb_m_s)
        self.armed_at_s = now_s
        self.all_up_s = now_s + climb_s
        self.phase = "climb"

    def _fly(self, xy: np.ndarray) -> None:
        """Fly through the ENU points ``xy`` ((K, 2)) at this vehicle's height and speed."""
        z = float(self.vehicle.home_enu_m[2]) + self.params.altitude_m
        xyz = np.column_stack((xy, np.full(len(xy), z)))
        self.vehicle.fly_path(xyz, self.params.speed_m_s)

    def _climb(self, now_s: float, here: np.ndarray) -> None:
        if now_s >= self.all_up_s and self.vehicle.path_done:
            self._fly(self.mission_xy)
            self.phase = "survey"

    def _survey(self, now_s: float, here: np.ndarray) -> None:
        v = self.vehicle
        if v.path_done:
            self.phase = "home"
            self._home(now_s, here)
            return
        i = min(v.path_index, len(self.mission_xy) - 1)
        remaining = float(np.hypot(*(self.mission_xy[i] - here[:2]))) + self.to_go_m[i]
        if now_s + finish_time_s(remaining, self.params, self.land_s) >= self.duration_s:
            self.returned_early = True
            home = v.home_enu_m
            free = self.path.free_area
            router = Router(free) if free is not None else None
            if router is not None and router.contains(here[:2]):
                corners = [*router.path(here[:2], home[:2]), home[:2]]
            else:
                corners = [home[:2]]
            xy = np.asarray(corners, dtype=float).reshape(-1, 2)
            self._fly(xy)
            self.phase = "home"

    def _home(self, now_s: float, here: np.ndarray) -> None:
        if self.vehicle.path_done:
            self.vehicle.land()
            self.phase = "land"

    def _land(self, now_s: float, here: np.ndarray) -> None:
        if not self.vehicle.airborne:
            self.phase = "done"

    # -- results ----------------------------------------------------------------------------

    def metrics(self) -> dict[str, tuple[Any, str]]:
        """As the MAVSDK program's ``result.json`` (coverage, distance, targets), plus messaging."""
        samples = np.array(self.samples).reshape(-1, 4)
        distance = float(np.linalg.norm(np.diff(samples[:, 1:], axis=0), axis=1).sum())
        fraction = 0.0
        in_footprint: list[str] = []
        if self.path is not None and len(self.surveyed) >= 2:
            track = np.array(self.surveyed)
            height = float(np.median(track[:, 3]))
            half = height * math.tan(math.radians(self.shared.hfov_deg) / 2.0)
            swept = shapely.LineString(track[:, 1:3]).buffer(half)
            strip = self.path.part.polygon
            fraction = swept.intersection(strip).area / strip.area if strip.area > 0 else 0.0
            for spill in world_spills(self.world):
                later = track[track[:, 0] >= spill.appear_s]
                if len(later) >= 2 and shapely.LineString(later[:, 1:3]).buffer(half).intersects(
                    spill.polygon
                ):
                    in_footprint.append(spill.name)
        known = set(self.found) | set(self.heard)
        return {
            "spills_in_footprint": (len(in_footprint), "count"),
            "spills_in_footprint_names": (sorted(in_footprint), "names"),
            "distance_flown_m": (round(distance, 2), "m"),
            "coverage_fraction": (round(float(fraction), 4), "1"),
            "targets_seen": (len(self.found), "count"),
            "targets_seen_names": (sorted(self.found), "names"),
            "targets_known_names": (sorted(known), "names"),
            "returned_early": (int(self.returned_early), "count"),
            "closest_neighbour_reported_m": (
                round(self.closest_neighbour_m, 2)
                if math.isfinite(self.closest_neighbour_m)
                else None,
                "m",
            ),
        }
