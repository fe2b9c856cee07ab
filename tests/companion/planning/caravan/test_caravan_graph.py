"""The lattice of seed 003's lower tier (Sec. 3.5): Dijkstra times against straight lines."""

from __future__ import annotations

import math

import numpy as np
import pytest

from companion.planning.caravan.graph import TaskGraph

OCTILE_MAX = 1.0 / math.cos(math.pi / 8.0)
"""The worst ratio of an 8-connected lattice path to the straight line (22.5 deg off-axis)."""


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_lattice_times_lie_between_the_straight_line_and_the_octile_bound(seed: int) -> None:
    """Between vertices, lattice time / straight time is in [1, 1.0824] and reaches the octile
    distance (max(dx, dy) + (sqrt2 - 1) min(dx, dy)) computed independently."""
    rng = np.random.default_rng(seed)
    g = TaskGraph((10.0, 8.0), 0.5)
    a = g.vertices_xy[rng.integers(g.n_vertices)]
    b = g.vertices_xy[rng.integers(g.n_vertices, size=40)]
    t = g.travel_times_s(a, b, 2.0)
    d = np.abs(b - a)
    octile = (d.max(axis=1) + (math.sqrt(2) - 1) * d.min(axis=1)) / 2.0
    np.testing.assert_allclose(t, octile, atol=1e-9)
    straight = np.hypot(*(b - a).T) / 2.0
    far = straight > 0
    ratio = t[far] / straight[far]
    assert ratio.min() >= 1.0 - 1e-12 and ratio.max() <= OCTILE_MAX + 1e-12


def test_vertices_follow_the_taskmap_convention_and_off_vertex_hops_are_added() -> None:
    """Vertex ``iy * nx + ix`` at (-sx/2 + ix s, -sy/2 + iy s); a start off the lattice pays its
    straight hop to the nearest vertex."""
    g = TaskGraph((10.0, 10.0), 0.5)
    assert g.nx == g.ny == 21
    assert g.vertex_of((-5.0, -5.0)) == 0
    assert g.vertex_of((-4.5, -4.0)) == 2 * 21 + 1
    t = g.travel_times_s((0.1, 0.0), np.array([[2.0, 0.0]]), 1.0)
    np.testing.assert_allclose(t, [0.1 + 2.0])


def test_path_keeps_corners_only_and_ends_at_the_target() -> None:
    """The polyline has the lattice length, turns at every listed point, ends at the target."""
    g = TaskGraph((10.0, 10.0), 0.5)
    start, goal = np.array([-4.0, -4.0]), np.array([3.0, -1.5])
    path = g.path_xy(start, goal)
    np.testing.assert_allclose(path[-1], goal)
    pts = np.vstack([start, path])
    seg = np.diff(pts, axis=0)
    length = np.hypot(*seg.T).sum()
    np.testing.assert_allclose(length, g.path_lengths_m(start, goal[None])[0])
    d = np.diff(pts, axis=0)
    d /= np.hypot(*d.T)[:, None]
    cross = d[1:, 0] * d[:-1, 1] - d[1:, 1] * d[:-1, 0]
    assert np.all(np.abs(cross) > 1e-9)  # every listed point but the last is a turn
    assert np.all(np.isin(np.round(np.abs(d) * 2**0.5, 6), [0.0, 1.0, 1.414214]))
    np.testing.assert_allclose(g.path_xy(goal, goal), goal[None])
