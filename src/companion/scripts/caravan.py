"""Caravan companion (seed 003): decentralised task allocation of a degraded fleet on a task map.

Each vehicle runs one agent of the allocator its role's ``algorithm`` names (CarA/ICF, GBAA or
ICA; ``companion.planning.caravan``), exchanges its consensus messages with the vehicles in radio
range, flies the lattice route to the task it holds, completes it on arrival, and lands at home
when every task is known completed. At swarm fidelity it runs in-process behind the kinematic
adapter (``swarm_program``, :mod:`companion.swarm.caravan`); the MAVSDK adapter for the full
stack is added by the full-stack scenario work.

Parameters (the scenario's role ``args``): :class:`CaravanParams`. ``run_metrics(env, report)``
computes the run's seed-003 figures (optimality gap, convergence steps, execution time, ...) from
the vehicles' metrics and the world.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from companion.planning.caravan.optimum import (
    achieved_score,
    optimal_score,
    optimality_gap,
    score_matrix,
)
from companion.planning.caravan.scores import CaravanParams
from companion.scenario_env import ScenarioEnv
from companion.swarm.caravan import caravan_params, task_map

PARAMS = CaravanParams
"""The dataclass of this program's ``args`` (checked when ``swarmsitl run`` loads a scenario)."""


def swarm_program(env: ScenarioEnv, vehicle: Any, node: Any) -> Any:
    """This role behind the swarm-scale engine's kinematic adapter (``companion.swarm.caravan``)."""
    from companion.swarm.caravan import CaravanProgram

    return CaravanProgram(env, vehicle, node)


def run_metrics(env: ScenarioEnv, report: dict[str, Any]) -> dict[str, tuple[Any, str]]:
    """Seed 003's figures for a whole run, from the report's per-vehicle metrics and the world.

    A task's completion time T_j is its first completion, counted from the completing vehicle's
    ``mission_start`` (when it had climbed: seed 003's agents start in the plane at time 0);
    ``optimality_gap`` compares J = sum a exp(-lambda T_j) over completed tasks with J*, the best
    single assignment (Eq. 1) from the vehicles' start points flying straight at the role's
    speed: full information, no loss, no lattice detour (the vehicles cut the lattice's corners,
    so lattice times would let a run beat its "optimum"); J can still exceed J* when a vehicle
    that finished its task takes a second one sooner than its holder would reach it (Eq. 14),
    which no single assignment expresses (``companion.planning.caravan.optimum``);
    ``execution_time`` is Eq. (29), the latest T_j (None if no task was completed).
    """
    if env.world is None:
        raise ValueError("run_metrics: the run's world (a taskmap) is needed")
    params = caravan_params(env)
    tasks_xy, _, _ = task_map(str(env.world))
    m = len(tasks_xy)
    rows = []
    for name in sorted(report["vehicles"], key=lambda s: int(s.removeprefix("vehicle"))):
        companion = report["vehicles"][name].get("companion") or {}
        if "algorithm" in companion:
            rows.append({k: v["value"] for k, v in companion.items()})
    first = np.full(m, np.nan)
    count = np.zeros(m, dtype=int)
    for r in rows:
        start = r.get("mission_start") or 0.0
        for j, t in r["completions"]:
            count[j] += 1
            first[j] = np.fmin(first[j], max(float(t) - start, 0.0))
    starts = np.array([r["start_xy"] for r in rows], dtype=float).reshape(-1, 2)
    j_star = optimal_score(score_matrix(None, starts, tasks_xy, params)) if len(rows) else 0.0
    j = achieved_score(first, params)
    done = np.isfinite(first)
    released = set().union(*(set(r["tasks_released"]) for r in rows)) if rows else set()
    return {
        "optimality_gap": (optimality_gap(j_star, j) if j_star > 0 else None, "fraction"),
        "score": (round(j, 3), "score"),
        "optimal_score": (round(j_star, 3), "score"),
        "convergence_steps": (max((r["last_change_step"] for r in rows), default=0), "count"),
        "execution_time": (float(first[done].max()) if done.any() else None, "s"),
        "tasks_assigned": (sum(r["tasks_assigned"] for r in rows), "count"),
        "tasks_released": (len(released), "count"),
        "tasks_validated": (int(done.sum()), "count"),
        "tasks_total": (m, "count"),
        "tasks_completed_twice": (int((count >= 2).sum()), "count"),
    }
