"""Seed 004's partitioners share the coverage lanes: disjoint regions tiling the free area."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, Point, box

from companion.planning.coverage import (
    PARTITIONS,
    CoverageSpec,
    free_area,
    plan_fleet,
    plan_vehicle,
    split,
)
from companion.planning.coverage_role import CoverageParams, plan
from companion.scenario_env import ScenarioEnv

AREA = box(-150.0, -100.0, 150.0, 100.0)
OBSTACLES = [
    box(-20.0, -10.0, 10.0, 25.0),  # a block in the middle
    Point(80.0, -40.0).buffer(12.0),  # a round tank
    shapely.Polygon([(-120, 60), (-90, 40), (-70, 80)]),  # a triangular no-fly zone
]
LATTICE = ("mco", "kmeans", "boustrophedon")
START = (-140.0, -95.0)


def _spec(partition: str, sweep_deg: float | None = None) -> CoverageSpec:
    return CoverageSpec(
        altitude_m=20.0,
        hfov_deg=90.0,
        overlap=0.2,
        margin_m=5.0,
        sweep_deg=sweep_deg,
        partition=partition,
    )


def _lane_length(part) -> float:
    return sum(s.length for lane in part.lanes for s in lane)


@pytest.mark.parametrize("partition", LATTICE)
@pytest.mark.parametrize("k", [2, 4, 6])
@pytest.mark.parametrize("sweep_deg", [None, 33.0])
def test_parts_are_disjoint_tile_the_free_area_and_share_its_lanes(partition, k, sweep_deg):
    """k parts, pairwise overlap ~0, union = the free area, every part holds lanes, and the
    lanes are the strips' lanes (same direction, same total length) cut among them."""
    free = free_area(AREA, OBSTACLES, 5.0)
    spec = _spec(partition, sweep_deg)
    parts = split(free, spec, k)
    assert len(parts) == k
    for a, b in itertools.combinations(parts, 2):
        assert a.polygon.intersection(b.polygon).area <= 1e-6 * free.area
        lanes_a = shapely.union_all([s for lane in a.lanes for s in lane])
        lanes_b = shapely.union_all([s for lane in b.lanes for s in lane])
        assert lanes_a.intersection(lanes_b).length <= 1e-6
    union = shapely.union_all([p.polygon for p in parts])
    assert union.intersection(free).area >= 0.999 * free.area
    assert union.difference(free).area <= 1e-6 * free.area
    strips = split(free, _spec("strips", sweep_deg), k)  # the same lanes, shared by strip
    total = sum(_lane_length(p) for p in strips)
    assert sum(_lane_length(p) for p in parts) == pytest.approx(total, rel=1e-9)
    whole = strips[0]
    for part in parts:
        assert len(part.lanes) >= 1 and _lane_length(part) > 0.0
        tolerant = part.polygon.buffer(1e-6)
        assert all(tolerant.covers(seg) for lane in part.lanes for seg in lane)
        assert _parallel_to(part, whole)


def _parallel_to(part, whole) -> bool:
    """Every segment of ``part`` runs along the (single) direction of ``whole``'s lanes."""
    (x0, y0), (x1, y1) = whole.lanes[0][0].coords[0], whole.lanes[0][0].coords[-1]
    u = np.array([x1 - x0, y1 - y0]) / math.hypot(x1 - x0, y1 - y0)
    for lane in part.lanes:
        for seg in lane:
            d = np.subtract(seg.coords[-1], seg.coords[0])
            if abs(u[0] * d[1] - u[1] * d[0]) > 1e-6 * np.hypot(*d):
                return False
    return True


@pytest.mark.parametrize("partition", LATTICE)
def test_parts_are_ordered_across_the_sweep_and_deterministic(partition):
    """Part j's centroid lies no nearer the first lane than part j - 1's (the strips' order),
    and a second split, computed afresh, is the same geometry."""
    free = free_area(AREA, OBSTACLES, 5.0)
    spec = _spec(partition, sweep_deg=0.0)  # lanes east-west: the cross axis is north
    parts = split(free, spec, 4)
    ys = [p.polygon.centroid.y for p in parts]
    assert ys == sorted(ys)
    split.cache_clear()
    again = split(free, spec, 4)
    for a, b in zip(parts, again, strict=True):
        assert shapely.to_wkb(a.polygon) == shapely.to_wkb(b.polygon)
        assert [[s.wkb for s in lane] for lane in a.lanes] == [
            [s.wkb for s in lane] for lane in b.lanes
        ]


@pytest.mark.parametrize("partition", LATTICE)
def test_paths_over_the_regions_cover_the_free_area(partition):
    """The footprints along the 4 vehicles' paths (no budget) cover >= 95 % of the free area,
    as the strips' do, and each path keeps the margin from every obstacle."""
    spec = _spec(partition)
    plans = plan_fleet(AREA, OBSTACLES, spec, [START] * 4)
    free = free_area(AREA, OBSTACLES, spec.margin_m)
    half = spec.footprint_width_m / 2.0
    swept = shapely.union_all(
        [LineString(p.waypoints_enu_m[:, :2]).buffer(half, cap_style="flat") for p in plans]
    )
    assert swept.intersection(free).area / free.area >= 0.95
    for p in plans:
        path = LineString(p.waypoints_enu_m[:, :2])
        assert all(path.distance(o) >= spec.margin_m - 0.01 for o in OBSTACLES)


def test_unknown_partition_and_too_many_vehicles_are_named():
    """A bad name lists the choices; a k the partitioner cannot make names k and the partition."""
    with pytest.raises(ValueError, match=r"partition.*strips.*mco.*kmeans.*boustrophedon.*voronoi"):
        _spec("voronoi")
    with pytest.raises(ValueError, match=r"PARAMS partition.*strips.*'voronoi'"):
        CoverageParams.from_mapping({"partition": "voronoi"})
    assert set(PARTITIONS) == {"strips", *LATTICE}
    free = free_area(AREA, OBSTACLES, 5.0)
    # more vehicles than lanes (7): regions share lanes, each vehicle still gets some
    assert all(p.lanes for p in split(free, _spec("kmeans", sweep_deg=0.0), 10))
    with pytest.raises(ValueError, match=r"'kmeans'.*k=1000"):
        split(free, _spec("kmeans"), 1000)
    # a plain rectangle is one boustrophedon cell: it cannot be shared by two vehicles
    with pytest.raises(ValueError, match=r"'boustrophedon'.*k=2"):
        split(AREA, _spec("boustrophedon"), 2)


def test_one_vehicle_gets_the_whole_free_area_whatever_the_partition():
    free = free_area(AREA, OBSTACLES, 5.0)
    strips = split(free, _spec("strips"), 1)
    for partition in LATTICE:
        (part,) = split(free, _spec(partition), 1)
        assert part.polygon.equals(strips[0].polygon) and part.lanes == strips[0].lanes


def test_plan_vehicle_and_the_role_plan_with_kmeans_fly_lanes():
    """``plan_vehicle`` and the role's ``plan`` (no world) give waypoints for every vehicle."""
    for i in range(3):
        vp = plan_vehicle(AREA, OBSTACLES, _spec("kmeans"), 3, i, START)
        assert len(vp.waypoints_enu_m) >= 2
    params = CoverageParams(area_enu_m=(0.0, 0.0, 300.0, 200.0), partition="kmeans")
    areas = []
    for i in range(3):
        env = ScenarioEnv(
            mavlink_url="swarm://",
            grpc_port=0,
            vehicle=i + 1,
            vehicles=3,
            role="coverage",
            role_index=i,
            role_count=3,
            seed=0,
            out_dir=".",
        )
        vp = plan(env, params, None, np.array([5.0 * i, 0.0, 0.0]), None)
        assert len(vp.waypoints_enu_m) >= 2
        assert np.allclose(vp.waypoints_enu_m[:, 2], params.altitude_m)
        areas.append(vp.part.polygon)
    assert sum(a.area for a in areas) == pytest.approx(300.0 * 200.0, rel=1e-9)
    assert all(a.intersection(b).area < 1e-6 for a, b in itertools.combinations(areas, 2))
