"""Seed 001's Ant System colony (Sec. 3.1, Alg. 1, Eqs. 1-3, Table 1)."""

from __future__ import annotations

import numpy as np
import pytest
from numba.core.registry import CPUDispatcher

from companion.planning.aco import colony
from companion.planning.aco.astar import astar_path
from companion.planning.aco.colony import AcoParams, aco_path, pheromone_update
from companion.planning.aco.roadmap import RoadmapParams, build_roadmap, roadmap_from_edges
from harness.kernels import SIGNATURES, compiles_forbidden, kernel

A = np.array([-400.0, 0.0, 20.0])
B = np.array([400.0, 50.0, 40.0])


def test_table_1_defaults():
    """rho 0.5, alpha 1, beta 5, tau0 0.01, 50 iterations (Table 1); 20 ants (a choice)."""
    p = AcoParams()
    assert (p.rho, p.alpha, p.beta, p.tau0, p.iterations, p.ants) == (0.5, 1.0, 5.0, 0.01, 50, 20)


def test_straight_path_on_a_trivial_roadmap():
    """Collinear nodes start - 2 - 3 - 4 - target beside detours through nodes 5-7 off the
    line, every node linked to its neighbours along both rows: the colony returns the line."""
    line = [[0, 0, 0], [100, 0, 0], [25, 0, 0], [50, 0, 0], [75, 0, 0]]
    off = [[25, 20, 0], [50, 25, 0], [75, 20, 0]]
    pts = np.array(line + off, dtype=float)
    edges = [[0, 2], [2, 3], [3, 4], [1, 4], [0, 5], [5, 6], [6, 7], [1, 7]]
    edges += [[2, 5], [3, 6], [4, 7], [2, 6], [3, 5], [3, 7], [4, 6]]
    rm = roadmap_from_edges(pts, edges)
    for seed in range(3):
        result = aco_path(rm, AcoParams(), np.random.default_rng(seed))
        assert result.path.tolist() == [0, 2, 3, 4, 1]
        assert result.length_m == pytest.approx(100.0)


@pytest.mark.parametrize("seed", range(4))
def test_within_a_few_percent_of_astar_on_a_random_roadmap(seed):
    """Default parameters on the default roadmap: the colony's path is a valid start ->
    target walk at most 4 % longer than A*'s shortest path (benchmarks/aco_plan.py: ~2 % on
    average)."""
    rng = np.random.default_rng(seed)
    rm = build_roadmap(A, B, RoadmapParams(), rng)
    result = aco_path(rm, AcoParams(), rng)
    _, best = astar_path(rm)
    assert result.path[0] == 0 and result.path[-1] == 1
    assert len(set(result.path.tolist())) == len(result.path)  # no node twice
    assert result.length_m == pytest.approx(rm.path_length_m(result.path))
    assert best <= result.length_m <= 1.04 * best


def test_same_seed_same_path():
    rm = build_roadmap(A, B, RoadmapParams(nodes=300), np.random.default_rng(5))
    one = aco_path(rm, AcoParams(ants=10), np.random.default_rng(9))
    two = aco_path(rm, AcoParams(ants=10), np.random.default_rng(9))
    np.testing.assert_array_equal(one.path, two.path)
    np.testing.assert_array_equal(one.pheromone, two.pheromone)


@pytest.mark.parametrize("iterations", [1, 2, 5])
def test_eq_1_on_a_three_node_line(iterations):
    """start (0) - node 2 - target (1), 30 m: every ant walks it, so after each iteration
    tau <- (1 - rho) tau + ants / 30 on both edges (Eq. 1, deposit 1/L per ant)."""
    pts = np.array([[0, 0, 0], [30, 0, 0], [10, 0, 0]], dtype=float)
    rm = roadmap_from_edges(pts, [[0, 2], [1, 2]])
    params = AcoParams(ants=4, iterations=iterations, rho=0.3, tau0=0.02)
    expected = params.tau0
    for _ in range(iterations):
        expected = (1 - params.rho) * expected + params.ants / 30.0
    result = aco_path(rm, params, np.random.default_rng(0))
    np.testing.assert_allclose(result.pheromone, [expected, expected], rtol=1e-12)
    assert result.path.tolist() == [0, 2, 1]


def test_pheromone_update_sums_the_ants_deposits():
    """Three edges; ant 0 used edges 0 and 2 (L = 4 m), ant 1 edge 1 (L = 5 m), ant 2 died:
    tau = (1 - rho) tau + sum of 1/L over the ants on each edge."""
    tau = np.array([0.01, 0.02, 0.03])
    edges = np.array([[0, 2], [1, -1], [-1, -1]], dtype=np.int64)
    hops = np.array([2, 1, 0], dtype=np.int64)
    length = np.array([4.0, 5.0, np.inf])
    pheromone_update(tau, edges, hops, length, 0.5)
    np.testing.assert_allclose(tau, [0.005 + 0.25, 0.01 + 0.2, 0.015 + 0.25])


def test_dead_end_ants_step_back_and_still_deposit():
    """The start's nearest neighbour towards the target (node 2) is a leaf: ants that enter it
    step back and take the long way; all arrive, so the long way's edges get every ant's 1/L
    and the leaf's edge none (one iteration)."""
    pts = np.array([[0, 0, 0], [100, 0, 0], [20, 0, 0], [0, 50, 0], [100, 50, 0]], dtype=float)
    rm = roadmap_from_edges(pts, [[0, 2], [0, 3], [3, 4], [1, 4]])  # edge ids in this order
    params = AcoParams(ants=8, iterations=1)
    result = aco_path(rm, params, np.random.default_rng(0))
    assert result.path.tolist() == [0, 3, 4, 1]
    around = 200.0
    keep = (1 - params.rho) * params.tau0
    np.testing.assert_allclose(result.pheromone, [keep] + [keep + 8 / around] * 3)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("ants", 0),
        ("iterations", 0),
        ("rho", 0.0),
        ("rho", 1.5),
        ("alpha", -1.0),
        ("beta", float("nan")),
        ("tau0", 0.0),
    ],
)
def test_params_validation_names_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        AcoParams(**{field: value})


def test_kernels_are_listed_in_harness_kernels_with_the_callers_types():
    """Every kernel of the colony module callable from Python is in harness.kernels.SIGNATURES,
    and once those signatures are loaded a plan compiles nothing (the listed types are the
    types aco_path passes)."""
    names = [
        f"{colony.__name__}:{attr}"
        for attr, value in vars(colony).items()
        if isinstance(value, CPUDispatcher)
        and value.py_func.__module__ == colony.__name__
        and not value.targetoptions.get("no_cpython_wrapper", False)
    ]
    assert sorted(names) == [
        f"{colony.__name__}:colony_kernel",
        f"{colony.__name__}:pheromone_update",
    ]
    for name in names:
        assert name in SIGNATURES
        for signature in SIGNATURES[name]:
            kernel(name).compile(signature)
    rm = build_roadmap(A, B, RoadmapParams(nodes=50), np.random.default_rng(0))
    with compiles_forbidden() as guard:
        aco_path(rm, AcoParams(ants=2, iterations=2), np.random.default_rng(0))
    assert guard.violations == []
