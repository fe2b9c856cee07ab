"""Seed 004's world abstraction: Eq. (1), the lattice, free-cell removal, input errors."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from shapely.geometry import Polygon, box

from companion.planning.mco.workspace import (
    Camera,
    Workspace,
    build_grid,
    default_takeoff_xy_m,
)


def test_eq1_footprint_and_altitude_of_the_papers_camera():
    """Seed 004's camera (87 deg, 4000x3000 px, 2 cm GSD): 80 m x 60 m footprint at ~42.2 m."""
    cam = Camera()
    h = cam.altitude_m()
    assert h == pytest.approx(80.0 / (2.0 * math.tan(math.radians(43.5))), rel=1e-12)
    assert h == pytest.approx(42.2, abs=0.05)
    lx, ly = cam.footprint_m(h)
    assert (lx, ly) == pytest.approx((80.0, 60.0), rel=1e-12)
    # The footprint scales linearly with height and keeps the image's aspect ratio (typo fixed).
    lx2, ly2 = cam.footprint_m(2.0 * h)
    assert (lx2, ly2) == pytest.approx((160.0, 120.0), rel=1e-12)


def test_cells_at_75_percent_overlap_are_20_by_15_m():
    """p = q = 0.75 gives a 20 m x 15 m step; a 700 m x 1000 m rectangle holds 35 x 67 cells."""
    grid = build_grid(Workspace(box(0.0, 0.0, 700.0, 1000.0)), Camera())
    assert grid.cell_m == pytest.approx((20.0, 15.0))
    assert grid.origin_xy_m == pytest.approx((10.0, 7.5))
    # 1000 / 15 = 66.7 rows: the 67th row's centre (997.5 m) is still inside.
    assert len(grid) == 35 * 67
    assert grid.zli_cells == 0 and grid.hole_cells == 0


def test_waypoints_ordered_south_to_north_then_west_to_east():
    """Rows increase monotonically and columns within a row too; xy match the lattice indices."""
    grid = build_grid(Workspace(box(0.0, 0.0, 100.0, 60.0)), Camera())
    key = grid.row * 1000 + grid.col
    assert np.all(np.diff(key) > 0)
    xy = np.column_stack(
        [
            grid.origin_xy_m[0] + grid.col * grid.cell_m[0],
            grid.origin_xy_m[1] + grid.row * grid.cell_m[1],
        ]
    )
    np.testing.assert_allclose(grid.waypoints_xy_m, xy)


def test_hole_and_zli_cells_are_removed():
    """Cells whose centre is in a hole or a ZLI are gone, counted apart, and no others."""
    hole = box(100.0, 150.0, 200.0, 300.0)  # cols 5..9, rows 10..19: 5 x 10 cells
    zli = box(300.0, 600.0, 400.0, 690.0)  # cols 15..19, rows 40..45: 5 x 6 cells
    polygon = Polygon(box(0, 0, 700, 1000).exterior.coords, [hole.exterior.coords])
    grid = build_grid(Workspace(polygon, (zli,)), Camera())
    assert grid.hole_cells == 50
    assert grid.zli_cells == 30
    assert len(grid) == 35 * 67 - 80
    xy = grid.waypoints_xy_m
    for zone in (hole, zli):
        x0, y0, x1, y1 = zone.bounds
        inside = (xy[:, 0] > x0) & (xy[:, 0] < x1) & (xy[:, 1] > y0) & (xy[:, 1] < y1)
        assert not inside.any()


def test_from_world_takes_boundary_and_low_interest():
    """A World's boundary (holes = no-fly) and low-interest zones become the workspace."""
    poly = box(0, 0, 200, 200)
    zli = (box(50, 50, 80, 80),)
    world = SimpleNamespace(boundary=poly, low_interest=zli, no_fly=())
    ws = Workspace.from_world(world)
    assert ws.polygon.equals(poly) and ws.zli == zli


def test_default_takeoff_is_a_free_waypoint_near_the_centre():
    """p0 is one of the waypoints and within a cell of the waypoints' mean."""
    grid = build_grid(Workspace(box(0, 0, 700, 1000)), Camera())
    p0 = default_takeoff_xy_m(grid)
    assert np.any(np.all(grid.waypoints_xy_m == p0, axis=1))
    assert np.linalg.norm(p0 - grid.waypoints_xy_m.mean(axis=0)) <= math.hypot(20, 15)


@pytest.mark.parametrize(
    ("make", "word"),
    [
        (lambda: Camera(aov_deg=0.0), "aov_deg"),
        (lambda: Camera(gsd_m=0.0), "gsd_m"),
        (lambda: Camera(width_px=0), "width_px"),
        (lambda: Camera().footprint_m(0.0), "altitude_m"),
        (lambda: build_grid(Workspace(box(0, 0, 100, 100)), Camera(), altitude_m=-1.0), "-1.0"),
        (lambda: build_grid(Workspace(box(0, 0, 100, 100)), Camera(), overlap=(1.0, 0.5)), "1.0"),
        (lambda: build_grid(Workspace(box(0, 0, 100, 100)), Camera(), overlap=(0.5, -0.1)), "-0.1"),
    ],
)
def test_bad_input_raises_naming_the_value(make, word):
    """Zero or negative footprint and overlap outside [0, 1) are ValueErrors naming the value."""
    with pytest.raises(ValueError, match=word.replace(".", r"\.").replace("[", r"\[")):
        make()


def test_workspace_without_free_cell_raises():
    """A polygon entirely covered by a ZLI has no free cell: ValueError."""
    poly = box(0, 0, 100, 100)
    with pytest.raises(ValueError, match="no free cell"):
        build_grid(Workspace(poly, (box(-1, -1, 101, 101),)), Camera())


def test_the_shipped_workspace_mco_world_gives_a_grid_without_its_holes_and_zones():
    """The example ``workspace_mco`` world: no waypoint in a no-fly hole or a low-interest zone."""
    import yaml
    from shapely import intersects_xy

    from worlds.examples import __file__ as examples_init
    from worlds.generate import build
    from worlds.schema import WorkspaceMcoSpec

    path = examples_init.replace("__init__.py", "workspace_mco.yaml")
    with open(path, encoding="utf-8") as fh:
        world = build(WorkspaceMcoSpec(**yaml.safe_load(fh)))
    grid = build_grid(Workspace.from_world(world), Camera())
    assert grid.hole_cells > 0 and grid.zli_cells > 0
    x, y = grid.waypoints_xy_m[:, 0], grid.waypoints_xy_m[:, 1]
    for zone in (*world.no_fly, *world.low_interest):
        assert not intersects_xy(zone, x, y).any()
