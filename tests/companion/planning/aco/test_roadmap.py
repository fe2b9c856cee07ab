"""Seed 001's random roadmap (Alg. 1 lines 3-4): seeded, connected, obstacle-aware on request."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

from companion.planning.aco.roadmap import (
    START,
    TARGET,
    Prism,
    RoadmapParams,
    build_roadmap,
)

A = np.array([-400.0, 0.0, 20.0])
B = np.array([400.0, 50.0, 40.0])


def adjacency(rm):
    n = rm.n_nodes
    rows = np.repeat(np.arange(n), np.diff(rm.indptr))
    return csr_matrix((rm.length_m, (rows, rm.indices)), shape=(n, n))


def test_same_seed_same_roadmap():
    """Two builds from equal seeds are identical; another seed gives other points."""
    one = build_roadmap(A, B, RoadmapParams(), np.random.default_rng(7))
    two = build_roadmap(A, B, RoadmapParams(), np.random.default_rng(7))
    other = build_roadmap(A, B, RoadmapParams(), np.random.default_rng(8))
    for field in ("points_enu_m", "indptr", "indices", "edge_id", "length_m"):
        np.testing.assert_array_equal(getattr(one, field), getattr(two, field))
    assert not np.array_equal(one.points_enu_m, other.points_enu_m)


@pytest.mark.parametrize("seed", range(3))
def test_graph_is_symmetric_in_the_box_and_joins_start_to_target(seed):
    """Start and target are nodes 0 and 1; points lie in the box; every edge exists both ways
    with its Euclidean length and one undirected id; each node has >= k neighbours; start and
    target lie in one component."""
    params = RoadmapParams(nodes=300, neighbours=6)
    rm = build_roadmap(A, B, params, np.random.default_rng(seed))
    np.testing.assert_array_equal(rm.points_enu_m[[START, TARGET]], [A, B])
    inner = rm.points_enu_m[2:]
    assert inner.shape == (300, 3)
    assert (inner >= params.min_enu_m).all() and (inner <= params.max_enu_m).all()
    adj = adjacency(rm)
    assert (adj != adj.T).nnz == 0
    rows = np.repeat(np.arange(rm.n_nodes), np.diff(rm.indptr))
    np.testing.assert_allclose(
        rm.length_m, np.linalg.norm(rm.points_enu_m[rm.indices] - rm.points_enu_m[rows], axis=1)
    )
    assert np.bincount(rm.edge_id).tolist() == [2] * rm.n_edges
    assert np.diff(rm.indptr).min() >= params.neighbours
    _, label = connected_components(adj, directed=False)
    assert label[START] == label[TARGET]


def test_flat_roadmap_when_the_altitude_band_is_a_plane():
    """Equal z corners: a 2-D roadmap at that altitude (besides the start and the target)."""
    params = RoadmapParams(nodes=50, min_enu_m=(-500, -500, 30), max_enu_m=(500, 500, 30))
    rm = build_roadmap(A, B, params, np.random.default_rng(0))
    assert (rm.points_enu_m[2:, 2] == 30.0).all()


def test_wall_between_start_and_target_is_unreachable():
    """A solid wall across the whole box, above its ceiling: ValueError naming both ends."""
    wall = Prism(shapely.box(-10.0, -600.0, 10.0, 600.0), 100.0)
    with pytest.raises(ValueError, match=r"target \(400\.0, 50\.0, 40\.0\) is unreachable"):
        build_roadmap(A, B, RoadmapParams(nodes=200), np.random.default_rng(0), (wall,))


@pytest.mark.parametrize("seed", range(3))
def test_solids_hold_no_node_and_no_edge_passes_through_them(seed):
    """Nodes inside solids are dropped and no edge enters one (checked by sampling each edge
    every 0.5 m)."""
    solids = (
        Prism(shapely.box(-100.0, -300.0, -40.0, 300.0), 80.0),
        Prism(shapely.Point(150.0, 0.0).buffer(60.0), 45.0),  # a cylinder, below the ceiling
        Prism(shapely.affinity.rotate(shapely.box(250, -200, 300, 100), 30.0), 70.0),
    )
    rm = build_roadmap(A, B, RoadmapParams(nodes=400), np.random.default_rng(seed), solids)
    rows = np.repeat(np.arange(rm.n_nodes), np.diff(rm.indptr))
    a, b = rm.points_enu_m[rows], rm.points_enu_m[rm.indices]
    steps = int(np.ceil(rm.length_m.max() / 0.5))
    t = np.linspace(0.0, 1.0, steps + 1)
    samples = (a[:, None, :] + t[None, :, None] * (b - a)[:, None, :]).reshape(-1, 3)
    for s in solids:
        inside = shapely.contains_xy(s.footprint, samples[:, 0], samples[:, 1])
        assert not (inside & (samples[:, 2] < s.height_m)).any()


def test_edges_over_a_low_solid_are_kept():
    """The cylinder's top is below the band: nodes above it stay, edges pass over it."""
    low = Prism(shapely.Point(0.0, 0.0).buffer(200.0), 5.0)
    params = RoadmapParams(nodes=200)
    free = build_roadmap(A, B, params, np.random.default_rng(3))
    over = build_roadmap(A, B, params, np.random.default_rng(3), (low,))
    for field in ("points_enu_m", "indptr", "indices", "length_m"):
        np.testing.assert_array_equal(getattr(free, field), getattr(over, field))


def test_start_inside_a_solid_is_unreachable():
    """A start inside a solid has no edge out of it: the same ValueError."""
    box = Prism(shapely.Point(A[0], A[1]).buffer(30.0), 50.0)
    with pytest.raises(ValueError, match=r"unreachable from start \(-400\.0, 0\.0, 20\.0\)"):
        build_roadmap(A, B, RoadmapParams(nodes=200), np.random.default_rng(0), (box,))


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"nodes": -1}, "nodes"),
        ({"neighbours": 0}, "neighbours"),
        ({"min_enu_m": (0.0, 0.0, 50.0), "max_enu_m": (1.0, 1.0, 40.0)}, "max_enu_m"),
        ({"min_enu_m": (0.0, float("nan"), 0.0)}, "min_enu_m"),
    ],
)
def test_params_validation_names_the_field(kwargs, field):
    with pytest.raises(ValueError, match=field):
        RoadmapParams(**kwargs)


def test_prism_height_validated():
    with pytest.raises(ValueError, match="height_m"):
        Prism(shapely.box(0, 0, 1, 1), 0.0)


def test_bad_end_point_rejected():
    with pytest.raises(ValueError, match="start_enu_m"):
        build_roadmap(np.array([0.0, 0.0]), B, RoadmapParams(), np.random.default_rng(0))
