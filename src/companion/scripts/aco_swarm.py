"""Seed 001's ACO swarm role: each UAV plans its own path, avoids collisions, keeps a formation.

At swarm fidelity (``swarm_program``) every vehicle runs :class:`companion.swarm.aco.AcoProgram`:
take off at its spawn point in the world's ``start`` zone, plan start -> its mirror point in the
``goal`` zone over its own roadmap (ACO, or A* as the baseline), fly it at 6 m/s broadcasting its
position and priority (topic ``aco``), run Alg. 2 (collision avoidance) every decision and, with
``option: 2``, Alg. 4 (formation conservation), and land at the target. The choices are in
``companion.swarm.aco`` and ``companion.planning.aco.{avoidance,formation,metrics}``. There is no
full-stack ``main`` yet.

Parameters (the scenario's role ``args``): :class:`AcoRoleParams`, checked when the scenario
loads, with ``check_run`` (the world must have ``start`` and ``goal`` zones, the start zone must
hold the fleet). ``run_metrics(env, report)`` computes Sec. 3.5's PQ, MC, AD, FT, FC and CF
(Eqs. 4-10) from the vehicles' metrics.
"""

from __future__ import annotations

import math
from typing import Any

from companion.planning.aco.metrics import (
    TIME_FRAME_S,
    average_divergence,
    cost_function,
    flight_time,
    formation_change,
    mission_completion,
    path_quality,
)
from companion.scenario_env import ScenarioEnv
from companion.swarm.aco import AcoProgram, AcoRoleParams, aco_params

PARAMS = AcoRoleParams
"""The dataclass of this program's ``args`` (checked when ``swarmsitl run`` loads a scenario)."""


def swarm_program(env: ScenarioEnv, vehicle: Any, node: Any) -> AcoProgram:
    """This role behind the swarm-scale engine's kinematic adapter (``companion.swarm.aco``)."""
    return AcoProgram(env, vehicle, node)


def run_metrics(env: ScenarioEnv, report: dict[str, Any]) -> dict[str, tuple[Any, str]]:
    """Seed 001's figures for the run (Sec. 3.5, Eqs. 4-10), in the paper's mixed units.

    Over the role's vehicles (those whose metrics carry ``reached``): PQ (Eq. 4, %) over the
    vehicles that reached their target (a vehicle that did not has no complete TotalDist); MC
    (Eq. 5, %); AD (Eq. 6, divergences per drone, all vehicles); FT (Eq. 7) with T the makespan
    from the first departure (the end of the first climb) to the last arrival, over 60 s (None
    unless every vehicle reached); FC (Eq. 8, %, option 2 only) from each vehicle's
    ``avg_dist_change_m`` and the role's ``threshold_m``; CF by Eq. 9 (option 1) or Eq. 10
    (option 2) when all its terms exist; and the mean plan wall time (ms).
    """
    params = aco_params(env)
    rows = []
    for veh in report["vehicles"].values():
        companion = veh.get("companion") or {}
        if "reached" in companion:
            rows.append({k: v["value"] for k, v in companion.items()})
    reached = [bool(r["reached"]) for r in rows]
    done = [r for r in rows if r["reached"] and r["total_dist_m"]]
    pq = path_quality([r["min_dist_m"] for r in done], [r["total_dist_m"] for r in done])
    mc = mission_completion(reached)
    ad = average_divergence([r["divergences"] for r in rows])
    ft = None
    if rows and all(reached):
        makespan = max(r["arrived_s"] for r in rows) - min(r["mission_start_s"] for r in rows)
        ft = flight_time(makespan, TIME_FRAME_S)
    fc = None
    if params.option == 2:
        changes = [r["avg_dist_change_m"] for r in rows if r["avg_dist_change_m"] is not None]
        fc = formation_change(changes, params.threshold_m) if changes else None
    cf = None
    if ft is not None and math.isfinite(pq) and (params.option == 1 or fc is not None):
        cf = cost_function(pq, ft, ad, mc, fc if params.option == 2 else None)
    plan = [r["plan_ms"] for r in rows if r["plan_ms"] is not None]

    def num(x: float | None) -> float | None:
        return None if x is None or not math.isfinite(x) else round(float(x), 4)

    return {
        "pq": (num(pq), "%"),
        "mc": (num(mc), "%"),
        "ad": (num(ad), "count"),
        "ft": (num(ft), "ratio"),
        "fc": (num(fc), "%"),
        "cf": (num(cf), "score"),
        "plan_ms_mean": (num(sum(plan) / len(plan)) if plan else None, "ms"),
        "divergences": (sum(r["divergences"] for r in rows), "count"),
        "reached": (sum(reached), "count"),
    }


if __name__ == "__main__":
    # A scenario at fidelity full starts the role as a process: say why nothing will fly.
    raise SystemExit(
        "companion.scripts.aco_swarm has no MAVSDK adapter yet: run its scenarios with "
        "fidelity: swarm (docs/companions.md, 'ACO swarm')"
    )
