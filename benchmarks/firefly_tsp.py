"""Firefly TSP (seed 004, Sec. 4.2.4): the paper's 100-cell case against 2-opt and the zigzag.

Sec. 4.2.4 chose the Firefly Algorithm on 100 uniformly distributed free cells with a population
of 500 and 5000 iterations. Here: 100 points uniform in a 200 m square, the tour starting and
ending at the square's centre, seeds 0..4 (``--seeds``); the Firefly tour
(:func:`companion.planning.mco.firefly.firefly_tour`, default parameters) against 2-opt from the
nearest-neighbour tour; then the same three planners and the zigzag on a 10 x 10 grid of 20 m
cells (the boustrophedon of Sec. 5.2). Mean tour length and wall ms per plan of each. The Firefly
kernel is compiled (or loaded from numba's cache) before the timings.

    python benchmarks/firefly_tsp.py
    python benchmarks/firefly_tsp.py --seeds 2 --population 100 --iterations 1000   # quicker

The last line is ``RESULT fa_length_m=... two_opt_length_m=... fa_over_two_opt=... fa_ms=...
two_opt_ms=...`` (the uniform case, means over the seeds).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from companion.planning.mco.firefly import FireflyParams, firefly_tour
from companion.planning.mco.tours import (
    nearest_neighbour_order,
    tour_length_m,
    two_opt,
    zigzag_order,
)
from realtime_factor import machine

SIDE_M = 200.0
CELLS = 100
START = np.array([SIDE_M / 2, SIDE_M / 2])


def timed(plan: Callable[..., np.ndarray], *args: object) -> tuple[np.ndarray, float]:
    """The plan's order and its wall time, ms."""
    t0 = time.perf_counter()
    order = plan(*args)
    return order, (time.perf_counter() - t0) * 1e3


def nn_two_opt(points: np.ndarray, start: np.ndarray) -> np.ndarray:
    """2-opt descent from the nearest-neighbour tour."""
    return two_opt(points, nearest_neighbour_order(points, start), start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--population", type=int, default=500)
    parser.add_argument("--iterations", type=int, default=5000)
    args = parser.parse_args()
    params = FireflyParams(population=args.population, iterations=args.iterations)
    print(f"machine: {machine()}; numba {numba.__version__}")
    print(f"Firefly: {params}")
    firefly_tour(
        np.random.default_rng(0).uniform(0, 1, (8, 2)),
        np.zeros(2),
        params,
        np.random.default_rng(0),
    )

    def fa(points: np.ndarray, start: np.ndarray, seed: int) -> np.ndarray:
        return firefly_tour(points, start, params, np.random.default_rng(seed))

    rows = {"fa": [], "two_opt": []}
    for seed in range(args.seeds):
        points = np.random.default_rng(seed).uniform(0, SIDE_M, (CELLS, 2))
        for name, (order, ms) in (
            ("fa", timed(fa, points, START, seed)),
            ("two_opt", timed(nn_two_opt, points, START)),
        ):
            rows[name].append((tour_length_m(points, order, START), ms))
        print(
            f"seed {seed}: uniform {CELLS} points: FA {rows['fa'][-1][0]:7.1f} m "
            f"({rows['fa'][-1][1]:7.0f} ms), 2-opt {rows['two_opt'][-1][0]:7.1f} m "
            f"({rows['two_opt'][-1][1]:5.1f} ms)",
            flush=True,
        )
    fa_len, fa_ms = np.mean(rows["fa"], axis=0)
    to_len, to_ms = np.mean(rows["two_opt"], axis=0)

    row, col = np.divmod(np.arange(CELLS), 10)
    grid = np.column_stack([col, row]) * (SIDE_M / 10) + SIDE_M / 20
    print(f"10 x 10 grid of {SIDE_M / 10:.0f} m cells, start at the centre:")
    for name, (order, ms) in (
        ("FA", timed(fa, grid, START, 0)),
        ("2-opt", timed(nn_two_opt, grid, START)),
        ("zigzag", timed(zigzag_order, grid, row, col, START)),
    ):
        print(f"  {name:7s} {tour_length_m(grid, order, START):7.1f} m  {ms:8.1f} ms")
    print(
        f"uniform: FA mean {fa_len:.1f} m in {fa_ms:.0f} ms, 2-opt {to_len:.1f} m in "
        f"{to_ms:.1f} ms, FA/2-opt {fa_len / to_len:.4f} over {args.seeds} seeds"
    )
    print(
        f"RESULT fa_length_m={fa_len:.1f} two_opt_length_m={to_len:.1f} "
        f"fa_over_two_opt={fa_len / to_len:.4f} fa_ms={fa_ms:.0f} two_opt_ms={to_ms:.1f}"
    )


if __name__ == "__main__":
    main()
