"""Planning arenas: seed 001's ACO arena, seed 004's MCO workspace, seed 003's task map."""

from __future__ import annotations

import math

import numpy as np
import shapely
from shapely.geometry import Point, Polygon

from worlds.model import LaunchArea, Solid, SolidMotion, Surface, TaskPoint, World
from worlds.schema import ArenaAcoSpec, TaskmapSpec, WorkspaceMcoSpec
from worlds.shapes import centred_rectangle, irregular_outline

_OBSTACLE = (0.5, 0.42, 0.35, 1.0)
_MOVER = (0.85, 0.1, 0.1, 1.0)
_OBSTACLE_GAP_M = 5.0


def build_arena_aco(spec: ArenaAcoSpec, rng: np.random.Generator) -> World:
    """Seed 001's arena; draw order: static obstacles, then moving ones.

    Start zone at 40 % of the width (or half ``zone_separation_m``) west of the centre, goal zone
    as far east; static obstacles (boxes with a random yaw, or cylinders) keep clear of both zones
    and ``_OBSTACLE_GAP_M`` of each other. Moving obstacles are drums that fly straight lines
    reflecting off the arena's edge (or ``moving_obstacle_region_m``'s) and bob vertically, "in
    different directions and elevations" (seed 001 Sec. 4.1).
    """
    sx, sy = spec.size_m
    half = 0.4 * sx if spec.zone_separation_m is None else spec.zone_separation_m / 2.0
    start = LaunchArea("start", (-half, 0.0, 0.0), spec.zone_radius_m)
    goal = LaunchArea("goal", (half, 0.0, 0.0), spec.zone_radius_m)
    taken = shapely.union_all([Point(a.center_enu_m[:2]).buffer(a.radius_m) for a in (start, goal)])
    solids: list[Solid] = []
    for _ in range(200 * max(spec.static_obstacle_count, 1)):
        if len(solids) == spec.static_obstacle_count:
            break
        shape = "box" if rng.uniform() < 0.5 else "cylinder"
        size = rng.uniform(*spec.static_obstacle_size_m, 2)
        if shape == "cylinder":
            size[1] = size[0]
        height = rng.uniform(*spec.obstacle_height_m)
        yaw = float(rng.uniform(0.0, 180.0)) if shape == "box" else 0.0
        reach = float(np.hypot(*size)) / 2.0
        c = (
            rng.uniform(-sx / 2.0 + reach, sx / 2.0 - reach),
            rng.uniform(-sy / 2.0 + reach, sy / 2.0 - reach),
        )
        s = Solid(
            f"obstacle_{len(solids)}",
            shape,
            (c[0], c[1], height / 2.0),
            (size[0], size[1], height),
            yaw,
            _OBSTACLE,
        )
        fp = s.footprint_at()
        if fp.distance(taken) < _OBSTACLE_GAP_M:
            continue
        solids.append(s)
        taken = taken.union(fp)
    else:
        raise ValueError(
            f"static_obstacle_count: cannot place {spec.static_obstacle_count} obstacles "
            f"in size_m {spec.size_m}"
        )
    for k in range(spec.moving_obstacle_count):
        d = rng.uniform(*spec.moving_obstacle_diameter_m)
        region = spec.moving_obstacle_region_m or (-sx / 2.0, -sy / 2.0, sx / 2.0, sy / 2.0)
        r = d / 2.0
        bounds = (region[0] + r, region[1] + r, region[2] - r, region[3] - r)
        c = (
            rng.uniform(bounds[0], bounds[2]),
            rng.uniform(bounds[1], bounds[3]),
            rng.uniform(*spec.moving_obstacle_altitude_m),
        )
        speed = rng.uniform(*spec.moving_obstacle_speed_m_s)
        heading = rng.uniform(0.0, 2.0 * math.pi)
        motion = SolidMotion(
            (float(speed * math.cos(heading)), float(speed * math.sin(heading))),
            bounds,
            spec.moving_obstacle_vertical_amplitude_m,
            float(rng.uniform(30.0, 90.0)),
            float(rng.uniform(0.0, 2.0 * math.pi)),
        )
        solids.append(
            Solid(
                f"mover_{k}", "cylinder", tuple(float(v) for v in c), (d, d, d), 0.0, _MOVER, motion
            )
        )
    surface = Surface("ground", spec.ground_rgba, "grass", 5.0, 0.2)
    return World(
        kind="arena_aco",
        seed=spec.seed,
        size_m=(sx, sy),
        boundary=centred_rectangle(sx, sy),
        surface=surface,
        solids=tuple(solids),
        launch_areas=(start, goal),
    )


def _place_blobs(
    rng: np.random.Generator,
    inside: Polygon,
    avoid: Polygon,
    count: int,
    radius_m: tuple[float, float],
    field: str,
) -> list[Polygon]:
    out: list[Polygon] = []
    x0, y0, x1, y1 = inside.bounds
    for _ in range(200 * max(count, 1)):
        if len(out) == count:
            return out
        c = (rng.uniform(x0, x1), rng.uniform(y0, y1))
        blob = irregular_outline(rng, c, rng.uniform(*radius_m), vertices=9, jitter=0.3)
        if inside.contains(blob) and (avoid.is_empty or blob.distance(avoid) > 10.0):
            out.append(blob)
            avoid = avoid.union(blob)
    if len(out) < count:
        raise ValueError(f"{field}: cannot place {count} zones of {radius_m} m in the workspace")
    return out


def _ring(points: list[tuple[float, float]], field: str) -> Polygon:
    """A valid polygon from a ring of a world file; ``ValueError`` naming the field."""
    poly = Polygon(points)
    if not poly.is_valid or poly.area <= 0.0:
        raise ValueError(
            f"{field}: not a simple polygon of positive area ({shapely.is_valid_reason(poly)})"
        )
    return poly


def _explicit_workspace(spec: WorkspaceMcoSpec) -> tuple[Polygon, list[Polygon], list[Polygon]]:
    """The outline, holes and zones a world file gives explicitly, checked against each other."""
    assert spec.outline_m is not None
    outline = _ring(spec.outline_m, "outline_m")
    sx, sy = spec.size_m
    x0, y0, x1, y1 = outline.bounds
    if x0 < -sx / 2 or x1 > sx / 2 or y0 < -sy / 2 or y1 > sy / 2:
        raise ValueError(
            f"outline_m: spans [{x0:g}, {x1:g}] x [{y0:g}, {y1:g}] m, outside the extent size_m "
            f"{list(spec.size_m)} (centred on the origin)"
        )
    holes = [_ring(r, f"holes_m[{k}]") for k, r in enumerate(spec.holes_m)]
    zones = [_ring(r, f"low_interest_m[{k}]") for k, r in enumerate(spec.low_interest_m)]
    for field, polys in (("holes_m", holes), ("low_interest_m", zones)):
        for k, poly in enumerate(polys):
            if not outline.contains(poly):
                raise ValueError(f"{field}[{k}]: not inside outline_m")
    for k, a in enumerate(holes):
        for j, b in enumerate(holes[k + 1 :], k + 1):
            if a.intersects(b):
                raise ValueError(f"holes_m[{k}] and holes_m[{j}] overlap")
    return outline, holes, zones


def build_workspace_mco(spec: WorkspaceMcoSpec, rng: np.random.Generator) -> World:
    """Seed 004's workspace; draw order: outline, holes, low-interest zones.

    The outline is star-shaped around the origin, inside the extent's ellipse; holes (obstacles,
    no-fly) and zones of low interest lie inside it, 10 m clear of each other and of the edge.
    """
    sx, sy = spec.size_m
    if spec.outline_m is not None:
        outline, holes, zones = _explicit_workspace(spec)
    else:
        n = spec.vertex_count
        angles = np.sort(rng.uniform(0.0, 2.0 * np.pi, n))
        scale = 1.0 - spec.radius_jitter * rng.uniform(0.0, 1.0, n)
        shell = np.column_stack(
            [sx / 2.0 * scale * np.cos(angles), sy / 2.0 * scale * np.sin(angles)]
        )
        outline = Polygon(shell)
        if not outline.is_valid:
            outline = outline.convex_hull
        inner = outline.buffer(-10.0)
        holes = _place_blobs(
            rng, inner, Polygon(), spec.hole_count, spec.hole_radius_m, "hole_count"
        )
        zones = _place_blobs(
            rng,
            inner,
            shapely.union_all(holes) if holes else Polygon(),
            spec.low_interest_count,
            spec.low_interest_radius_m,
            "low_interest_count",
        )
    boundary = Polygon(outline.exterior.coords, [h.exterior.coords for h in holes])
    launch: tuple[LaunchArea, ...] = ()
    if spec.launch_m is not None:
        x, y = spec.launch_m
        if not boundary.contains(Point(x, y)):
            raise ValueError(f"launch_m: {list(spec.launch_m)} is not inside the workspace")
        launch = (LaunchArea("start", (float(x), float(y), 0.0), spec.launch_radius_m),)
    surface = Surface("ground", spec.ground_rgba, "grass", 4.0, 0.25)
    return World(
        kind="workspace_mco",
        seed=spec.seed,
        size_m=(sx, sy),
        boundary=boundary,
        surface=surface,
        launch_areas=launch,
        no_fly=tuple(holes),
        low_interest=tuple(zones),
        extras={
            "area_m2": float(boundary.area),
            "diagonal_m": float(math.dist(*np.reshape(outline.bounds, (2, 2)))),
        },
    )


def build_taskmap(spec: TaskmapSpec, rng: np.random.Generator) -> World:
    """Seed 003's task map; draw order: task vertices, demands, agent starts.

    Tasks sit on distinct vertices of a ``grid_spacing_m`` grid, chosen uniformly; agents start
    i.i.d. uniform on the map (seed 003: "agent and task positions are i.i.d. uniform").
    """
    sx, sy = spec.size_m
    gx = np.arange(-sx / 2.0, sx / 2.0 + 1e-9, spec.grid_spacing_m)
    gy = np.arange(-sy / 2.0, sy / 2.0 + 1e-9, spec.grid_spacing_m)
    if spec.task_count > gx.size * gy.size:
        raise ValueError(
            f"task_count: {spec.task_count} tasks exceed the {gx.size * gy.size} grid vertices"
        )
    picks = rng.choice(gx.size * gy.size, size=spec.task_count, replace=False)
    demands = rng.uniform(*spec.demand, spec.task_count)
    tasks = tuple(
        TaskPoint(f"task_{k}", (float(gx[p % gx.size]), float(gy[p // gx.size])), float(d))
        for k, (p, d) in enumerate(zip(picks, demands, strict=True))
    )
    starts = rng.uniform(-0.5, 0.5, (spec.agent_count, 2)) * np.array([sx, sy])
    launch = tuple(
        LaunchArea(f"agent_start_{k}", (float(x), float(y), 0.0), spec.grid_spacing_m / 2.0)
        for k, (x, y) in enumerate(starts)
    )
    surface = Surface("ground", spec.ground_rgba, "concrete", spec.grid_spacing_m, 0.1)
    return World(
        kind="taskmap",
        seed=spec.seed,
        size_m=(sx, sy),
        boundary=centred_rectangle(sx, sy),
        surface=surface,
        launch_areas=launch,
        targets=tasks,
        extras={"grid_spacing_m": spec.grid_spacing_m, "diagonal_m": math.hypot(sx, sy)},
    )
