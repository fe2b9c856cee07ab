"""City world (seed 000 S2): blocks of lots with buildings, a land base, moving hotspots."""

from __future__ import annotations

import numpy as np
from shapely.geometry import box

from worlds.model import Hotspot, LaunchArea, Solid, Surface, World
from worlds.schema import CitySpec


def _facade(rng: np.random.Generator) -> tuple[float, float, float, float]:
    grey = rng.uniform(0.45, 0.85)
    tint = rng.uniform(-0.08, 0.08, 3)
    r, g, b = np.clip(grey + tint, 0.0, 1.0)
    return (float(r), float(g), float(b), 1.0)


def build_city(spec: CitySpec, rng: np.random.Generator) -> World:
    """The city; draw order: land-base block, buildings block by block, hotspots.

    Blocks tile the extent with ``street_width_m`` streets between them (and around the edge); each
    block has ``lots_per_block_side``^2 lots, each lot one building set back ``lot_setback_m`` from
    the lot's edges, so buildings never overlap. One random block is a plaza holding the land base.
    """
    sx, sy = spec.size_m
    nbx, nby = spec.blocks
    w = spec.street_width_m
    bw, bh = (sx - (nbx + 1) * w) / nbx, (sy - (nby + 1) * w) / nby
    n_lots = spec.lots_per_block_side
    if bw <= 0 or bh <= 0 or min(bw, bh) / n_lots <= 2.0 * spec.lot_setback_m:
        raise ValueError(
            f"blocks: {spec.blocks} blocks with street_width_m {w} and lot_setback_m "
            f"{spec.lot_setback_m} do not fit in size_m {spec.size_m}"
        )
    base_block = (int(rng.integers(nbx)), int(rng.integers(nby)))
    solids: list[Solid] = []
    base = None
    for i in range(nbx):
        for j in range(nby):
            x0, y0 = -sx / 2.0 + w + i * (bw + w), -sy / 2.0 + w + j * (bh + w)
            if (i, j) == base_block:
                c = (x0 + bw / 2.0, y0 + bh / 2.0, 0.0)
                base = LaunchArea("land_base", c, min(spec.land_base_radius_m, bw / 2.0, bh / 2.0))
                continue
            lw, lh = bw / n_lots, bh / n_lots
            for a in range(n_lots):
                for b in range(n_lots):
                    # Random footprint within the lot, inside the setback.
                    fx = rng.uniform(0.6, 1.0) * (lw - 2.0 * spec.lot_setback_m)
                    fy = rng.uniform(0.6, 1.0) * (lh - 2.0 * spec.lot_setback_m)
                    height = rng.uniform(*spec.building_height_m)
                    cx = x0 + (a + 0.5) * lw
                    cy = y0 + (b + 0.5) * lh
                    solids.append(
                        Solid(
                            f"building_{len(solids)}",
                            "box",
                            (cx, cy, height / 2.0),
                            (fx, fy, height),
                            0.0,
                            _facade(rng),
                        )
                    )
    assert base is not None
    bounds = (-sx / 2.0, -sy / 2.0, sx / 2.0, sy / 2.0)
    hotspots = []
    for k in range(spec.hotspot_count):
        radius = rng.uniform(*spec.hotspot_radius_m)
        inner = (bounds[0] + radius, bounds[1] + radius, bounds[2] - radius, bounds[3] - radius)
        center = (float(rng.uniform(inner[0], inner[2])), float(rng.uniform(inner[1], inner[3])))
        speed = rng.uniform(*spec.hotspot_speed_m_s)
        heading = rng.uniform(0.0, 2.0 * np.pi)
        velocity = (float(speed * np.cos(heading)), float(speed * np.sin(heading)))
        hotspots.append(Hotspot(f"hotspot_{k}", center, float(radius), velocity, inner))
    surface = Surface("ground", spec.ground_rgba, "asphalt", 2.0, 0.15)
    return World(
        kind="city",
        seed=spec.seed,
        size_m=(sx, sy),
        boundary=box(*bounds),
        surface=surface,
        solids=tuple(solids),
        launch_areas=(base,),
        targets=tuple(hotspots),
        extras={"street_width_m": w},
    )
