"""The discrete Firefly tour of seed 004 (Sec. 4.2.4)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from companion.planning.mco.firefly import FireflyParams, firefly_tour
from companion.planning.mco.tours import tour_length_m

SMALL = FireflyParams(population=40, iterations=300)


def circle(k, radius=50.0):
    angles = 0.7 + 2 * np.pi * np.arange(k) / k
    return np.column_stack([radius * np.cos(angles), radius * np.sin(angles)])


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("nearest", [True, False])
def test_finds_the_circle_tour(seed, nearest):
    """21 points on a circle, start at one, the others shuffled: the FA tour is the circle."""
    rng = np.random.default_rng(seed)
    ring = circle(21)
    perm = rng.permutation(20)
    pts, start = ring[1:][perm], ring[0]
    params = FireflyParams(population=40, iterations=300, seed_with_nearest=nearest)
    order = firefly_tour(pts, start, params, np.random.default_rng(seed))
    optimum = 21 * 2 * 50 * np.sin(np.pi / 21)
    assert tour_length_m(pts, order, start) == pytest.approx(optimum, rel=1e-9)


@pytest.mark.parametrize("seed", range(3))
def test_deterministic_and_beats_random(seed):
    """Same seed, same tour; a permutation of the points; far shorter than random orders."""
    rng = np.random.default_rng(100 + seed)
    pts = rng.uniform(0, 200, (60, 2))
    start = np.array([100.0, 100.0])
    a = firefly_tour(pts, start, SMALL, np.random.default_rng(seed))
    b = firefly_tour(pts, start, SMALL, np.random.default_rng(seed))
    assert a.tolist() == b.tolist()
    assert sorted(a.tolist()) == list(range(60))
    random_lengths = [tour_length_m(pts, rng.permutation(60), start) for _ in range(20)]
    assert tour_length_m(pts, a, start) < 0.3 * min(random_lengths)


@pytest.mark.parametrize("k", [0, 1, 2, 3, 4, 5, 6])
def test_small_k_is_optimal(k):
    """K <= 6: the tour is as short as the best of all orders (brute force)."""
    rng = np.random.default_rng(k)
    pts = rng.uniform(0, 100, (k, 2))
    start = rng.uniform(0, 100, 2)
    order = firefly_tour(pts, start, SMALL, np.random.default_rng(0))
    assert sorted(order.tolist()) == list(range(k))
    best = min(
        tour_length_m(pts, np.array(p, dtype=int), start) for p in itertools.permutations(range(k))
    )
    assert tour_length_m(pts, order, start) == pytest.approx(best, abs=1e-9)


def test_bad_params_raise():
    with pytest.raises(ValueError, match="population must be >= 2, got 1"):
        FireflyParams(population=1)
    with pytest.raises(ValueError, match="iterations must be >= 0, got -1"):
        FireflyParams(iterations=-1)
    with pytest.raises(ValueError, match="finite"):
        firefly_tour(np.array([[0.0, np.nan]]), np.zeros(2), SMALL, np.random.default_rng(0))


def test_zero_iterations_is_the_best_initial_tour():
    """iterations = 0 with the nearest-neighbour seed: at most the nearest-neighbour length."""
    from companion.planning.mco.tours import nearest_neighbour_order

    rng = np.random.default_rng(5)
    pts = rng.uniform(0, 200, (30, 2))
    start = np.zeros(2)
    order = firefly_tour(pts, start, FireflyParams(population=5, iterations=0), rng)
    nn = nearest_neighbour_order(pts, start)
    assert tour_length_m(pts, order, start) <= tour_length_m(pts, nn, start) + 1e-9
