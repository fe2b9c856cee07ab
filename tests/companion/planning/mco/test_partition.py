"""Seed 004's MCO partition: n connected non-empty sub-areas, determinism, Phase I geometry."""

from __future__ import annotations

import networkx as nx
import numpy as np
import pytest
from shapely.geometry import Polygon, box

from companion.planning.mco.partition import (
    Partition,
    grid_edges,
    heterogeneity_std_pct,
    mco_partition,
    repair_connectivity,
)
from companion.planning.mco.workspace import Camera, Workspace, build_grid


def rejoya_like() -> Workspace:
    """About Rejoya's 70 ha: 700 m x 1000 m, one no-fly hole, two ZLIs (one touching the hole)."""
    hole = box(150.0, 600.0, 300.0, 750.0)
    polygon = Polygon(box(0.0, 0.0, 700.0, 1000.0).exterior.coords, [hole.exterior.coords])
    zli = (box(400.0, 200.0, 550.0, 320.0), box(280.0, 700.0, 420.0, 820.0))
    return Workspace(polygon, zli)


@pytest.fixture(scope="module")
def world():
    ws = rejoya_like()
    return ws, build_grid(ws, Camera())


def components_of(grid, labels, label):
    """8-connected components of one sub-area, built independently with networkx."""
    cells = {
        (int(r), int(c))
        for r, c, lab in zip(grid.row, grid.col, labels, strict=True)
        if lab == label
    }
    g = nx.Graph()
    g.add_nodes_from(cells)
    for r, c in cells:
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                if (dr, dc) != (0, 0) and (r + dr, c + dc) in cells:
                    g.add_edge((r, c), (r + dr, c + dc))
    return nx.number_connected_components(g)


@pytest.mark.parametrize("n", [*range(2, 17), 20, 33])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_exactly_n_connected_non_empty_sub_areas(world, n, seed):
    """Every n gives n sub-areas, all non-empty and 8-connected, despite a hole and ZLIs."""
    ws, grid = world
    part = mco_partition(grid, ws, n, np.random.default_rng(seed))
    assert part.method == "mco"
    assert part.n == n and part.sites_xy_m.shape == (n, 2)
    assert part.labels.shape == (len(grid),)
    assert set(np.unique(part.labels)) == set(range(n))
    assert part.counts().sum() == len(grid)
    for label in range(n):
        assert components_of(grid, part.labels, label) == 1
    v = 1 if n <= 16 else n // 16 + 1
    assert part.takeoff_xy_m.shape == (v, 2)


def test_same_seed_same_partition_other_seed_other(world):
    """Determinism per seed; a different seed draws other circles."""
    ws, grid = world
    a = mco_partition(grid, ws, 12, np.random.default_rng(5))
    b = mco_partition(grid, ws, 12, np.random.default_rng(5))
    c = mco_partition(grid, ws, 12, np.random.default_rng(6))
    np.testing.assert_array_equal(a.labels, b.labels)
    np.testing.assert_array_equal(a.sites_xy_m, b.sites_xy_m)
    assert not np.array_equal(a.labels, c.labels)


@pytest.mark.parametrize("n", [2, 3, 4])
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_phase_one_sites_on_the_circle_of_radius_width_over_n(n, seed):
    """Phase I: site 0 is p0; the n - 1 others lie at r = (E-W width) / n from it (Postulate 1)."""
    ws = Workspace(box(0.0, 0.0, 700.0, 1000.0))
    grid = build_grid(ws, Camera())
    p0 = np.array([350.0, 502.5])
    part = mco_partition(grid, ws, n, np.random.default_rng(seed), takeoff_xy_m=p0)
    np.testing.assert_allclose(part.sites_xy_m[0], p0)
    np.testing.assert_allclose(part.takeoff_xy_m, p0[None, :])
    r = np.linalg.norm(part.sites_xy_m[1:] - p0, axis=1)
    np.testing.assert_allclose(r, 700.0 / n, rtol=1e-12)


def test_voronoi_assignment_is_nearest_site_without_repair_needed():
    """On a convex, hole-free square with n <= 4 each waypoint is in its nearest site's cell."""
    ws = Workspace(box(0.0, 0.0, 600.0, 600.0))
    grid = build_grid(ws, Camera())
    part = mco_partition(grid, ws, 4, np.random.default_rng(3))
    d = np.linalg.norm(grid.waypoints_xy_m[:, None, :] - part.sites_xy_m[None], axis=2)
    own = d[np.arange(len(grid)), part.labels]
    assert np.all(own <= d.min(axis=1) + 1e-9)


def test_heterogeneity_formula_on_a_hand_made_partition():
    """Counts (1, 3) of 4 waypoints: population std 1, so 1 / 4 * 100 = 25 %."""
    part = Partition(
        labels=np.array([0, 1, 1, 1]),
        sites_xy_m=np.zeros((2, 2)),
        takeoff_xy_m=np.zeros((1, 2)),
        method="hand",
    )
    np.testing.assert_array_equal(part.counts(), [1, 3])
    assert heterogeneity_std_pct(part) == pytest.approx(25.0)
    equal = Partition(np.array([0, 0, 1, 1, 2, 2]), np.zeros((3, 2)), np.zeros((1, 2)), "hand")
    assert heterogeneity_std_pct(equal) == 0.0


def test_repair_moves_a_cut_off_fragment_to_the_neighbour_it_touches():
    """A label split in two by another keeps its larger piece; the smaller joins the neighbour."""
    ws = Workspace(box(0.0, 0.0, 100.0, 15.0))  # one row of 5 cells
    grid = build_grid(ws, Camera())
    assert len(grid) == 5
    labels = repair_connectivity(grid, np.array([0, 0, 1, 0, 1]), 2)
    np.testing.assert_array_equal(labels, [0, 0, 1, 1, 1])


def test_grid_edges_are_the_8_neighbourhood():
    """A 3 x 3 block of cells has 12 orthogonal and 8 diagonal neighbour pairs."""
    grid = build_grid(Workspace(box(0.0, 0.0, 60.0, 45.0)), Camera())
    assert len(grid) == 9
    edges = grid_edges(grid)
    assert len(edges) == 20
    assert len({tuple(sorted(e)) for e in edges.tolist()}) == 20


@pytest.mark.parametrize("n", [1, 0, 10_000])
def test_n_out_of_range_raises_naming_n(world, n):
    """n < 2 or n above the waypoint count: ValueError naming n."""
    ws, grid = world
    with pytest.raises(ValueError, match=f"n={n}"):
        mco_partition(grid, ws, n, np.random.default_rng(0))


def test_phase_four_takeoffs_must_match_v(world):
    """n = 20 needs v = 2 take-off locations; one given is a ValueError naming v."""
    ws, grid = world
    with pytest.raises(ValueError, match="v=2"):
        mco_partition(grid, ws, 20, np.random.default_rng(0), takeoff_xy_m=np.zeros(2))
