"""The swarm-scale engine: kinematic vehicles, node messaging and companion programs in one loop.

``SwarmEngine`` advances a :class:`sitl.kinematic_fleet.KinematicFleet` at ``step_hz`` and, at
``decision_hz``, refreshes what the programs observe and lets every program decide: where the
vehicles are (the link network's node positions, for range and coverage), each node's neighbour
table (the ``neighbours`` nearest nodes within the edge-edge link's range, one KD-tree query for
the fleet), and which targets each camera sees (world targets and Poisson events, one KD-tree
query). Messages travel through the same :class:`sitl.links.network.LinkNetwork` and
``companion.net.Node`` as in the full stack, over an :class:`~sitl.links.inprocess.InProcessPort`
in simulation time. Each kinematic step drains every vehicle's pack
(:class:`sitl.power.hover_drain.HoverDrain`); each decision counts every airborne vehicle's links
(the other airborne vehicles within ``link_range_m``, one KD-tree query). ``VehicleHandle`` is the
kinematic adapter a program gets (``companion.swarm.SwarmVehicle``). The scenario's faults are
applied at the first kinematic step at or after their time: a crashed vehicle drops to the
ground and stays there, taking no commands (its program keeps deciding, and the run waits for
it as the full stack waits for its companion); a land fault lands the vehicle as the autopilot's
Land mode does (a later command flies it again); a radio fault silences the node at its port.
Deterministic: one generator per run, programs called in vehicle order.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from companion.swarm.vehicle import Detection, Sensed, SwarmProgram
from harness.report.collisions import CollisionCounter, contacts
from harness.scenarios.faults import Fault
from sitl.kinematic_fleet import KinematicFleet
from sitl.power.hover_drain import HoverDrain
from worlds.solid_set import SolidSet


@dataclass(frozen=True)
class Target:
    """Something a camera can see: a world target or a Poisson event."""

    name: str
    xy_m: tuple[float, float]
    """Centre, east and north, m."""
    radius_m: float
    """Radius of a disc of the target's area, m (it is seen when that disc meets the footprint)."""
    appear_s: float
    """When it appears, simulated s."""


def poisson_events(
    rate_hz: float, duration_s: float, bounds_xy_m: tuple[float, float, float, float],
    rng: np.random.Generator, inside: Callable[[np.ndarray], np.ndarray] | None = None,
) -> list[Target]:  # fmt: skip
    """Targets appearing as a Poisson process of ``rate_hz`` at uniform points of the bounds.

    ``inside`` (optional) keeps only points it accepts ((K, 2) -> (K,) bool; points are drawn
    again until accepted, up to 100 rounds).
    """
    if rate_hz <= 0.0 or duration_s <= 0.0:
        return []
    count = int(rng.poisson(rate_hz * duration_s))
    times = np.sort(rng.uniform(0.0, duration_s, count))
    x0, y0, x1, y1 = bounds_xy_m
    points = np.column_stack((rng.uniform(x0, x1, count), rng.uniform(y0, y1, count)))
    if inside is not None and count:
        for _ in range(100):
            bad = ~inside(points)
            if not bad.any():
                break
            k = int(bad.sum())
            points[bad] = np.column_stack((rng.uniform(x0, x1, k), rng.uniform(y0, y1, k)))
    return [
        Target(f"event_{k}", (float(p[0]), float(p[1])), 0.0, float(t))
        for k, (t, p) in enumerate(zip(times, points, strict=True))
    ]


RadioFault = Callable[[str, bool, bool], None]
"""``(node_id, tx, rx)``: silence a node's radio from now on (sending, hearing)."""


@dataclass
class EngineStats:
    """What the engine counted while running."""

    decisions: int = 0
    """Program decisions made."""
    decision_wall_s: float = 0.0
    """Wall time spent inside the programs' ``decide``, s (not simulation; never compared)."""
    min_separation_m: float = math.inf
    min_separation_at_s: float = math.nan
    min_separation_airborne_m: float = math.inf
    first_seen_s: dict[str, float] = field(default_factory=dict)
    """Target name -> when some camera first saw it, s."""
    outside_world: set[int] = field(default_factory=set)
    """Vehicles that left the world's boundary."""
    errors: dict[int, str] = field(default_factory=dict)
    """Vehicle index -> the exception its program raised."""
    link_decisions: int = 0
    """Decision ticks at which links were counted (the first entries of ``series_*``)."""
    last_landing_s: float | None = None
    """When a vehicle last touched down, simulated s (None: none has landed)."""


class VehicleHandle:
    """The kinematic adapter of one vehicle (``companion.swarm.SwarmVehicle``)."""

    def __init__(self, engine: SwarmEngine, index: int, node_id: str) -> None:
        self._engine = engine
        self._fleet = engine.fleet
        self.index = index
        self.node_id = node_id
        self.priority = int(engine.priority[index])
        self._seen: list[Detection] = []

    @property
    def time_s(self) -> float:
        """Simulation time, s."""
        return self._engine.time_s

    @property
    def position_enu_m(self) -> np.ndarray:
        """(3,) ENU position, m (a copy)."""
        return self._fleet.state.position_m[self.index].copy()

    @property
    def home_enu_m(self) -> np.ndarray:
        """(3,) start point, m."""
        return self._engine.home_m[self.index].copy()

    @property
    def airborne(self) -> bool:
        """Off the ground."""
        return bool(self._fleet.state.airborne[self.index])

    @property
    def battery_remaining_pct(self) -> float:
        """Charge remaining in the pack, % (NaN: the engine models no battery)."""
        power = self._engine.power
        return math.nan if power is None else float(power.remaining_pct[self.index])

    @property
    def path_index(self) -> int:
        """Index of the waypoint being flown to."""
        return int(self._fleet.index[self.index])

    @property
    def path_done(self) -> bool:
        """At the last waypoint, or resting."""
        return bool(self._engine.path_done[self.index])

    def takeoff(self, height_m: float, climb_m_s: float | None = None) -> None:
        """Arm and climb to ``height_m`` above the ground."""
        if self._engine.crashed[self.index]:
            return  # a crashed vehicle takes no commands
        self._fleet.takeoff(self.index, height_m, climb_m_s)
        self._engine.path_done[self.index] = False

    def fly_path(self, waypoints_enu_m: np.ndarray, speed_m_s: float) -> None:
        """Fly the waypoints at ``speed_m_s``."""
        if self._engine.crashed[self.index]:
            return  # a crashed vehicle takes no commands
        self._fleet.set_path(self.index, waypoints_enu_m, speed_m_s)
        self._engine.path_done[self.index] = False

    def set_velocity(self, velocity_enu_m_s: np.ndarray) -> None:
        """Hold this ENU velocity, m/s, within the limits, until another command."""
        if self._engine.crashed[self.index]:
            return  # a crashed vehicle takes no commands
        self._fleet.set_velocity(self.index, velocity_enu_m_s)
        self._engine.path_done[self.index] = False

    def goto(self, position_enu_m: np.ndarray, speed_m_s: float) -> None:
        """Fly straight to ``position_enu_m`` at ``speed_m_s`` and hold there."""
        self.fly_path(np.asarray(position_enu_m, dtype=float).reshape(1, 3), speed_m_s)

    def sense(self, radius_m: float) -> list[Sensed]:
        """Solids and airborne vehicles within ``radius_m`` of the body, nearest first."""
        return self._engine.sense(self.index, radius_m)

    def land(self) -> None:
        """Land where it is."""
        if self._engine.crashed[self.index]:
            return  # a crashed vehicle takes no commands
        self._fleet.land(self.index)
        self._engine.path_done[self.index] = False

    def neighbours(self) -> list[str]:
        """Nearest nodes within radio range, nearest first."""
        return self._engine.neighbour_ids(self.index)

    def observe(self, detection: Detection) -> None:
        """The engine's camera model saw ``detection`` (handed out by ``detections``)."""
        self._seen.append(detection)

    def detections(self) -> list[Detection]:
        """Targets seen since the last call."""
        out, self._seen = self._seen, []
        return out


class SwarmEngine:
    """Kinematic fleet + targets + neighbour tables + programs (see the module docstring).

    Args:
        fleet: the vehicles.
        node_ids: each vehicle's messaging node id.
        step_hz: kinematic steps per simulated second.
        decision_hz: program decisions per simulated second (divides ``step_hz``).
        neighbours: nodes per neighbour table.
        radio_range_m: neighbours farther than this are not listed, m (inf: no limit).
        camera_tan_half_fov: (N,) ``tan(hfov / 2)`` of each vehicle's down camera; NaN: none.
        targets: what the cameras can see.
        inside_world: (K, 2) -> (K,) bool, the world's boundary test (None: no boundary).
        power: the vehicles' packs, drained each kinematic step (None: no battery model).
        link_range_m: two airborne vehicles closer than this are linked, m (None:
            ``radio_range_m``).
        faults: the scenario's faults, in time order (``Scenario.faults``).
        radio_fault: silences a node's radio (the messaging port's); None: radio faults are
            recorded but act on nothing.
        radius_m: (N,) each vehicle's radius (half its airframe's diameter), m, for sensing and
            collisions (None: 0, points).
        solids: the world's solids (None: none), for sensing and collisions.
        priority: each vehicle's priority (None: its vehicle number, ``index + 1``).

    At each decision the engine counts, for every airborne vehicle, the other airborne vehicles
    within ``link_range_m`` (its links): ``links_total`` sums them per vehicle; ``series_time_s``,
    ``series_active`` (airborne vehicles) and ``series_links_mean`` (mean links per airborne
    vehicle, 0 with none) hold one entry per position sample (each decision, then the end of a
    run that reached its duration).

    After every kinematic step the engine counts collisions (``harness.report.collisions``:
    contact events of airborne vehicles with each other and with the solids) in ``collisions``.
    ``sense(i, radius)`` answers a program's obstacle query from a KD-tree over the vehicles
    (built once per simulated instant) and one over the solids' centres at that instant.
    """

    def __init__(
        self,
        fleet: KinematicFleet,
        node_ids: list[str],
        step_hz: float,
        decision_hz: float,
        neighbours: int,
        radio_range_m: float,
        camera_tan_half_fov: np.ndarray,
        targets: list[Target],
        inside_world: Callable[[np.ndarray], np.ndarray] | None = None,
        power: HoverDrain | None = None,
        link_range_m: float | None = None,
        faults: Sequence[Fault] = (),
        radio_fault: RadioFault | None = None,
        radius_m: np.ndarray | None = None,
        solids: SolidSet | None = None,
        priority: Sequence[int] | None = None,
    ) -> None:
        self.fleet = fleet
        self.node_ids = node_ids
        self.dt_s = 1.0 / step_hz
        self.steps_per_decision = round(step_hz / decision_hz)
        self.k_neighbours = int(neighbours)
        self.radio_range_m = float(radio_range_m)
        self.camera_tan = np.asarray(camera_tan_half_fov, dtype=float)
        self.targets = sorted(targets, key=lambda t: (t.appear_s, t.name))
        self.inside_world = inside_world
        self.power = power
        self.link_range_m = self.radio_range_m if link_range_m is None else float(link_range_m)
        self.links_total = np.zeros(fleet.n, dtype=np.int64)
        """Links of each vehicle summed over the decisions (see the class docstring)."""
        self.series_time_s: list[float] = []
        self.series_active: list[int] = []
        self.series_links_mean: list[float] = []
        self.home_m = fleet.state.position_m.copy()
        self.radius_m = (
            np.zeros(fleet.n) if radius_m is None else np.asarray(radius_m, dtype=float).copy()
        )
        self.solids = solids if solids is not None and len(solids) else None
        self.priority = list(range(1, fleet.n + 1)) if priority is None else list(priority)
        if len(self.priority) != fleet.n or len(self.radius_m) != fleet.n:
            raise ValueError(f"radius_m and priority: one per vehicle ({fleet.n})")
        self.collisions = CollisionCounter(
            fleet.n, self.solids.names if self.solids else [], list(node_ids)
        )
        """Contact events so far (see the class docstring)."""
        self._sense_at = -1
        self._vehicle_tree: cKDTree | None = None
        self._airborne_rows = np.zeros(0, dtype=int)
        self._solid_velocity = np.zeros((0, 3))
        self.steps = 0
        self.time_s = 0.0
        self.path_done = np.ones(fleet.n, dtype=bool)
        self.handles = [VehicleHandle(self, i, node_ids[i]) for i in range(fleet.n)]
        self.programs: list[SwarmProgram | None] = [None] * fleet.n
        self.stats = EngineStats()
        self._neighbours = np.full((fleet.n, self.k_neighbours), -1, dtype=int)
        self._seen_by: list[set[str]] = [set() for _ in range(fleet.n)]
        self._before_decisions: list[Callable[[SwarmEngine], None]] = []
        self.samples: list[np.ndarray] = []
        """Positions at each decision, (N, 3) each."""
        self.faults = sorted(faults, key=lambda f: f.time_s)
        self.radio_fault = radio_fault
        self.crashed = np.zeros(fleet.n, dtype=bool)
        """(N,) bool: crashed by a fault (lies on the ground, takes no commands)."""
        self.fault_records: list[dict[str, Any]] = []
        """The faults applied so far, each ``Fault.record(time applied)`` with ``applied``."""
        self._next_fault = 0

    def on_decision(self, hook: Callable[[SwarmEngine], None]) -> None:
        """Call ``hook(engine)`` at each decision tick before the programs decide."""
        self._before_decisions.append(hook)

    # -- observations ---------------------------------------------------------------------

    def neighbour_ids(self, i: int) -> list[str]:
        """Node ids of vehicle ``i``'s neighbour table."""
        return [self.node_ids[j] for j in self._neighbours[i] if j >= 0]

    def _sense_state(self) -> None:
        """The KD-tree of the airborne vehicles and the solids' velocities, once per step."""
        if self._sense_at == self.steps:
            return
        self._sense_at = self.steps
        up = np.flatnonzero(self.fleet.state.airborne)
        self._airborne_rows = up
        self._vehicle_tree = cKDTree(self.fleet.state.position_m[up]) if len(up) else None
        if self.solids is not None:
            self._solid_velocity = self.solids.velocities_at(self.time_s)

    def sense(self, i: int, radius_m: float) -> list[Sensed]:
        """What vehicle ``i`` senses within ``radius_m`` (``SwarmVehicle.sense``), nearest first."""
        self._sense_state()
        s = self.fleet.state
        me = s.position_m[i]
        r_me = float(self.radius_m[i])
        out: list[Sensed] = []
        if self._vehicle_tree is not None:
            reach = radius_m + r_me + float(self.radius_m.max())
            for row in self._vehicle_tree.query_ball_point(me, reach):
                j = int(self._airborne_rows[row])
                if j == i:
                    continue
                p = s.position_m[j]
                d = math.dist(p, me) - r_me - float(self.radius_m[j])
                if d <= radius_m:
                    c, sn = math.cos(s.course_rad[j]), math.sin(s.course_rad[j])
                    v = (
                        float(s.speed_m_s[j] * c),
                        float(s.speed_m_s[j] * sn),
                        float(s.climb_m_s[j]),
                    )
                    out.append(Sensed("vehicle", self.node_ids[j], tuple(map(float, p)), v, d))
        if self.solids is not None:
            _, ks, closest = self.solids.near(me[None, :], radius_m + r_me, self.time_s)
            for k, c in zip(ks, closest, strict=True):
                d = math.dist(c, me) - r_me
                v = tuple(float(x) for x in self._solid_velocity[k])
                out.append(Sensed("solid", self.solids.names[k], tuple(map(float, c)), v, d))
        out.sort(key=lambda x: x.distance_m)
        return out

    def _count_collisions(self) -> None:
        s = self.fleet.state
        vv, vs = contacts(s.position_m, s.airborne, self.radius_m, self.solids, self.time_s)
        self.collisions.update(self.time_s, vv, vs)

    def _refresh_neighbours(self, pos: np.ndarray) -> None:
        n, k = self.fleet.n, self.k_neighbours
        if k == 0 or n < 2:
            return
        tree = cKDTree(pos)
        kk = min(k + 1, n)
        dist, idx = tree.query(pos, k=kk, distance_upper_bound=self.radio_range_m)
        idx = np.where(np.isfinite(dist), idx, -1).reshape(n, kk)
        own = idx == np.arange(n)[:, None]
        order = np.argsort(own, axis=1, kind="stable")  # each row's own index last, order kept
        ranked = np.take_along_axis(idx, order, axis=1)[:, : kk - 1]
        table = np.full((n, k), -1, dtype=int)
        table[:, : ranked.shape[1]] = ranked
        self._neighbours = table

    def _refresh_detections(self, pos: np.ndarray) -> None:
        if not self.targets:
            return
        now = self.time_s
        active = [t for t in self.targets if t.appear_s <= now]
        if not active:
            return
        airborne = self.fleet.state.airborne & np.isfinite(self.camera_tan)
        if not airborne.any():
            return
        which = np.flatnonzero(airborne)
        reach = np.maximum(pos[which, 2], 0.0) * self.camera_tan[which]  # footprint on z = 0
        centres = np.array([t.xy_m for t in active])
        radii = np.array([t.radius_m for t in active])
        tree = cKDTree(centres)
        hits = tree.query_ball_point(pos[which, :2], reach + radii.max())
        for i, r, found in zip(which, reach, hits, strict=True):
            for j in found:
                t = active[j]
                if t.name in self._seen_by[i]:
                    continue
                if math.dist(pos[i, :2], t.xy_m) <= r + t.radius_m:
                    self._seen_by[i].add(t.name)
                    self.stats.first_seen_s.setdefault(t.name, now)
                    self.handles[i].observe(Detection(t.name, t.xy_m, t.appear_s, now))

    def _separation(self, pos: np.ndarray) -> None:
        n = self.fleet.n
        if n < 2:
            return
        dist, _ = cKDTree(pos).query(pos, k=2)
        nearest = dist[:, 1]
        d = float(nearest.min())
        if d < self.stats.min_separation_m:
            self.stats.min_separation_m = d
            self.stats.min_separation_at_s = self.time_s
        up = np.flatnonzero(self.fleet.state.airborne)
        if len(up) >= 2:
            dist_up, _ = cKDTree(pos[up]).query(pos[up], k=2)
            self.stats.min_separation_airborne_m = min(
                self.stats.min_separation_airborne_m, float(dist_up[:, 1].min())
            )

    def _links(self, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The airborne vehicles and, for each, the other airborne ones within link range."""
        up = np.flatnonzero(self.fleet.state.airborne)
        if len(up) < 2:
            return up, np.zeros(len(up), dtype=np.int64)
        if not math.isfinite(self.link_range_m):
            return up, np.full(len(up), len(up) - 1, dtype=np.int64)
        near = cKDTree(pos[up]).query_ball_point(pos[up], self.link_range_m, return_length=True)
        return up, np.asarray(near, dtype=np.int64) - 1

    def _sample(self, pos: np.ndarray, decision: bool) -> None:
        """Record the positions and the links; at a decision, add the links to the totals."""
        self.samples.append(pos.copy())
        up, links = self._links(pos)
        if decision:
            self.links_total[up] += links
            self.stats.link_decisions += 1
        self.series_time_s.append(self.time_s)
        self.series_active.append(len(up))
        self.series_links_mean.append(float(links.mean()) if len(up) else 0.0)

    # -- faults ---------------------------------------------------------------------------

    def _apply_faults(self) -> None:
        """Apply every fault due by now (see the module docstring)."""
        while self._next_fault < len(self.faults):
            fault = self.faults[self._next_fault]
            if fault.time_s > self.time_s + 1e-9:
                return
            self._next_fault += 1
            i = fault.vehicle
            if "crash" in fault.kinds:
                self.fleet.crash(i)
                self.crashed[i] = True
            elif "land" in fault.kinds and self.fleet.state.airborne[i]:
                self.fleet.land(i)  # as the autopilot's Land mode: a later command flies again
            tx, rx = fault.silences
            if (tx or rx) and self.radio_fault is not None:
                self.radio_fault(self.node_ids[i], tx, rx)
            self.fault_records.append(fault.record(self.time_s))

    def pending_fault_records(self) -> list[dict[str, Any]]:
        """The faults not applied (due after the run's end): ``time_s`` None, not applied."""
        return [f.record(None) for f in self.faults[self._next_fault :]]

    # -- the loop -------------------------------------------------------------------------

    def _decide(self) -> None:
        pos = self.fleet.state.position_m
        self.path_done = self.fleet.path_done()
        self._sample(pos, decision=True)
        self._separation(pos)
        if self.inside_world is not None:
            up = np.flatnonzero(self.fleet.state.airborne)
            if len(up):
                out = up[~self.inside_world(pos[up, :2])]
                self.stats.outside_world.update(int(i) for i in out)
        self._refresh_neighbours(pos)
        self._refresh_detections(pos)
        for hook in self._before_decisions:
            hook(self)
        now = self.time_s
        t0 = time.perf_counter()
        for i, program in enumerate(self.programs):
            if program is None or i in self.stats.errors or program.done:
                continue
            try:
                program.decide(now)
            except Exception as exc:  # one program's failure lands its vehicle, not the run
                self.stats.errors[i] = f"{type(exc).__name__}: {exc}"
                if self.fleet.state.airborne[i]:
                    self.fleet.land(i)
            self.stats.decisions += 1
        self.stats.decision_wall_s += time.perf_counter() - t0

    def all_done(self) -> bool:
        """Every program finished (or failed) and every vehicle is on the ground."""
        finished = all(
            p is None or p.done or i in self.stats.errors for i, p in enumerate(self.programs)
        )
        return finished and not self.fleet.state.airborne.any()

    def run(self, duration_s: float, end_when_done: bool = True) -> str:
        """Run to ``duration_s`` simulated seconds (or until all done); return why it stopped."""
        total = round(duration_s / self.dt_s)
        while self.steps < total:
            self._apply_faults()
            if self.steps % self.steps_per_decision == 0:
                self._decide()
                if end_when_done and self.steps > 0 and self.all_done():
                    return "done"
            airborne = self.fleet.state.airborne
            end_s = (self.steps + 1) * self.dt_s
            if self.power is not None:
                self.power.draw(airborne, self.dt_s, end_s)
            was_up = airborne.copy()
            self.fleet.step(self.dt_s)
            if (was_up & ~self.fleet.state.airborne).any():
                self.stats.last_landing_s = end_s
            self.steps += 1
            self.time_s = end_s
            self._count_collisions()
        self.path_done = self.fleet.path_done()
        self._sample(self.fleet.state.position_m, decision=False)
        return "duration"
