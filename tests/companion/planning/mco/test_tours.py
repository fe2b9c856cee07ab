"""Tours of seed 004's sub-areas: length, nearest neighbour, 2-opt, zigzag."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from companion.planning.mco.tours import (
    nearest_neighbour_order,
    tour_length_m,
    two_opt,
    zigzag_order,
)


def circle(k, radius=50.0, phase=0.3):
    angles = phase + 2 * np.pi * np.arange(k) / k
    return np.column_stack([radius * np.cos(angles), radius * np.sin(angles)])


def is_circle_order(order):
    """The order goes round the circle (either way), starting anywhere."""
    k = len(order)
    steps = np.diff(np.concatenate([order, order[:1]])) % k
    return bool(np.all(steps == 1) or np.all(steps == k - 1))


def test_tour_length_closed_and_open():
    square = np.array([[1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    assert tour_length_m(square, np.arange(3), np.zeros(2)) == pytest.approx(4.0)
    assert tour_length_m(square, np.arange(3)) == pytest.approx(2.0)
    assert tour_length_m(square, np.zeros(0, dtype=int), np.zeros(2)) == 0.0


@pytest.mark.parametrize("seed", range(5))
def test_two_opt_never_lengthens_and_is_two_opt_optimal(seed):
    """From a random order: not longer, and no single reversal shortens the result."""
    rng = np.random.default_rng(seed)
    pts = rng.uniform(0, 200, (40, 2))
    start = rng.uniform(0, 200, 2)
    order = rng.permutation(40)
    better = two_opt(pts, order, start)
    length = tour_length_m(pts, better, start)
    assert sorted(better.tolist()) == list(range(40))
    assert length <= tour_length_m(pts, order, start) + 1e-9
    for i, j in itertools.combinations(range(40), 2):
        moved = better.copy()
        moved[i : j + 1] = moved[i : j + 1][::-1]
        assert tour_length_m(pts, moved, start) >= length - 1e-6


@pytest.mark.parametrize("seed", range(3))
def test_two_opt_finds_the_circle(seed):
    """Points on a circle with the start at one of them (a convex case): 2-opt reaches the
    circle order, the optimum, from a random permutation."""
    rng = np.random.default_rng(seed)
    ring = circle(16)
    pts, start = ring[1:], ring[0]
    order = two_opt(pts, rng.permutation(15), start)
    assert is_circle_order(np.concatenate([[0], order + 1]))
    assert tour_length_m(pts, order, start) == pytest.approx(16 * 2 * 50 * np.sin(np.pi / 16))


def test_nearest_neighbour_is_greedy():
    pts = np.array([[5.0, 0.0], [1.0, 0.0], [2.0, 0.0], [-4.0, 0.0]])
    assert nearest_neighbour_order(pts, np.zeros(2)).tolist() == [1, 2, 0, 3]


@pytest.mark.parametrize("corner", [(0.0, 0.0), (100.0, 0.0), (0.0, 100.0), (100.0, 100.0)])
def test_zigzag_visits_each_cell_once_alternating(corner):
    """A 10x10 grid with ZLI holes: every cell once, rows contiguous, direction alternating,
    starting at the end nearest the start."""
    rows, cols = np.divmod(np.arange(100), 10)
    keep = ~(((rows == 4) & (cols > 2) & (cols < 7)) | ((rows == 7) & (cols == 0)))
    rows, cols = rows[keep], cols[keep]
    pts = np.column_stack([cols * 10.0 + 5, rows * 10.0 + 5])
    start = np.array(corner)
    order = zigzag_order(pts, rows, cols, start)
    assert sorted(order.tolist()) == list(range(len(pts)))
    seen_rows = [int(r) for r, _ in itertools.groupby(rows[order])]
    assert len(seen_rows) == 10 and sorted(seen_rows) in (seen_rows, seen_rows[::-1])
    directions = []
    for _, group in itertools.groupby(order, key=lambda k: rows[k]):
        c = cols[list(group)]
        steps = np.sign(np.diff(c))
        assert len(set(steps.tolist())) == 1
        directions.append(steps[0])
    assert all(a == -b for a, b in itertools.pairwise(directions))
    first = pts[order[0]]
    assert np.linalg.norm(first - start) == pytest.approx(7.0710678, abs=1e-6)
