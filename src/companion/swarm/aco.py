"""Seed 001's ACO swarm (options 1 and 2, Algs. 2-4): the decisions both adapters run.

One :class:`AcoProgram` per vehicle, deciding at a fixed period: the swarm engine's decision
rate at swarm fidelity, where the engine's kinematic vehicle is its :class:`AcoVehicle`
(``companion.scripts.aco_swarm.swarm_program``); ``decision_period_s`` of the vehicle's clock on
the full stack, where ``companion.scripts.aco_swarm.MavsdkVehicle`` is (offboard setpoints over
MAVSDK, an idealised obstacle sensor, the peers from the radio). Layout and plan are the pure
functions :func:`aco_layout` and :func:`plan_route`; the decisions (Alg. 2, Alg. 4) are
:meth:`AcoProgram.decide`. The adapters only carry commands and observations.

* **Layout.** The vehicle's start is its spawn point (on the full stack its estimated position
  at rest; it must lie in the world's launch area ``start``) at ``altitude_m``; its target is
  the *mirror point in the goal zone*: the spawn's offset from the start zone's centre, east
  component negated, added to the goal zone's centre
  (``arena_aco``: the zones are mirror images about the arena's north-south centre line). The
  fleet's targets are thus its starts mirrored, every pairwise distance kept (the formation of
  option 2 is reachable at the goal), and paths do not all cross one point.
* **Option 2's layout and plan.** The target is the start *translated* by the zones' centres'
  offset, and every UAV flies the same plan translated by its start offset: the path planned
  (with the run's seed, identically on every UAV) from the start zone's centre to the goal
  zone's, its static solids grown by the start zone's radius as well. Alg. 4 line 4 ("apply
  the ant colony algorithm for all UAVs") is read so: with one ACO path per UAV over different
  random roadmaps the pairwise distances drift by metres along the way and a 0.1 m threshold
  has every UAV chasing its formation instead of its target (tried: no UAV arrived), whereas
  Table 2's FC (about 25 % of 0.1 m) says the paper's formations stayed nearly rigid.
  Avoidance and Alg. 4 then mend the deviations the obstacles cause.
  On the 300 m test arena (5 UAVs, threshold 0.1 m) every UAV arrives, FC about 5 % with few
  drums and 29 % with 20 drums (one drum contact in that run); Alg. 4's check is the median of
  the own row (``formation.in_formation``).
* **Plan** (Alg. 3 lines 2-3, Alg. 4 line 4). Before the flight, each vehicle plans its own path
  over its own seeded roadmap of the arena (``RoadmapParams``: the world's extent, heights
  ``altitude_m`` to ``altitude_m + altitude_band_m``), ACO or the A* baseline
  (:func:`companion.planning.aco.plan.plan_path`). The world's *static* solids, grown by
  ``roadmap_margin_m``, are given to the roadmap (edges and nodes inside them are dropped): with
  R_s = 5 m, reactive avoidance alone would have to walk around a 60 m building by 5 m hops;
  the moving drums are left to Alg. 2 (the paper's obstacles are "unknown to the UAVs").
* **Fly.** Take off to ``altitude_m``, then (once climbed, and not before ``depart_s``: the
  fleet leaves together, Alg. 3's main loop starting when every path is ready) ``fly_path``
  the waypoints at ``speed_m_s``.
  Every decision: poll the messages (topic ``aco``: role index, time, priority, start,
  position, velocity; a peer's position is extrapolated to now with its velocity), broadcast
  its own, sense R_s, and run Alg. 2 (:func:`avoidance.avoid`) against the current waypoint.
  DIVERT (one divergence): fly to the point and then restore the path,
  as one ``fly_path`` through the point and on from the current waypoint (the vehicle does not
  stop at the point, as a ``goto`` would: a swarm of stop-and-go hops crawls); HOLD:
  ``set_velocity(0)`` (brake) and decide again, then restore the path from its waypoint.
  Option 2 adds Alg. 4 while on the path (not heading to a point) and clear of conflicts: out
  of formation (own row, ``threshold_m``) -> the restoring point, the same way (one divergence).
  The reference array comes from the starts the others broadcast (Alg. 4 line 1).
* **Arrive.** At the path's end (within the autopilot's acceptance radius, phase ``arrive``)
  it closes on the target; within ``ARRIVE_M`` of it: reached; land there. A vehicle that has
  not arrived when the run ends is not ``reached``.

Metrics per vehicle (:meth:`AcoProgram.metrics`): ``reached``, ``min_dist_m`` (straight
start -> target at altitude, Eq. 4's MinDist), ``total_dist_m`` (flown from the mission start
to the arrival, Eq. 4's TotalDist), ``travel_time_s``, ``mission_start_s`` and ``arrived_s``
(simulated), ``divergences``, ``holds``, ``avg_dist_change_m`` (option 2, Eq. 8's input),
``plan_ms``, ``path_length_m``, ``phase``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from companion.planning.aco.avoidance import Action, AvoidanceParams, Obstacle, avoid, obstacle
from companion.planning.aco.colony import AcoParams
from companion.planning.aco.formation import (
    FormationTracker,
    current_distances,
    in_formation,
    reference_distances,
    restoring_point,
)
from companion.planning.aco.plan import PlannedPath, Planner, plan_path, straight_line_length
from companion.planning.aco.roadmap import Prism, RoadmapParams
from companion.role_params import params_from_mapping
from companion.scenario_env import ScenarioEnv
from companion.swarm.vehicle import Sensed

TOPIC = "aco"
"""Message topic of the positions (and priorities, starts) the vehicles broadcast."""
CLIMB_M_S = 2.0
"""Climb rate of the take-off, m/s."""
ARRIVE_M = 1.0
"""Distance to the target within which it counts as reached, m."""
START_AREA = "start"
"""The world's launch area of the starts."""
GOAL_AREA = "goal"
"""The world's launch area of the targets."""


@dataclass(frozen=True)
class AcoRoleParams:
    """The ``aco_swarm`` role's ``args`` (seed 001; defaults from Sec. 4.1 and Table 1)."""

    option: int = 1
    """1: shortest path + collision avoidance (Alg. 3); 2: + formation conservation (Alg. 4)."""
    planner: str = "aco"
    """``aco`` (seed 001's Ant System) or ``astar`` (the baseline on the same roadmap)."""
    d_min_m: float = 1.0
    """D_min, the safe gap, m (Sec. 4.2's default)."""
    sense_m: float = 5.0
    """R_s, the detection range and avoidance sampling radius, m (Sec. 4.1)."""
    speed_m_s: float = 6.0
    """Commanded speed, m/s (Sec. 4.1)."""
    threshold_m: float = 0.1
    """Option 2's allowable distance change, m (Table 2's 0.1)."""
    points: int = 25
    """Avoidance points per draw (Sec. 4.1)."""
    attempts: int = 3
    """Draws of ``points`` before holding."""
    altitude_m: float = 15.0
    """Flight height above the start's ground, m (the paper gives none)."""
    altitude_band_m: float = 10.0
    """Roadmap nodes between ``altitude_m`` and this much higher, m (0: a 2-D roadmap)."""
    min_altitude_m: float = 5.0
    """Lowest avoidance point, m above ground."""
    roadmap_nodes: int = 200
    """Random roadmap points besides start and target (``RoadmapParams.nodes``)."""
    roadmap_neighbours: int = 10
    """k of the roadmap's k-nearest-neighbour edges."""
    roadmap_margin_m: float = 3.0
    """Static solids are grown by this much for the roadmap, m."""
    ants: int = 20
    """Ants per colony iteration (Table 1 gives none)."""
    iterations: int = 50
    """Colony iterations (Table 1)."""
    depart_s: float = 0.0
    """Time (the vehicle's clock, s) before which a climbed vehicle does not leave for its path:
    the fleet's common start of Alg. 3's main loop. 0: each leaves as soon as it has climbed
    (the swarm engine's vehicles climb in step). On the full stack the vehicles arm a second or
    two apart, and an option-2 formation that starts broken is chased, not kept."""
    decision_period_s: float = 0.1
    """Vehicle (simulated) seconds between two decisions of the MAVSDK adapter (``python -m
    companion.scripts.aco_swarm``). At swarm fidelity the engine's ``decision_hz`` sets it and
    this field is not read. 0.1 s keeps Eqs. 11-12's real-time bound (a cycle well under
    R_s / v = 0.83 s) with room for the vehicle to react within R_s."""

    def __post_init__(self) -> None:
        if self.option not in (1, 2):
            raise ValueError(f"option: {self.option!r} must be 1 or 2")
        if self.planner not in tuple(p.value for p in Planner):
            raise ValueError(
                f"planner: {self.planner!r} is not one of {[p.value for p in Planner]}"
            )
        for name in (
            "d_min_m", "sense_m", "speed_m_s", "threshold_m", "altitude_m", "decision_period_s",
        ):  # fmt: skip
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name}: {value!r} must be a positive number")
        for name in ("altitude_band_m", "min_altitude_m", "roadmap_margin_m", "depart_s"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise ValueError(f"{name}: {value!r} must be a number >= 0")
        for name in ("points", "attempts", "roadmap_neighbours", "ants", "iterations"):
            if not (isinstance(getattr(self, name), int) and getattr(self, name) >= 1):
                raise ValueError(f"{name}: {getattr(self, name)!r} must be an integer >= 1")
        if not (isinstance(self.roadmap_nodes, int) and self.roadmap_nodes >= 0):
            raise ValueError(f"roadmap_nodes: {self.roadmap_nodes!r} must be an integer >= 0")
        if self.min_altitude_m > self.altitude_m:
            raise ValueError(
                f"min_altitude_m: {self.min_altitude_m} must be <= altitude_m {self.altitude_m}"
            )

    def check_run(self, vehicles: int, world: Any) -> None:
        """Does the world have the zones, and does the start zone hold ``vehicles`` vehicles?

        The vehicles must stand at least ``d_min_m`` + 1 m apart (0.5 m bodies with D_min
        between them) inside the ``start`` area (``worlds.launch.spawn_points``' lattice).

        Raises:
            ValueError: no world, no ``start``/``goal`` areas, or the start zone is too small.
        """
        if world is None:
            raise ValueError("the aco_swarm role needs the scenario's world (arena_aco)")
        start, _ = zones(world)
        from worlds.launch import spawn_points

        try:
            spawn_points(start, vehicles, self.d_min_m + 1.0)
        except ValueError as exc:
            raise ValueError(
                f"the start zone (radius {start.radius_m} m) cannot hold {vehicles} vehicles "
                f"{self.d_min_m + 1.0} m apart: {exc}"
            ) from exc

    @property
    def avoidance(self) -> AvoidanceParams:
        """Alg. 2's parameters."""
        return AvoidanceParams(
            sense_m=self.sense_m,
            d_min_m=self.d_min_m,
            points=self.points,
            attempts=self.attempts,
            z_min_m=self.min_altitude_m,
        )


def zones(world: Any) -> tuple[Any, Any]:
    """The world's ``start`` and ``goal`` launch areas (ValueError naming what is missing)."""
    areas = {a.name: a for a in world.launch_areas}
    missing = [n for n in (START_AREA, GOAL_AREA) if n not in areas]
    if missing:
        raise ValueError(
            f"the world has no launch area(s) {missing} (an arena_aco world has 'start', 'goal')"
        )
    return areas[START_AREA], areas[GOAL_AREA]


def arena(world_path: str) -> Any:
    """The built world of a run (built once per process and file content)."""
    return _built_world(Path(world_path).read_text())


@functools.lru_cache(maxsize=8)
def _built_world(text: str) -> Any:
    import worlds

    return worlds.build(worlds.parse_world(text, "world"))


def aco_params(env: ScenarioEnv) -> AcoRoleParams:
    """The role's ``args`` as AcoRoleParams (unknown keys and bad values name themselves)."""
    return params_from_mapping(AcoRoleParams, env.params)


def mirror_target(
    home: np.ndarray, start_center: np.ndarray, goal_center: np.ndarray
) -> np.ndarray:
    """The goal-zone point mirroring ``home`` (east offset negated), ENU m (surface z)."""
    off = np.asarray(home, float)[:2] - np.asarray(start_center, float)[:2]
    gx, gy = np.asarray(goal_center, float)[:2]
    return np.array([gx - off[0], gy + off[1], float(goal_center[2])])


def static_prisms(world: Any, margin_m: float) -> tuple[Prism, ...]:
    """The world's static solids for the roadmap, grown by ``margin_m``."""
    out = []
    for s in world.solids:
        if s.motion is not None:
            continue
        top = float(s.center_enu_m[2]) + float(s.size_m[2]) / 2.0 + margin_m
        out.append(Prism(s.footprint_at().buffer(margin_m), top))
    return tuple(out)


@dataclass(frozen=True)
class AcoLayout:
    """Where one vehicle starts and where it goes (module docstring, "Layout")."""

    start_enu_m: np.ndarray
    """(3,) its home at ``altitude_m``, world ENU m: the path's first point."""
    target_enu_m: np.ndarray
    """(3,) its target at ``altitude_m`` in the goal zone, world ENU m: the path's last point."""
    offset_enu_m: np.ndarray
    """(3,) its home's offset from the start zone's centre (up 0), m (option 2's formation)."""
    cruise_z_m: float
    """Height of the start, ENU m: the roadmap's lowest nodes."""


def aco_layout(world: Any, params: AcoRoleParams, home_enu_m: np.ndarray, who: str) -> AcoLayout:
    """Start and target of the vehicle standing at ``home_enu_m`` (Alg. 3 line 1, Alg. 4 line 1).

    Option 1: the mirror point in the goal zone; option 2: the start translated by the zones'
    centres' offset (the formation kept). Raises ValueError naming ``who`` when the home is
    outside the start zone.
    """
    start_area, goal_area = zones(world)
    home = np.asarray(home_enu_m, float)
    if math.dist(home[:2], start_area.center_enu_m[:2]) > start_area.radius_m + 1e-6:
        raise ValueError(
            f"{who} starts at {np.round(home[:2], 2).tolist()}, outside the "
            f"start zone (centre {list(start_area.center_enu_m[:2])}, radius "
            f"{start_area.radius_m} m)"
        )
    up = np.array([0.0, 0.0, params.altitude_m])
    start_c = np.asarray(start_area.center_enu_m, float)
    goal_c = np.asarray(goal_area.center_enu_m, float)
    offset = np.array([home[0] - start_c[0], home[1] - start_c[1], 0.0])
    if params.option == 1:
        target = mirror_target(home, start_c, goal_c) + up
    else:  # the formation translated: the shared plan of the zones' centres, offset
        target = goal_c + offset + up
    return AcoLayout(home + up, target, offset, float(home[2]) + params.altitude_m)


def plan_route(
    world: Any, params: AcoRoleParams, layout: AcoLayout, seed: int, rng: np.random.Generator
) -> PlannedPath:
    """The vehicle's path before the flight (Alg. 3 lines 2-3, Alg. 4 line 4).

    Option 1: its own roadmap and colony from ``rng`` (which the decisions then go on drawing
    from); option 2: the path every UAV plans alike from the run's ``seed`` between the zones'
    centres, translated by ``layout.offset_enu_m`` (``rng`` untouched).
    """
    p = params
    sx, sy = world.size_m
    z0 = layout.cruise_z_m
    roadmap = RoadmapParams(
        nodes=p.roadmap_nodes,
        neighbours=p.roadmap_neighbours,
        min_enu_m=(-sx / 2.0, -sy / 2.0, z0),
        max_enu_m=(sx / 2.0, sy / 2.0, z0 + p.altitude_band_m),
    )
    aco = AcoParams(ants=p.ants, iterations=p.iterations)
    if p.option == 1:
        return plan_path(
            layout.start_enu_m, layout.target_enu_m, roadmap, rng, p.planner, aco,
            static_prisms(world, p.roadmap_margin_m),
        )  # fmt: skip
    start_area, goal_area = zones(world)
    c0 = np.array([start_area.center_enu_m[0], start_area.center_enu_m[1], z0])
    c1 = np.array([goal_area.center_enu_m[0], goal_area.center_enu_m[1], z0])
    plan = plan_path(
        c0, c1, roadmap, np.random.default_rng([seed]), p.planner, aco,
        static_prisms(world, p.roadmap_margin_m + start_area.radius_m),
    )  # fmt: skip
    return dataclasses.replace(plan, waypoints_enu_m=plan.waypoints_enu_m + layout.offset_enu_m)


@dataclass(frozen=True)
class Peer:
    """Another vehicle of the role as its last message (topic ``aco``) describes it."""

    index: int
    """Its role index."""
    priority: int
    start: np.ndarray
    """(3,) its start, ENU m (Alg. 4's reference)."""
    position: np.ndarray
    """(3,) where it was at ``time_s``, ENU m."""
    velocity: np.ndarray
    """(3,) its velocity then, ENU m/s."""
    time_s: float
    """When it sent the message, its vehicle time, s."""

    @classmethod
    def from_body(cls, body: dict[str, Any]) -> Peer:
        """The peer a message body (:meth:`AcoProgram.message`) describes."""
        return cls(
            int(body["k"]), int(body["prio"]), np.asarray(body["s"], float),
            np.asarray(body["p"], float), np.asarray(body["v"], float), float(body["t"]),
        )  # fmt: skip

    def at(self, now_s: float) -> np.ndarray:
        """Its position extrapolated to ``now_s`` (messages are a decision or more old)."""
        return self.position + self.velocity * max(now_s - self.time_s, 0.0)


class AcoVehicle(Protocol):
    """What :class:`AcoProgram` commands and observes of its vehicle (the adapter interface).

    The swarm engine's kinematic vehicle (``companion.swarm.vehicle.SwarmVehicle``) is one; the
    MAVSDK adapter (``companion.scripts.aco_swarm.MavsdkVehicle``) the other. World ENU, m.
    """

    priority: int
    """The vehicle's priority (smaller number: higher, Alg. 2)."""

    @property
    def position_enu_m(self) -> np.ndarray:
        """(3,) where it is (estimated on the full stack)."""

    @property
    def home_enu_m(self) -> np.ndarray:
        """(3,) where it took off."""

    @property
    def airborne(self) -> bool:
        """Flying (False once down: landed, or brought down)."""

    @property
    def path_index(self) -> int:
        """Index of the waypoint of the last ``fly_path`` being flown to."""

    @property
    def path_done(self) -> bool:
        """Climbed (after ``takeoff``), or at the last waypoint of the path."""

    def takeoff(self, height_m: float, climb_m_s: float | None = None) -> None:
        """Arm and climb to ``height_m`` above home."""

    def fly_path(self, waypoints_enu_m: np.ndarray, speed_m_s: float) -> None:
        """Fly through the waypoints ((K, 3)) at ``speed_m_s``, stopping at the last."""

    def set_velocity(self, velocity_enu_m_s: np.ndarray) -> None:
        """Hold this velocity (m/s) until the next command (zeros: brake and hover)."""

    def land(self) -> None:
        """Descend where it is, touch down, disarm."""

    def sense(self, radius_m: float) -> list[Sensed]:
        """Solids and other vehicles within ``radius_m`` of its body (Eq. 14), nearest first."""


class AcoProgram:
    """One vehicle of seed 001's swarm (see the module docstring)."""

    def __init__(self, env: ScenarioEnv, vehicle: AcoVehicle, node: Any) -> None:
        if env.world is None:
            raise ValueError("the aco_swarm role needs the run's world (arena_aco)")
        self.env, self.vehicle, self.node = env, vehicle, node
        self.params = p = aco_params(env)
        self.avoid_params = p.avoidance
        world = arena(str(env.world))
        self.layout = aco_layout(world, p, vehicle.home_enu_m, f"vehicle {env.vehicle}")
        self.start, self.target = self.layout.start_enu_m, self.layout.target_enu_m
        self.rng = np.random.default_rng([env.seed, env.vehicle])
        plan = plan_route(world, p, self.layout, env.seed, self.rng)
        self.waypoints = plan.waypoints_enu_m
        self.plan_ms = plan.plan_ms
        self.path_length_m = plan.length_m
        self.phase = "takeoff"
        self.error: str | None = None
        self.base = 0
        """Index in ``waypoints`` of the first waypoint of the path last given to fly_path."""
        self._resume_at = 0
        """Index of the waypoint to resume the path at after a hold."""
        self.lead = 0
        """Avoidance points ahead of ``waypoints[base]`` in the path given to fly_path (0, 1)."""
        self.point: np.ndarray | None = None
        self.divergences = 0
        self.holds = 0
        self.total_dist_m = 0.0
        self.mission_start_s = math.nan
        self.arrived_s = math.nan
        self.reached = False
        self.peers: dict[str, Peer] = {}
        self.tracker = FormationTracker()
        self._last: tuple[float, np.ndarray] | None = None
        self._velocity = np.zeros(3)

    @property
    def done(self) -> bool:
        """Landed at the target, or the vehicle is down."""
        return self.phase in ("done", "down")

    @property
    def index(self) -> int:
        """Index in ``waypoints`` of the current path waypoint."""
        if self.phase in ("path", "arrive"):
            k = self.base + max(self.vehicle.path_index - self.lead, 0)
        else:
            k = self._resume_at
        return min(k, len(self.waypoints) - 1)

    @property
    def waypoint(self) -> np.ndarray:
        """The current path waypoint (the one Alg. 2 scores avoidance points against)."""
        return self.waypoints[self.index]

    @property
    def diverting(self) -> bool:
        """Flying to an avoidance (or restoring) point, not yet back on the path."""
        return self.phase == "path" and self.vehicle.path_index < self.lead

    def decide(self, now_s: float) -> None:
        """One tick of Alg. 3 (option 1) or Alg. 4 (option 2)."""
        v, p = self.vehicle, self.params
        if self.done:
            return
        if self.phase == "takeoff":
            v.takeoff(p.altitude_m, CLIMB_M_S)
            self.phase = "climb"
            return
        if not v.airborne:
            self.phase = "done" if self.phase == "land" else "down"
            return
        if self.phase == "land":
            return
        here = np.asarray(v.position_enu_m, float)
        self._odometry(now_s, here)
        self._messages(now_s, here)
        if self.phase == "climb":
            if v.path_done and now_s >= self.params.depart_s:
                self.mission_start_s = now_s
                self._fly_from(0)
            return
        if self.phase == "path" and v.path_done:  # within the autopilot's acceptance radius
            self.phase = "arrive"
        if self.phase == "arrive" and math.dist(here, self.target) <= ARRIVE_M:
            self.reached = True
            self.arrived_s = now_s
            v.land()
            self.phase = "land"
            return
        self._avoid(now_s, here)

    def _avoid(self, now_s: float, here: np.ndarray) -> None:
        v, p = self.vehicle, self.params
        waypoint = self.waypoint
        aim = self.point if self.diverting and self.point is not None else waypoint
        sensed = self._sensed(here)
        d = avoid(here, aim, waypoint, v.priority, sensed, p.speed_m_s, self.rng, self.avoid_params)
        if d.action is Action.DIVERT:
            self._divert(d.point)
            return
        if d.action is Action.HOLD:
            if self.phase != "hold":
                self._resume_at = self.index
                self.holds += 1
            v.set_velocity(np.zeros(3))
            self.phase = "hold"
            return
        if self.phase == "hold":  # restore the path
            self._fly_from(self._resume_at)
            return
        if p.option == 2 and self.phase == "path" and not self.diverting:
            self._formation(now_s, here, sensed)

    def _formation(self, now_s: float, here: np.ndarray, sensed: list[Obstacle]) -> None:
        """Alg. 4: this UAV's row against the reference; divert to a restoring point if broken."""
        n = self.env.role_count
        i = self.env.role_index
        starts = np.full((n, 3), np.nan)
        pos = np.full((n, 3), np.nan)
        vel = np.zeros((n, 3))
        starts[i], pos[i], vel[i] = self.start, here, self._velocity
        for peer in self.peers.values():
            if 0 <= peer.index < n:
                starts[peer.index], pos[peer.index] = peer.start, peer.at(now_s)
                vel[peer.index] = peer.velocity
        ref = reference_distances(starts)
        cur = current_distances(pos)
        self.tracker.add(i, cur, ref)
        if in_formation(i, cur, ref, self.params.threshold_m):
            return
        point = restoring_point(
            i, here, pos, vel, ref, self.params.speed_m_s, sensed, self.rng, self.avoid_params,
            waypoint=self.waypoint,
        )  # fmt: skip
        if point is not None:
            self._divert(point)

    def _divert(self, point: np.ndarray) -> None:
        """Adopt an avoidance point: fly through it and on along the rest of the path."""
        k = self.index
        self.point = np.asarray(point, float)
        self._fly(k, self.point)
        self.divergences += 1

    def _fly_from(self, k: int) -> None:
        self._fly(min(k, len(self.waypoints) - 1), None)

    def _fly(self, k: int, point: np.ndarray | None) -> None:
        rest = self.waypoints[k:]
        self.base, self._resume_at = k, k
        self.lead = 0 if point is None else 1
        if point is not None:
            rest = np.vstack([point, rest])
        else:
            self.point = None
        self.vehicle.fly_path(rest, self.params.speed_m_s)
        self.phase = "path"

    def _odometry(self, now_s: float, here: np.ndarray) -> None:
        if self._last is not None:
            t0, x0 = self._last
            if now_s > t0:
                self._velocity = (here - x0) / (now_s - t0)
            if self.phase in ("path", "hold", "arrive"):
                self.total_dist_m += float(np.linalg.norm(here - x0))
        self._last = (now_s, here)

    def _messages(self, now_s: float, here: np.ndarray) -> None:
        if self.node is None:
            return
        for env in self.node.poll():
            if env.topic != TOPIC or not isinstance(env.body, dict):
                continue
            self.peers[env.src] = Peer.from_body(env.body)
        self.node.broadcast(TOPIC, self.message(now_s, here))

    def message(self, now_s: float, here: np.ndarray) -> dict[str, Any]:
        """This vehicle's broadcast (topic ``aco``; :meth:`Peer.from_body` reads it).

        Role index, time, priority, start, position, velocity.
        """
        return {
            "k": self.env.role_index,
            "t": round(float(now_s), 4),
            "prio": int(self.vehicle.priority),
            "s": [round(float(c), 3) for c in self.start],
            "p": [round(float(c), 3) for c in here],
            "v": [round(float(c), 3) for c in self._velocity],
        }

    def _sensed(self, here: np.ndarray) -> list[Obstacle]:
        out = []
        for s in self.vehicle.sense(self.params.sense_m):
            peer = self.peers.get(s.name) if s.kind == "vehicle" else None
            out.append(
                obstacle(
                    here,
                    s.position_enu_m,
                    s.velocity_enu_m_s,
                    s.distance_m,
                    s.kind,
                    s.name,
                    None if peer is None else peer.priority,
                )
            )
        return out

    def metrics(self) -> dict[str, tuple[Any, str]]:
        """This vehicle's seed-001 quantities (``companion.scripts.aco_swarm.run_metrics``)."""
        travel = self.arrived_s - self.mission_start_s

        def num(x: float, nd: int = 3) -> float | None:
            return None if not math.isfinite(x) else round(float(x), nd)

        return {
            "reached": (bool(self.reached), "bool"),
            "min_dist_m": (num(straight_line_length(self.start, self.target)), "m"),
            "total_dist_m": (num(self.total_dist_m), "m"),
            "travel_time_s": (num(travel), "s"),
            "mission_start_s": (num(self.mission_start_s), "s"),
            "arrived_s": (num(self.arrived_s), "s"),
            "divergences": (self.divergences, "count"),
            "holds": (self.holds, "count"),
            "avg_dist_change_m": (num(self.tracker.avg_dist_change_m, 4), "m"),
            "plan_ms": (num(self.plan_ms), "ms"),
            "path_length_m": (num(self.path_length_m), "m"),
            "option": (self.params.option, "count"),
            "phase": (self.phase, "name"),
        }
