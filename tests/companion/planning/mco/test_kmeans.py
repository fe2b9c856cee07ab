"""Seed 004's K-means baseline: n non-empty clusters, centroid sites, determinism per seed."""

from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import Polygon, box

from companion.planning.mco import kmeans as km
from companion.planning.mco.kmeans import kmeans_partition
from companion.planning.mco.workspace import Camera, Workspace, build_grid


@pytest.fixture(scope="module")
def grid():
    hole = box(150.0, 600.0, 300.0, 750.0)
    polygon = Polygon(box(0.0, 0.0, 700.0, 1000.0).exterior.coords, [hole.exterior.coords])
    ws = Workspace(polygon, (box(400.0, 200.0, 550.0, 320.0), box(80.0, 250.0, 200.0, 400.0)))
    return build_grid(ws, Camera())


@pytest.mark.parametrize("n", [2, 5, 12, 40])
@pytest.mark.parametrize("seed", [0, 1])
def test_n_non_empty_clusters_with_centroid_sites(grid, n, seed):
    """k = n clusters, none empty; waypoints nearest their own centroid (Lloyd's fixed point)."""
    part = kmeans_partition(grid, n, np.random.default_rng(seed))
    assert part.method == "kmeans" and part.n == n
    assert set(np.unique(part.labels)) == set(range(n))
    for i in range(n):
        np.testing.assert_allclose(
            part.sites_xy_m[i], grid.waypoints_xy_m[part.labels == i].mean(axis=0)
        )
    d = np.linalg.norm(grid.waypoints_xy_m[:, None] - part.sites_xy_m[None], axis=2)
    assert np.mean(d[np.arange(len(grid)), part.labels] <= d.min(axis=1) + 1e-6) > 0.99


def test_near_homogeneous_compared_with_n(grid):
    """K-means sizes stay within a factor 3 of the mean size (the paper's homogeneous baseline)."""
    counts = kmeans_partition(grid, 12, np.random.default_rng(3)).counts()
    assert counts.max() < 3 * counts.mean() and counts.min() > counts.mean() / 3


def test_same_seed_same_clusters(grid):
    """One Generator seed, one result."""
    a = kmeans_partition(grid, 8, np.random.default_rng(9))
    b = kmeans_partition(grid, 8, np.random.default_rng(9))
    np.testing.assert_array_equal(a.labels, b.labels)


def test_fill_empty_gives_every_cluster_a_waypoint():
    """The repair leaves no cluster empty and moves the largest cluster's outlier."""
    xy = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [10.0, 0.0]])
    labels = km._fill_empty(xy, np.array([0, 0, 0, 0]), 3)
    assert set(labels.tolist()) == {0, 1, 2}
    assert labels[3] != 0


def test_n_out_of_range_raises(grid):
    """n = 1 or n above the waypoints: ValueError naming n."""
    with pytest.raises(ValueError, match="n=1"):
        kmeans_partition(grid, 1, np.random.default_rng(0))
    with pytest.raises(ValueError, match=f"n={len(grid) + 1}"):
        kmeans_partition(grid, len(grid) + 1, np.random.default_rng(0))
