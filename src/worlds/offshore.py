"""Offshore oil-spill world (seed 000 S1): sea, rig with helideck, shuttle tanker, spills, wind."""

from __future__ import annotations

import math

import numpy as np
import shapely

from worlds.model import LaunchArea, OilSpill, Solid, Surface, Wind, World
from worlds.schema import OffshoreSpec
from worlds.shapes import centred_rectangle, irregular_outline

_STEEL = (0.45, 0.45, 0.48, 1.0)
_RIG_YELLOW = (0.85, 0.7, 0.15, 1.0)
_HELIDECK_GREEN = (0.15, 0.4, 0.2, 1.0)
_HULL_RED = (0.5, 0.12, 0.1, 1.0)
_SUPERSTRUCTURE_WHITE = (0.9, 0.9, 0.88, 1.0)


def _rig(spec: OffshoreSpec, cx: float, cy: float) -> tuple[list[Solid], LaunchArea]:
    dx, dy = spec.rig_deck_size_m
    h = spec.rig_deck_height_m
    deck_t = 3.0
    solids = [
        Solid("rig_deck", "box", (cx, cy, h - deck_t / 2.0), (dx, dy, deck_t), 0.0, _RIG_YELLOW),
        Solid("rig_derrick", "box", (cx + dx / 4.0, cy, h + 15.0), (6.0, 6.0, 30.0), 0.0, _STEEL),
    ]
    for i, (sx, sy) in enumerate(((-1, -1), (1, -1), (1, 1), (-1, 1))):
        leg_xy = (cx + sx * (dx / 2.0 - 3.0), cy + sy * (dy / 2.0 - 3.0))
        solids.append(
            Solid(
                f"rig_leg_{i}",
                "cylinder",
                (*leg_xy, (h - deck_t) / 2.0),
                (4.0, 4.0, h - deck_t),
                0.0,
                _STEEL,
            )
        )
    # Helideck: a thin disc overhanging the deck's west edge, 2 m above the deck.
    r = spec.helideck_diameter_m / 2.0
    hx, hz = cx - dx / 2.0 - r / 2.0, h + 2.0
    solids.append(
        Solid("helideck", "cylinder", (hx, cy, hz - 0.5), (2 * r, 2 * r, 1.0), 0.0, _HELIDECK_GREEN)
    )
    return solids, LaunchArea("helideck", (hx, cy, hz), r * 0.8)


def build_offshore(spec: OffshoreSpec, rng: np.random.Generator) -> World:
    """The offshore world; draw order: rig offset, tanker, wind, spills."""
    sx, sy = spec.size_m
    rig_xy = rng.uniform(-0.1, 0.1, 2) * np.array([sx, sy])
    solids, helideck = _rig(spec, float(rig_xy[0]), float(rig_xy[1]))
    # Shuttle tanker: moored at a random bearing and distance, hull along a random heading.
    bearing = rng.uniform(0.0, 2.0 * math.pi)
    dist = rng.uniform(*spec.tanker_distance_m)
    heading = rng.uniform(0.0, 180.0)
    tx, ty = rig_xy[0] + dist * math.cos(bearing), rig_xy[1] + dist * math.sin(bearing)
    half = np.array([sx, sy]) / 2.0 - spec.tanker_length_m / 2.0
    tx, ty = float(np.clip(tx, -half[0], half[0])), float(np.clip(ty, -half[1], half[1]))
    fb = spec.tanker_freeboard_m
    solids.append(
        Solid(
            "tanker_hull",
            "box",
            (tx, ty, fb / 2.0),
            (spec.tanker_length_m, spec.tanker_beam_m, fb),
            heading,
            _HULL_RED,
        )
    )
    aft = -0.4 * spec.tanker_length_m
    c, s = math.cos(math.radians(heading)), math.sin(math.radians(heading))
    solids.append(
        Solid(
            "tanker_bridge",
            "box",
            (tx + c * aft, ty + s * aft, fb + 7.5),
            (20.0, spec.tanker_beam_m * 0.8, 15.0),
            heading,
            _SUPERSTRUCTURE_WHITE,
        )
    )
    # Drawn even when the file fixes it, so fixing the wind does not move the spills.
    drawn_from_deg = float(rng.uniform(0.0, 360.0))
    wind_from = spec.wind_from_deg if spec.wind_from_deg is not None else drawn_from_deg
    wind = Wind(spec.wind_speed_m_s, wind_from, spec.wind_gust_std_m_s)
    # Spills on open sea: spill_clearance_m clear of every solid, not overlapping each other.
    keep_out = shapely.unary_union([s.footprint_at(0.0) for s in solids]).buffer(
        spec.spill_clearance_m
    )
    area = centred_rectangle(sx, sy)
    spills: list[OilSpill] = []
    taken = keep_out
    attempts = 0
    min_area = spec.spill_count * math.pi * (0.65 * spec.spill_radius_m[0]) ** 2
    while len(spills) < spec.spill_count:
        attempts += 1
        if attempts > 100 * max(spec.spill_count, 1) or min_area > 0.5 * (
            area.area - keep_out.area
        ):
            raise ValueError(
                f"spill_count: cannot place {spec.spill_count} spills of spill_radius_m "
                f"{spec.spill_radius_m} on a {sx} x {sy} m sea; placed {len(spills)}"
            )
        radius = rng.uniform(*spec.spill_radius_m)
        center = (rng.uniform(-sx / 2.0, sx / 2.0), rng.uniform(-sy / 2.0, sy / 2.0))
        poly = irregular_outline(rng, center, radius)
        if not area.contains(poly) or poly.intersects(taken):
            continue
        appear = float(rng.uniform(*spec.spill_appear_s))
        coords = tuple((float(x), float(y)) for x, y in poly.exterior.coords[:-1])
        spills.append(OilSpill(f"spill_{len(spills)}", coords, appear))
        taken = taken.union(poly.buffer(2.0))
    surface = Surface(
        "sea", spec.sea_rgba, "waves", spec.wave_length_m, 0.25, spec.wave_amplitude_m
    )
    return World(
        kind="offshore",
        seed=spec.seed,
        size_m=(sx, sy),
        boundary=area,
        surface=surface,
        solids=tuple(solids),
        launch_areas=(helideck,),
        targets=tuple(spills),
        wind=wind,
    )
