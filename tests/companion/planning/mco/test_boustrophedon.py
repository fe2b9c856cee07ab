"""Seed 004's boustrophedon baseline: known cell counts, a valid decomposition, merge to n."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, Polygon, box

from companion.planning.mco.boustrophedon import (
    boustrophedon_cell_count,
    boustrophedon_cells,
    boustrophedon_partition,
    free_space,
)
from companion.planning.mco.workspace import Camera, Workspace, build_grid


def square_with_hole() -> Workspace:
    return Workspace(
        Polygon(box(0, 0, 300, 300).exterior.coords, [box(100, 100, 200, 200).exterior.coords])
    )


def rejoya_like() -> Workspace:
    hole = box(150.0, 600.0, 300.0, 750.0)
    polygon = Polygon(box(0.0, 0.0, 700.0, 1000.0).exterior.coords, [hole.exterior.coords])
    return Workspace(polygon, (box(400.0, 200.0, 550.0, 320.0), box(80.0, 250.0, 200.0, 400.0)))


@pytest.mark.parametrize(
    ("workspace", "cells"),
    [
        (Workspace(box(0, 0, 300, 200)), 1),
        (square_with_hole(), 4),  # left, below, above, right of the hole
        (Workspace(box(0, 0, 300, 300), (box(100, 100, 200, 200),)), 4),  # a ZLI cuts the same
        (Workspace(box(0, 0, 200, 100).union(box(0, 0, 100, 200))), 1),  # L: slice stays 1 piece
        # A U opening east: the slice splits into two pieces at x = 100.
        (Workspace(box(0, 0, 100, 300).union(box(0, 0, 300, 100)).union(box(0, 200, 300, 300))), 3),
        # Two holes side by side: left, 2 around hole 1, between, 2 around hole 2, right.
        (
            Workspace(
                Polygon(
                    box(0, 0, 500, 300).exterior.coords,
                    [
                        box(100, 100, 200, 200).exterior.coords,
                        box(300, 100, 400, 200).exterior.coords,
                    ],
                )
            ),
            7,
        ),
    ],
)
def test_known_cell_counts(workspace, cells):
    """Cells are cut only where the sweep line's connectivity changes (Choset & Pignon)."""
    assert len(boustrophedon_cells(workspace)) == cells


@pytest.mark.parametrize("workspace", [square_with_hole(), rejoya_like()])
def test_cells_tile_the_free_space_and_are_vertically_monotone(workspace):
    """Cells are disjoint, tile the free space; a vertical line meets a cell in one piece."""
    cells = boustrophedon_cells(workspace)
    free = free_space(workspace)
    assert sum(c.area for c in cells) == pytest.approx(free.area, rel=1e-9)
    assert shapely.union_all(cells).symmetric_difference(free).area < 1e-6
    for i, a in enumerate(cells):
        for b in cells[i + 1 :]:
            assert a.intersection(b).area < 1e-6
    for cell in cells:
        x0, y0, x1, y1 = cell.bounds
        for x in np.linspace(x0, x1, 23)[1:-1]:
            cut = cell.intersection(LineString([(x, y0 - 1), (x, y1 + 1)]))
            assert cut.geom_type == "LineString", (cell.bounds, x, cut.geom_type)


def test_partition_labels_by_cell_and_merges_to_n():
    """Each n up to the cell count gives n non-empty sub-areas, each inside the cells."""
    ws = rejoya_like()
    grid = build_grid(ws, Camera())
    count = boustrophedon_cell_count(grid, ws)
    assert count == len(boustrophedon_cells(ws))
    full = boustrophedon_partition(grid, ws, count)
    cells = boustrophedon_cells(ws)
    for label in range(count):
        pts = grid.waypoints_xy_m[full.labels == label]
        holders = [c for c in cells if shapely.intersects_xy(c, pts[:, 0], pts[:, 1]).all()]
        assert len(holders) >= 1
    for n in range(2, count + 1):
        part = boustrophedon_partition(grid, ws, n)
        assert part.method == "boustrophedon"
        assert part.n == n and set(np.unique(part.labels)) == set(range(n))
        assert part.takeoff_xy_m.shape == (1, 2)
        np.testing.assert_allclose(
            part.sites_xy_m[0], grid.waypoints_xy_m[part.labels == 0].mean(axis=0)
        )


def test_merge_takes_the_smallest_cell_into_its_smallest_neighbour():
    """Square with a hole at n = 3: one of the two 1-wide strips joins a side, the other stays."""
    ws = square_with_hole()
    grid = build_grid(ws, Camera())
    counts4 = boustrophedon_partition(grid, ws, 4).counts()
    counts3 = np.sort(boustrophedon_partition(grid, ws, 3).counts())
    smallest = np.sort(counts4)
    assert counts3.sum() == counts4.sum()
    # the smallest cell merged into a neighbour: the new sizes are the old ones with two summed
    candidates = {
        tuple(sorted([*np.delete(smallest, [0, j]), smallest[0] + smallest[j]]))
        for j in range(1, 4)
    }
    assert tuple(counts3) in candidates


def test_n_beyond_the_cell_count_raises():
    """n above the decomposition's cells is a ValueError naming both."""
    ws = square_with_hole()
    grid = build_grid(ws, Camera())
    with pytest.raises(ValueError, match=r"has 4 cells; n=5 exceeds it"):
        boustrophedon_partition(grid, ws, 5)
    with pytest.raises(ValueError, match="n=1"):
        boustrophedon_partition(grid, ws, 1)
