"""Seed 001's per-UAV ACO planner: ms per plan vs roadmap size and ants, against A*; Eq. 11's bound.

Per roadmap size (200, 500, 1000, 2000 random nodes in the 1 km x 1 km x 10-60 m box) and colony
size (10, 20, 50 ants; Table 1's other values), ``--seeds`` start/target pairs across the arena
(start in a 40 m disc 400 m west of the centre, target likewise east, as ``arena_aco``'s zones):
the colony's wall ms per plan (roadmap given), A*'s on the same roadmaps, and the ratio of their
path lengths (ACO's quality against the optimum on the roadmap; A*/straight shows what the
roadmap itself costs). Then Eq. 11's real-time bound (option 1): 80 UAVs each plan with
:func:`companion.planning.aco.plan.plan_path` at the defaults (roadmap built per UAV, one core),
against R_s / v = 5 m / 6 m/s = 0.833 s. Kernels are compiled (or loaded) before the timings.

    python benchmarks/aco_plan.py
    python benchmarks/aco_plan.py --seeds 2   # quicker

The last line is ``RESULT default_nodes=... default_ants=... aco_ms=... astar_ms=...
aco_over_astar=... plans80_s=... bound_s=0.833 plans80_over_bound=...`` (defaults, means).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from companion.planning.aco.astar import astar_path
from companion.planning.aco.colony import AcoParams, aco_path
from companion.planning.aco.plan import plan_path, straight_line_length
from companion.planning.aco.roadmap import RoadmapParams, build_roadmap
from realtime_factor import machine

NODES = (200, 500, 1000, 2000)
ANTS = (10, 20, 50)
UAVS = 80
SENSING_RANGE_M = 5.0
SPEED_M_S = 6.0
BOUND_S = SENSING_RANGE_M / SPEED_M_S


def ends(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A start in the west zone and a target in the east zone, 10-60 m up."""

    def zone(x: float) -> np.ndarray:
        r, a = 40.0 * np.sqrt(rng.random()), rng.uniform(0, 2 * np.pi)
        return np.array([x + r * np.cos(a), r * np.sin(a), rng.uniform(10.0, 60.0)])

    return zone(-400.0), zone(400.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    args = parser.parse_args()
    defaults = RoadmapParams(), AcoParams()
    print(f"machine: {machine()}; numba {numba.__version__}")
    print(f"defaults: {defaults[0]}; {defaults[1]}")
    warm = build_roadmap(
        *ends(np.random.default_rng(0)), RoadmapParams(nodes=30), np.random.default_rng(0)
    )
    aco_path(warm, AcoParams(ants=2, iterations=2), np.random.default_rng(0))

    table: dict[tuple[int, int], tuple[float, float, float]] = {}
    print(" nodes  ants   ACO ms   A* ms  ACO/A* (max)  A*/straight")
    for nodes in NODES:
        maps = []
        for seed in range(args.seeds):
            rng = np.random.default_rng(seed)
            a, b = ends(rng)
            rm = build_roadmap(a, b, RoadmapParams(nodes=nodes), rng)
            t0 = time.perf_counter()
            _, best = astar_path(rm)
            maps.append(
                (rm, best, (time.perf_counter() - t0) * 1e3, best / straight_line_length(a, b))
            )
        astar_ms = float(np.mean([m[2] for m in maps]))
        detour = float(np.mean([m[3] for m in maps]))
        for ants in ANTS:
            params = AcoParams(ants=ants)
            ms, ratio = [], []
            for seed, (rm, best, _, _) in enumerate(maps):
                t0 = time.perf_counter()
                found = aco_path(rm, params, np.random.default_rng(1000 + seed))
                ms.append((time.perf_counter() - t0) * 1e3)
                ratio.append(found.length_m / best)
            table[nodes, ants] = (float(np.mean(ms)), astar_ms, float(np.mean(ratio)))
            print(
                f"{nodes:6d} {ants:5d} {np.mean(ms):8.2f} {astar_ms:7.2f} {np.mean(ratio):7.4f} "
                f"({np.max(ratio):.4f}) {detour:9.4f}",
                flush=True,
            )

    rng = np.random.default_rng(12345)
    pairs = [ends(rng) for _ in range(UAVS)]
    t0 = time.perf_counter()
    lengths = [plan_path(a, b, defaults[0], rng, "aco", defaults[1]).length_m for a, b in pairs]
    plans_s = time.perf_counter() - t0
    straight = [straight_line_length(a, b) for a, b in pairs]
    quality = float(np.mean(np.divide(straight, lengths)))
    print(
        f"{UAVS} ACO plans at the defaults (roadmap built per UAV, one core): {plans_s:.3f} s "
        f"against Eq. 11's R_s / v = {BOUND_S:.3f} s ({plans_s / BOUND_S:.2f} of it); "
        f"straight/planned (Eq. 4's PQ before avoidance) {quality:.4f}"
    )
    aco_ms, astar_ms, ratio = table[defaults[0].nodes, defaults[1].ants]
    print(
        f"RESULT default_nodes={defaults[0].nodes} default_ants={defaults[1].ants} "
        f"aco_ms={aco_ms:.2f} astar_ms={astar_ms:.2f} aco_over_astar={ratio:.4f} "
        f"plans80_s={plans_s:.3f} bound_s={BOUND_S:.3f} plans80_over_bound={plans_s / BOUND_S:.3f} "
        f"pq={quality:.4f}"
    )


if __name__ == "__main__":
    main()
