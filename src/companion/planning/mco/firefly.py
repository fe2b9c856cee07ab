"""Coverage tour of a sub-area by a discrete Firefly Algorithm (Sec. 4.2.4, seed 004).

Seed 004 picks Yang's Firefly Algorithm (ref. [37]; Yang 2008, "Nature-Inspired Metaheuristic
Algorithms") for the TSP of each sub-area's waypoints, but gives neither its encoding nor its
parameters (digest Sec. 6 item 8). The discrete variant here follows the evolutionary discrete
FA of Jati & Suyanto 2011 ("Evolutionary discrete firefly algorithm for travelling salesman
problem", ICAIS 2011) in spirit:

* A firefly is a closed tour start -> the K points in some order -> start; brightness = 1/length.
* Distance r between two fireflies = the number of edges of one absent from the other, divided
  by K + 1 (the tour's edge count), so r is in [0, 1] and a tour and its reverse are at r = 0.
* Attraction beta = beta0 exp(-gamma r^2). A firefly moves toward a brighter one by
  ``ceil(beta r (K + 1))`` edge insertions: take an edge (a, b) of the brighter tour missing from
  its own and make a and b adjacent by one 2-opt segment reversal.
* Random step (Yang's alpha epsilon): once per firefly per iteration, a random node is joined to
  one of its :data:`NEAREST` nearest nodes by a 2-opt segment reversal (a random reversal of a
  good tour almost always wrecks it; this candidate-list move is the 2-opt move worth trying),
  kept if it does not lengthen the tour, or anyway with probability alpha_t;
  alpha_t = alpha alpha_decay^t (t the iteration).
* Tractability: instead of all pairs (O(P^2) per iteration), each firefly compares itself with
  ``sample`` fireflies drawn at random and moves toward the brightest of them if it is brighter
  than itself; otherwise it only takes the random step. The brightest tour ever seen is kept.
* Initial population: random permutations; with ``seed_with_nearest`` the first is the
  nearest-neighbour tour.

The iterations run in one numba kernel (:func:`firefly_kernel`); its random numbers come from
numba's generator seeded from the caller's ``numpy.random.Generator`` (same seed, same tour).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numba
import numpy as np

from companion.planning.mco.tours import nearest_neighbour_order, tour_length_m

NEAREST = 8
"""Candidates of the random step: a node is joined to one of its NEAREST nearest nodes."""


@dataclass(frozen=True)
class FireflyParams:
    """Parameters of :func:`firefly_tour` (seed 004 gives population and iterations only)."""

    population: int = 500
    """Fireflies (tours), Sec. 4.2.4's benchmark: 500."""
    iterations: int = 5000
    """Generations, Sec. 4.2.4's benchmark: 5000."""
    beta0: float = 1.0
    """Attractiveness at r = 0 (Yang's beta0)."""
    gamma: float = 1.0
    """Light absorption, on r normalised to [0, 1] (Yang's gamma; beta(1) = exp(-gamma))."""
    alpha: float = 0.2
    """Probability that the random step is kept even if it lengthens the tour, at t = 0."""
    alpha_decay: float = 0.97
    """alpha_t = alpha * alpha_decay^t."""
    sample: int = 8
    """Fireflies each one compares itself with per iteration (instead of all pairs)."""
    seed_with_nearest: bool = True
    """Start one firefly from the nearest-neighbour tour (the others are random permutations)."""

    def __post_init__(self) -> None:
        if self.population < 2:
            raise ValueError(f"population must be >= 2, got {self.population}")
        if self.iterations < 0:
            raise ValueError(f"iterations must be >= 0, got {self.iterations}")
        if not (math.isfinite(self.beta0) and self.beta0 >= 0.0):
            raise ValueError(f"beta0 must be finite and >= 0, got {self.beta0}")
        if not (math.isfinite(self.gamma) and self.gamma >= 0.0):
            raise ValueError(f"gamma must be finite and >= 0, got {self.gamma}")
        if not 0.0 <= self.alpha <= 1.0:
            raise ValueError(f"alpha must be in [0, 1], got {self.alpha}")
        if not 0.0 < self.alpha_decay <= 1.0:
            raise ValueError(f"alpha_decay must be in (0, 1], got {self.alpha_decay}")
        if self.sample < 1:
            raise ValueError(f"sample must be >= 1, got {self.sample}")


def firefly_tour(
    points_xy: np.ndarray,
    start_xy: np.ndarray,
    params: FireflyParams,
    rng: np.random.Generator,
) -> np.ndarray:
    """Order of the K points of the Firefly tour start -> points -> start (Sec. 4.2.4, seed 004).

    K <= 3 is solved exactly (every order is tried). Raises ``ValueError`` on non-finite points.
    """
    pts = np.asarray(points_xy, dtype=float).reshape(-1, 2)
    start = np.asarray(start_xy, dtype=float)
    if not np.isfinite(pts).all():
        raise ValueError("points_xy must be finite")
    if start.shape != (2,) or not np.isfinite(start).all():
        raise ValueError(f"start_xy must be a finite (2,) point, got {start_xy!r}")
    k = len(pts)
    if k <= 3:
        orders = [np.array(p, dtype=np.int64) for p in itertools.permutations(range(k))]
        return min(orders, key=lambda o: (round(tour_length_m(pts, o, start), 9), o.tolist()))
    nodes = np.concatenate([start[None, :], pts])
    dist = np.ascontiguousarray(np.linalg.norm(nodes[:, None, :] - nodes[None, :, :], axis=2))
    pop = np.zeros((params.population, k + 1), dtype=np.int64)  # column 0: the start (node 0)
    pop[:, 1:] = rng.permuted(np.tile(np.arange(1, k + 1), (params.population, 1)), axis=1)
    if params.seed_with_nearest:
        pop[0, 1:] = nearest_neighbour_order(pts, start) + 1
    near = np.ascontiguousarray(np.argsort(dist, axis=1, kind="stable")[:, 1 : NEAREST + 1])
    best = firefly_kernel(
        dist,
        near,
        pop,
        int(params.iterations),
        float(params.beta0),
        float(params.gamma),
        float(params.alpha),
        float(params.alpha_decay),
        int(params.sample),
        int(rng.integers(0, 2**62)),
    )
    return best[1:] - 1


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _length(dist: np.ndarray, tour: np.ndarray) -> float:  # pragma: no cover - compiled
    """Closed length of ``tour`` (node ids, start first)."""
    m = tour.shape[0]
    total = 0.0
    for p in range(m):
        total += dist[tour[p], tour[(p + 1) % m]]
    return total


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _reverse(tour: np.ndarray, pos: np.ndarray, lo: int, hi: int) -> None:  # pragma: no cover
    """Reverse ``tour[lo..hi]`` in place, keeping ``pos`` (node -> position) current."""
    while lo < hi:
        a = tour[lo]
        b = tour[hi]
        tour[lo] = b
        tour[hi] = a
        pos[b] = lo
        pos[a] = hi
        lo += 1
        hi -= 1


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _reversal_gain(
    dist: np.ndarray, tour: np.ndarray, lo: int, hi: int
) -> float:  # pragma: no cover
    """How much reversing ``tour[lo..hi]`` (1 <= lo <= hi < m) shortens the closed tour."""
    m = tour.shape[0]
    before = tour[lo - 1]
    after = tour[(hi + 1) % m]
    first = tour[lo]
    last = tour[hi]
    return dist[before, first] + dist[last, after] - dist[before, last] - dist[first, after]


@numba.njit(cache=True)
def firefly_kernel(
    dist: np.ndarray,
    near: np.ndarray,
    pop: np.ndarray,
    iterations: int,
    beta0: float,
    gamma: float,
    alpha: float,
    alpha_decay: float,
    sample: int,
    seed: int,
) -> np.ndarray:  # pragma: no cover - compiled
    """Run the discrete FA on ``pop`` (tours as node ids, node 0 = start first); the best tour.

    ``dist``: ``(K + 1, K + 1)`` distances between the start (node 0) and the points, m.
    ``near``: ``(K + 1, c)`` each node's c nearest other nodes. ``pop`` is moved in place.
    The moves are described in the module docstring.
    """
    np.random.seed(seed)
    n_ff, m = pop.shape
    lengths = np.empty(n_ff)
    for f in range(n_ff):
        lengths[f] = _length(dist, pop[f])
    best_f = int(np.argmin(lengths))
    best = pop[best_f].copy()
    best_len = lengths[best_f]
    pos = np.empty(m, dtype=np.int64)
    succ = np.empty(m, dtype=np.int64)
    pred = np.empty(m, dtype=np.int64)
    alpha_t = alpha
    for _ in range(iterations):
        for f in range(n_ff):
            tour = pop[f]
            # the brightest of a random sample, if brighter than this one
            target = -1
            target_len = lengths[f]
            for _s in range(sample):
                g = np.random.randint(0, n_ff)
                if lengths[g] < target_len:
                    target = g
                    target_len = lengths[g]
            if target >= 0:
                for p in range(m):
                    pos[tour[p]] = p
                other = pop[target]
                for p in range(m):
                    succ[other[p]] = other[(p + 1) % m]
                    pred[other[(p + 1) % m]] = other[p]
                differ = 0
                for p in range(m):
                    a = tour[p]
                    b = tour[(p + 1) % m]
                    if succ[a] != b and pred[a] != b:
                        differ += 1
                r = differ / m
                beta = beta0 * math.exp(-gamma * r * r)
                moves = int(math.ceil(beta * r * m))  # noqa: RUF046 (numba: keep it an int)
                for _mv in range(moves):
                    # an edge (a, succ[a]) of the brighter tour, missing here: make it adjacent
                    a = np.random.randint(0, m)
                    b = succ[a]
                    found = False
                    for _try in range(m):
                        b = succ[a]
                        pa = pos[a]
                        if tour[(pa + 1) % m] != b and tour[(pa + m - 1) % m] != b:
                            found = True
                            break
                        a = b
                    if not found:
                        break  # same tour: nothing left to copy
                    pa = pos[a]
                    pb = pos[b]
                    lo = min(pa, pb) + 1
                    hi = max(pa, pb)
                    lengths[f] -= _reversal_gain(dist, tour, lo, hi)
                    _reverse(tour, pos, lo, hi)
            # the random step: join a random node to one of its nearest by a 2-opt reversal,
            # kept if the tour is not longer, or anyway with probability alpha_t
            if target < 0:
                for p in range(m):
                    pos[tour[p]] = p
            a = np.random.randint(0, m)
            b = near[a, np.random.randint(0, near.shape[1])]
            pa = pos[a]
            pb = pos[b]
            if tour[(pa + 1) % m] != b and tour[(pa + m - 1) % m] != b:
                lo = min(pa, pb) + 1
                hi = max(pa, pb)
                gain = _reversal_gain(dist, tour, lo, hi)
                if gain >= 0.0 or np.random.random() < alpha_t:
                    lengths[f] -= gain
                    _reverse(tour, pos, lo, hi)
            if lengths[f] < best_len - 1e-9:
                lengths[f] = _length(dist, tour)  # drop the drift of the running sum
                if lengths[f] < best_len:
                    best_len = lengths[f]
                    best[:] = tour
        alpha_t *= alpha_decay
    return best
