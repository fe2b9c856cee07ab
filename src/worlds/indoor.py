"""Indoor industrial plant (seed 000 S3): walls, doorways, rooms, machinery, pipes, people.

The plant is a grid of rooms; every wall between two neighbouring rooms has one doorway and the
south wall has one exterior doorway, so every room is reachable from the safe point in the yard.
Machinery stays ``wall_clearance_m`` away from the walls, which keeps a corridor along every wall.
GPS-denied: vehicles fly on the indoor positioning source.
"""

from __future__ import annotations

import numpy as np
from shapely.geometry import Point

from worlds.model import LaunchArea, Person, Solid, Surface, World
from worlds.schema import IndoorSpec
from worlds.shapes import centred_rectangle

_WALL = (0.78, 0.76, 0.7, 1.0)
_MACHINE = (0.2, 0.35, 0.6, 1.0)
_PIPE = (0.7, 0.55, 0.1, 1.0)
_MACHINE_GAP_M = 1.5


def _wall(
    name: str,
    along_x: bool,
    fixed: float,
    a0: float,
    a1: float,
    door: float | None,
    spec: IndoorSpec,
) -> list[Solid]:
    """Boxes of one wall from ``a0`` to ``a1``, split around a doorway centred at ``door``."""
    t, h = spec.wall_thickness_m, spec.wall_height_m
    pieces = (
        [(a0, a1)]
        if door is None
        else [(a0, door - spec.doorway_width_m / 2.0), (door + spec.doorway_width_m / 2.0, a1)]
    )
    out = []
    for lo, hi in pieces:
        if hi - lo <= 1e-6:
            continue
        mid, length = (lo + hi) / 2.0, hi - lo
        center = (mid, fixed, h / 2.0) if along_x else (fixed, mid, h / 2.0)
        size = (length, t, h) if along_x else (t, length, h)
        out.append(Solid(name, "box", center, size, 0.0, _WALL))
    return out


def build_indoor(spec: IndoorSpec, rng: np.random.Generator) -> World:
    """The plant; draw order: doorways, machinery room by room, pipes, people."""
    px, py = spec.size_m
    rx, ry = spec.rooms
    rw, rh = px / rx, py / ry
    t, dw, clear = spec.wall_thickness_m, spec.doorway_width_m, spec.wall_clearance_m
    if min(rw, rh) <= dw + 2.0 * clear + t:
        raise ValueError(
            f"rooms: {spec.rooms} rooms of {rw:.1f} x {rh:.1f} m cannot hold a "
            f"doorway_width_m {dw} doorway"
        )

    def door_in(a0: float, a1: float) -> float:
        margin = t + dw / 2.0 + 0.2
        return float(rng.uniform(a0 + margin, a1 - margin))

    xs = -px / 2.0 + rw * np.arange(rx + 1)
    ys = -py / 2.0 + rh * np.arange(ry + 1)
    solids: list[Solid] = []
    # Outer walls; the south one has the exterior doorway in a random room.
    exit_room = int(rng.integers(rx))
    for i in range(rx):
        door = door_in(xs[i], xs[i + 1]) if i == exit_room else None
        if door is not None:
            exit_x = door
        solids += _wall("wall", True, -py / 2.0, xs[i] - t / 2.0, xs[i + 1] + t / 2.0, door, spec)
        solids += _wall("wall", True, py / 2.0, xs[i] - t / 2.0, xs[i + 1] + t / 2.0, None, spec)
    for j in range(ry):
        solids += _wall("wall", False, -px / 2.0, ys[j], ys[j + 1], None, spec)
        solids += _wall("wall", False, px / 2.0, ys[j], ys[j + 1], None, spec)
    # Interior walls, one doorway per pair of neighbouring rooms.
    for i in range(1, rx):
        for j in range(ry):
            solids += _wall("wall", False, xs[i], ys[j], ys[j + 1], door_in(ys[j], ys[j + 1]), spec)
    for j in range(1, ry):
        for i in range(rx):
            solids += _wall("wall", True, ys[j], xs[i], xs[i + 1], door_in(xs[i], xs[i + 1]), spec)
    # Machinery inside each room, clear of the walls and of each other.
    inner_rooms = [
        (
            xs[i] + t / 2.0 + clear,
            ys[j] + t / 2.0 + clear,
            xs[i + 1] - t / 2.0 - clear,
            ys[j + 1] - t / 2.0 - clear,
        )
        for i in range(rx)
        for j in range(ry)
    ]
    machines: list[Solid] = []
    for x0, y0, x1, y1 in inner_rooms:
        placed = 0
        for _ in range(50 * spec.machinery_per_room):
            if placed == spec.machinery_per_room:
                break
            size = rng.uniform(*spec.machinery_size_m, 2)
            height = rng.uniform(*spec.machinery_height_m)
            if size[0] > x1 - x0 or size[1] > y1 - y0:
                continue
            cx = rng.uniform(x0 + size[0] / 2.0, x1 - size[0] / 2.0)
            cy = rng.uniform(y0 + size[1] / 2.0, y1 - size[1] / 2.0)
            m = Solid(
                f"machine_{len(machines)}",
                "box",
                (cx, cy, height / 2.0),
                (size[0], size[1], height),
                0.0,
                _MACHINE,
            )
            if any(m.footprint_at().distance(o.footprint_at()) < _MACHINE_GAP_M for o in machines):
                continue
            machines.append(m)
            placed += 1
    solids += machines
    # Overhead pipes running the plant's length or width through the walls.
    for k in range(spec.pipe_count):
        d = spec.pipe_diameter_m
        if rng.uniform() < 0.5:
            y = rng.uniform(-py / 2.0 + 1.0, py / 2.0 - 1.0)
            solids.append(
                Solid(f"pipe_{k}", "box", (0.0, y, spec.pipe_height_m), (px - t, d, d), 0.0, _PIPE)
            )
        else:
            x = rng.uniform(-px / 2.0 + 1.0, px / 2.0 - 1.0)
            solids.append(
                Solid(f"pipe_{k}", "box", (x, 0.0, spec.pipe_height_m), (d, py - t, d), 0.0, _PIPE)
            )
    # People on the floor, in rooms, not in or against machinery.
    people = []
    for _ in range(1000 * max(spec.person_count, 1)):
        if len(people) == spec.person_count:
            break
        x0, y0, x1, y1 = inner_rooms[int(rng.integers(len(inner_rooms)))]
        p = Point(rng.uniform(x0, x1), rng.uniform(y0, y1))
        if any(p.distance(m.footprint_at()) < 0.8 for m in machines):
            continue
        people.append(Person(f"person_{len(people)}", (float(p.x), float(p.y), 0.0)))
    if len(people) < spec.person_count:
        raise ValueError(
            f"person_count: no room left for {spec.person_count} people beside the machinery"
        )
    yard = spec.yard_m
    sx, sy = px + 2.0 * yard, py + 2.0 * yard
    safe = LaunchArea("safe_point", (exit_x, -py / 2.0 - yard / 2.0, 0.0), min(yard / 2.0, 2.0))
    surface = Surface("floor", spec.floor_rgba, "concrete", 1.0, 0.1)
    return World(
        kind="indoor",
        seed=spec.seed,
        size_m=(sx, sy),
        boundary=centred_rectangle(sx, sy),
        surface=surface,
        solids=tuple(solids),
        launch_areas=(safe,),
        targets=tuple(people),
        gps_denied=True,
        extras={"plant_size_x_m": px, "plant_size_y_m": py},
    )
