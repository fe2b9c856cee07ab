"""A* on the roadmap: the shortest path, against scipy's Dijkstra."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from companion.planning.aco.astar import astar_path
from companion.planning.aco.roadmap import (
    START,
    TARGET,
    RoadmapParams,
    build_roadmap,
    roadmap_from_edges,
)


@pytest.mark.parametrize("seed", range(5))
def test_astar_length_is_dijkstras(seed):
    """On random roadmaps (3-D, 2-D band, sparse k) the A* path is a walk along edges from the
    start to the target whose length is scipy's Dijkstra distance."""
    rng = np.random.default_rng(seed)
    params = RoadmapParams(nodes=int(rng.integers(20, 400)), neighbours=int(rng.integers(3, 12)))
    ends = rng.uniform([-500, -500, 10], [500, 500, 60], (2, 3))
    rm = build_roadmap(ends[0], ends[1], params, rng)
    path, length = astar_path(rm)
    n = rm.n_nodes
    rows = np.repeat(np.arange(n), np.diff(rm.indptr))
    adj = csr_matrix((rm.length_m, (rows, rm.indices)), shape=(n, n))
    assert path[0] == START and path[-1] == TARGET
    assert all(adj[a, b] > 0 for a, b in itertools.pairwise(path))
    expected = dijkstra(adj, directed=False, indices=START)[TARGET]
    assert length == pytest.approx(expected, rel=1e-12)
    assert rm.path_length_m(path) == pytest.approx(expected, rel=1e-12)


def test_astar_takes_the_detour_when_it_is_shorter():
    """A small hand graph: start - a - target (2 + 2 m) beats start - b - c - target."""
    pts = np.array([[0, 0, 0], [4, 0, 0], [2, 0, 0], [0, 1, 0], [4, 1, 0]], dtype=float)
    rm = roadmap_from_edges(pts, [[0, 2], [1, 2], [0, 3], [3, 4], [1, 4]])
    path, length = astar_path(rm)
    assert path.tolist() == [0, 2, 1] and length == pytest.approx(4.0)


def test_astar_unreachable_raises():
    pts = np.array([[0, 0, 0], [4, 0, 0], [2, 0, 0]], dtype=float)
    with pytest.raises(ValueError, match="unreachable"):
        astar_path(roadmap_from_edges(pts, [[0, 2]]))
