"""Seed 004's whole plan, from a workspace and a fleet to one task per vehicle.

The five stages of Sec. 4.2, run once before take-off: world abstraction (Eq. 1) -> partition
(MCO's extended Voronoi, or a baseline: Boustrophedon cells, K-means) -> roles (Master,
Coordinators, Operators) -> a tour per sub-area (discrete Firefly TSP, or zigzag) -> the adapted
FIPA English auction (Eq. 2) giving each vehicle one sub-area. Every vehicle of a run computes
the same plan from the same inputs (workspace, parameters, fleet, take-off point, seed) and flies
its own task, so the plan needs no message (the paper's ground station would broadcast it).
Pure: no I/O.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from companion.planning.mco.auction import AuctionResult, Bidder, Task, english_auction
from companion.planning.mco.boustrophedon import boustrophedon_cell_count, boustrophedon_partition
from companion.planning.mco.firefly import FireflyParams, firefly_tour
from companion.planning.mco.kmeans import kmeans_partition
from companion.planning.mco.partition import Partition, heterogeneity_std_pct, mco_partition
from companion.planning.mco.roles import Role, assign_roles
from companion.planning.mco.tours import tour_length_m, zigzag_order
from companion.planning.mco.workspace import Camera, Grid, Workspace, build_grid

PLANNERS = ("mco_firefly", "mco_zigzag", "boustrophedon", "kmeans")
"""Partition + tour pairs of Sec. 5: MCO with Firefly tours (Sec. 5.3), MCO and the two baselines
with zigzag tours (Sec. 5.2)."""


@dataclass(frozen=True)
class McoParams:
    """The MCO role's arguments (``SWARMSITL_PARAMS``), SI units."""

    planner: str = "mco_firefly"
    """One of PLANNERS."""
    speed_m_s: float = 10.0
    """Cruise speed of every vehicle (P4: same speed for all), m/s; the paper gives none."""
    altitude_m: float | None = None
    """Flight height above the take-off point (P4: same for all), m; None: the height at which
    the camera gives ``gsd_m`` (42.2 m for the paper's camera)."""
    altitude_step_m: float = 0.0
    """Vehicle k flies ``altitude_m + k * altitude_step_m`` (0: the paper's one altitude; the
    full stack staggers transits, which P5's disjoint sub-areas do not separate near p0)."""
    overlap: float = 0.75
    """Longitudinal and cross overlap p = q of neighbouring footprints (Sec. 5: 75 %)."""
    aov_deg: float = 87.0
    """Camera angle of view across the image width, degrees (Sec. 5)."""
    width_px: int = 4000
    height_px: int = 3000
    gsd_m: float = 0.02
    """Ground sample distance, m per pixel (Sec. 5: 2 cm)."""
    coordinators: int = 4
    """Coordinators per partition level (Sec. 4.2.3)."""
    fa_population: int = 500
    """Fireflies (Sec. 4.2.4's benchmark: 500)."""
    fa_iterations: int = 5000
    """Firefly iterations (Sec. 4.2.4's benchmark: 5000)."""
    climb_m_s: float = 2.0
    """Climb rate the flight-time estimate uses, m/s."""

    def __post_init__(self) -> None:
        if self.planner not in PLANNERS:
            raise ValueError(f"planner: {self.planner!r} is not one of {list(PLANNERS)}")
        for name in ("speed_m_s", "gsd_m", "aov_deg", "climb_m_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name}: {value!r} must be a positive number")
        if self.altitude_m is not None and not self.altitude_m > 0:
            raise ValueError(f"altitude_m: {self.altitude_m!r} must be positive")
        if not 0.0 <= self.overlap < 1.0:
            raise ValueError(f"overlap: {self.overlap!r} must be in [0, 1)")
        if self.width_px <= 0 or self.height_px <= 0:
            raise ValueError(f"width_px, height_px: {self.width_px} x {self.height_px} px")
        if self.coordinators < 0:
            raise ValueError(f"coordinators: {self.coordinators} must be >= 0")

    def check_run(self, vehicles: int, world: Any) -> None:
        """Can ``vehicles`` vehicles share ``world``'s workspace (``companion.role_params``)?

        Raises:
            ValueError: what ``check_fleet_size`` raises, or no world to plan.
        """
        if world is None:
            raise ValueError("the MCO role needs the scenario's world: the workspace to cover")
        from companion.planning.mco.role import workspace_of

        check_fleet_size(workspace_of(world)[0], self, vehicles)

    @property
    def camera(self) -> Camera:
        """The survey camera."""
        return Camera(self.aov_deg, self.width_px, self.height_px, self.gsd_m)

    @property
    def flight_altitude_m(self) -> float:
        """The survey height, m."""
        return self.altitude_m if self.altitude_m is not None else self.camera.altitude_m()

    @property
    def firefly(self) -> FireflyParams:
        """The Firefly TSP's parameters."""
        return FireflyParams(population=self.fa_population, iterations=self.fa_iterations)


@dataclass(frozen=True)
class VehicleTask:
    """What one vehicle flies."""

    vehicle: int
    """The vehicle (``Bidder.vehicle``)."""
    sub_area: int
    role: Role
    waypoints_xy_m: np.ndarray
    """(K, 2) the sub-area's waypoints in flying order (the tour without the take-off point)."""
    path_length_m: float
    """Take-off point -> tour -> take-off point, m."""
    flight_time_s: float
    """The path at cruise speed plus the climb and the descent, s (what the auction asks for)."""


@dataclass(frozen=True)
class MissionPlan:
    """The plan of the whole fleet."""

    grid: Grid
    partition: Partition
    roles: tuple[Role, ...]
    """Role of each sub-area."""
    tasks: tuple[VehicleTask, ...]
    """One per vehicle, in the order of the fleet given."""
    auction: AuctionResult
    heterogeneity_std_pct: float
    """Std of the sub-areas' waypoint counts over the total, % (Fig. 15)."""

    @property
    def waypoints(self) -> int:
        """Free waypoints of the workspace."""
        return len(self.grid.waypoints_xy_m)

    def task_of(self, vehicle: int) -> VehicleTask:
        """The task of ``vehicle``; KeyError naming the vehicles otherwise."""
        for task in self.tasks:
            if task.vehicle == vehicle:
                return task
        raise KeyError(f"vehicle {vehicle} has no task; vehicles {[t.vehicle for t in self.tasks]}")


def check_fleet_size(workspace: Workspace, params: McoParams, n: int) -> Grid:
    """The grid, after checking that ``n`` vehicles can share it (before anything runs).

    Raises:
        ValueError: n < 2, more vehicles than free waypoints, or (Boustrophedon) than the
            decomposition's cells; a zero footprint or no free cell (from ``build_grid``).
    """
    if n < 2:
        raise ValueError(f"n: {n} vehicles; the MCO plan shares a workspace among at least 2")
    grid = build_grid(workspace, params.camera, params.flight_altitude_m, (params.overlap,) * 2)
    if n > len(grid.waypoints_xy_m):
        raise ValueError(
            f"n: {n} vehicles for {len(grid.waypoints_xy_m)} free waypoints: a sub-area each "
            "is not possible"
        )
    if params.planner == "boustrophedon":
        cells = boustrophedon_cell_count(grid, workspace)
        if n > cells:
            raise ValueError(
                f"n: {n} vehicles exceed the {cells} cells of the workspace's boustrophedon "
                "decomposition (the paper's largest n per workspace)"
            )
    return grid


def partition_for(
    planner: str, grid: Grid, workspace: Workspace, n: int, takeoff_xy_m: np.ndarray,
    rng: np.random.Generator,
) -> Partition:  # fmt: skip
    """The sub-areas of ``planner`` (MCO for both MCO planners)."""
    if planner.startswith("mco"):
        return mco_partition(grid, workspace, n, rng, takeoff_xy_m)
    if planner == "boustrophedon":
        return boustrophedon_partition(grid, workspace, n, takeoff_xy_m)
    if planner == "kmeans":
        return kmeans_partition(grid, n, rng)
    raise ValueError(f"planner: {planner!r} is not one of {list(PLANNERS)}")


def plan_mission(
    workspace: Workspace,
    params: McoParams,
    fleet: Sequence[Bidder],
    takeoff_xy_m: np.ndarray,
    rng: np.random.Generator,
) -> MissionPlan:
    """The five stages of Sec. 4.2 for ``fleet`` taking off at ``takeoff_xy_m``.

    Raises:
        ValueError: what ``check_fleet_size`` raises, naming the value.
    """
    n = len(fleet)
    home = np.asarray(takeoff_xy_m, dtype=float).reshape(2)
    grid = check_fleet_size(workspace, params, n)
    partition = partition_for(params.planner, grid, workspace, n, home, rng)
    roles = tuple(assign_roles(partition.sites_xy_m, partition.takeoff_xy_m, params.coordinators))
    climb_s = 2.0 * params.flight_altitude_m / params.climb_m_s  # up, and down again
    orders, lengths = [], []
    for k in range(n):
        members = np.flatnonzero(partition.labels == k)
        points = grid.waypoints_xy_m[members]
        if params.planner == "mco_firefly":
            order = firefly_tour(points, home, params.firefly, rng)
        else:
            order = zigzag_order(points, grid.row[members], grid.col[members], home)
        orders.append(points[order])
        lengths.append(tour_length_m(points, order, home))
    tasks = [Task(k, roles[k], lengths[k] / params.speed_m_s + climb_s) for k in range(n)]
    auction = english_auction(tasks, fleet)
    by_vehicle = {v: k for k, v in auction.assignment.items()}
    out = []
    for bidder in fleet:
        k = by_vehicle[bidder.vehicle]
        out.append(
            VehicleTask(bidder.vehicle, k, roles[k], orders[k], lengths[k], tasks[k].flight_time_s)
        )
    return MissionPlan(
        grid, partition, roles, tuple(out), auction, heterogeneity_std_pct(partition)
    )
