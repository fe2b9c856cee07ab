"""The caravan role (``companion.scripts.caravan``, seed 003) behind the kinematic adapter.

Every decision is one consensus step of the allocator the role's ``algorithm`` names (CarA/ICF,
GBAA or ICA, ``companion.planning.caravan``): read the neighbours' messages (topic ``caravan``;
the link network delivers only within range, and loses some), bid Eq. (26) from where the
vehicle is (lattice travel times, ``TaskGraph``), step, broadcast its message, and fly the
lattice route to the task it heads to when that changes. Within ``arrive_tolerance_m`` of its
task (horizontally) the task is completed (Eq. 19). When every task it knows of is completed it
flies home and lands.

It takes off first, to ``altitude_m`` plus ``altitude_step_m`` per role index (seed 003's
staggered altitudes: no collision avoidance); consensus runs from the first decision, the flight
to tasks starts once the vehicle has climbed (its ``mission_start``). A vehicle found on the
ground while the program flies it (a fault brought it down) ends the program quietly (phase
``down``, no error): a companion whose vehicle is lost stops acting and stops talking.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path
from typing import Any

import numpy as np

from companion.net.node import Node
from companion.planning.caravan.agent import make_allocator
from companion.planning.caravan.graph import TaskGraph
from companion.planning.caravan.scores import CaravanParams
from companion.role_params import params_from_mapping
from companion.scenario_env import ScenarioEnv
from companion.swarm.vehicle import SwarmVehicle

TOPIC = "caravan"
"""Message topic of the allocators' consensus."""
CLIMB_M_S = 2.0
"""Climb rate of the take-off, m/s."""
HOME_TOLERANCE_M = 0.3
"""Horizontal distance from home within which the vehicle lands, m."""


@functools.lru_cache(maxsize=8)
def task_map(world_path: str) -> tuple[np.ndarray, tuple[float, float], float]:
    """(task positions (N_m, 2) m, map size (sx, sy) m, grid spacing m) of a taskmap world."""
    import worlds

    world = worlds.build(worlds.load_world(Path(world_path)))
    tasks = world.targets_of(worlds.TaskPoint)
    if not tasks:
        raise ValueError(f"world {world_path}: no TaskPoint targets (a taskmap world has them)")
    xy = np.array([t.position_xy_m for t in tasks], dtype=float)
    size = (float(world.size_m[0]), float(world.size_m[1]))
    return xy, size, float(world.extras["grid_spacing_m"])


@functools.lru_cache(maxsize=8)
def task_graph(size_m: tuple[float, float], spacing_m: float) -> TaskGraph:
    """One lattice per map in a process (its Dijkstra cache is shared by the vehicles)."""
    return TaskGraph(size_m, spacing_m)


def caravan_params(env: ScenarioEnv) -> CaravanParams:
    """The role's ``args`` as CaravanParams (unknown keys and bad values name themselves)."""
    return params_from_mapping(CaravanParams, env.params)


class CaravanProgram:
    """One vehicle's allocator and flight at swarm scale (see the module docstring)."""

    def __init__(self, env: ScenarioEnv, vehicle: SwarmVehicle, node: Node | None) -> None:
        if env.world is None:
            raise ValueError("the caravan role needs the run's world (a taskmap): the tasks")
        self.env = env
        self.vehicle = vehicle
        self.node = node
        self.params = caravan_params(env)
        self.tasks_xy, size, spacing = task_map(str(env.world))
        self.graph = task_graph(size, spacing)
        self.agent = env.role_index
        self.allocator = make_allocator(self.params, self.agent, env.role_count, len(self.tasks_xy))
        self.height_m = self.params.altitude_m + self.params.altitude_step_m * env.role_index
        self.start_xy = vehicle.home_enu_m[:2].copy()
        self.phase = "takeoff"
        self.error: str | None = None
        self.mission_start_s = math.nan
        self.landed_s = math.nan
        self._target: int | None = None

    @property
    def done(self) -> bool:
        """Landed after the mission, or its vehicle is down."""
        return self.phase in ("done", "down")

    def decide(self, now_s: float) -> None:
        """One consensus step and the flight phase's next command."""
        v = self.vehicle
        if self.done:
            return
        if self.phase == "takeoff":
            v.takeoff(self.height_m, CLIMB_M_S)
            self.phase = "climb"
        elif not v.airborne and self.phase != "land":
            self.phase = "down"  # brought down while flying: stop acting, stop talking
            return
        if self.phase == "land":
            if not v.airborne:
                self.landed_s = now_s
                self.phase = "done"
            return
        self._consensus(now_s)
        if self.phase == "climb" and v.path_done:
            self.mission_start_s = now_s
            self.phase = "mission"
        if self.phase == "mission" and self.allocator.finished:
            home = v.home_enu_m
            self._fly_to(home[:2])
            self.phase = "home"
        elif self.phase == "home" and v.path_done:
            here = v.position_enu_m[:2]
            if math.dist(here, v.home_enu_m[:2]) <= HOME_TOLERANCE_M:
                v.land()
                self.phase = "land"

    def _consensus(self, now_s: float) -> None:
        """Messages in, bids, one allocator step, arrival, message out, the route."""
        a = self.allocator
        if self.node is not None:
            for env in self.node.poll():
                if env.topic == TOPIC and isinstance(env.body, dict):
                    a.inbox(int(env.body["agent"]), env.body["m"], now_s)
        here = self.vehicle.position_enu_m[:2]
        times = self.graph.travel_times_s(here, self.tasks_xy, self.params.speed_m_s)
        task = a.step(now_s, self.params.bids(now_s, times))
        if (
            task is not None
            and math.dist(here, self.tasks_xy[task]) <= self.params.arrive_tolerance_m
        ):
            a.arrived(task, now_s)
            task = None
        if self.node is not None:
            self.node.broadcast(TOPIC, {"agent": self.agent, "m": a.outbox(now_s)})
        if self.phase != "mission" or task == self._target:
            return
        self._target = task
        if task is None:
            self._fly_to(here, lattice=False)  # hold where it is
        else:
            self._fly_to(self.tasks_xy[task])

    def _fly_to(self, xy: np.ndarray, lattice: bool = True) -> None:
        here = self.vehicle.position_enu_m[:2]
        route = self.graph.path_xy(here, xy) if lattice else np.asarray(xy, float).reshape(1, 2)
        z = np.full((len(route), 1), float(self.vehicle.home_enu_m[2]) + self.height_m)
        self.vehicle.fly_path(np.hstack([route, z]), self.params.speed_m_s)

    def metrics(self) -> dict[str, tuple[Any, str]]:
        """What this vehicle's allocator counted (``companion.scripts.caravan.run_metrics``)."""
        st = self.allocator.stats
        start = None if math.isnan(self.mission_start_s) else round(self.mission_start_s, 3)
        return {
            "algorithm": (self.params.algorithm, "name"),
            "completions": ([[j, round(t, 3)] for j, t in st.completed], "list"),
            "tasks_completed": (len(st.completed), "count"),
            "tasks_assigned": (st.assigned, "count"),
            "tasks_released": (sorted(st.released), "list"),
            "tasks_validated": (len(st.validated), "count"),
            "last_change_step": (st.last_change_step, "count"),
            "steps": (st.steps, "count"),
            "duplicates": (st.duplicates, "count"),
            "start_xy": ([round(float(c), 3) for c in self.start_xy], "m"),
            "mission_start": (start, "s"),
            "phase": (self.phase, "name"),
        }
