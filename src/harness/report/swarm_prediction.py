"""What the swarm-scale engine predicts for a full-fidelity run, beside what the flight model gave.

A scenario with ``swarm_prediction: true`` runs once more after its full-fidelity run: the same
scenario and seed at ``fidelity: swarm`` (kinematic vehicles, hover-power battery drain;
docs/swarm.md), in this process. Per vehicle the report then holds the battery left, the
airborne time and the distance flown of both, and their differences: how far the fast model can
be trusted for this mission (seed 004's remaining battery, for one).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from harness.report.totals import number_of
from harness.scenarios.spec import Scenario


def _round(x: float, digits: int = 2) -> float | None:
    return round(x, digits) if math.isfinite(x) else None


def swarm_prediction(scenario: Scenario, seed: int, report: dict[str, Any]) -> dict[str, Any]:
    """The swarm-fidelity run of ``scenario`` compared with the full run's ``report``.

    Returns ``{"vehicles": {name: {battery_remaining_full, battery_remaining_swarm,
    battery_difference, airborne_time_full, ...}}, "battery_difference_mean_abs": pp,
    "battery_difference_max_abs": pp, "complete": bool, "warnings": [...]}`` (percentages of
    the pack; differences swarm minus full).
    """
    from harness.swarm.run import run_swarm

    spec = scenario.spec.model_copy(update={"fidelity": "swarm"})
    predicted = run_swarm(dataclasses.replace(scenario, spec=spec), seed, None)
    vehicles: dict[str, Any] = {}
    diffs = []
    for name, full in (report.get("vehicles") or {}).items():
        swarm = (predicted.get("vehicles") or {}).get(name, {})
        b_full = 100.0 * number_of(full.get("final_battery_soc"))
        b_swarm = number_of(swarm.get("battery_remaining"))
        entry = {
            "battery_remaining_full": _round(b_full),
            "battery_remaining_swarm": _round(b_swarm),
            "battery_difference": _round(b_swarm - b_full),
            "airborne_time_full": _round(number_of(full.get("airborne_time")), 1),
            "airborne_time_swarm": _round(number_of(swarm.get("airborne_time")), 1),
            "distance_flown_full": _round(number_of(full.get("distance_flown")), 1),
            "distance_flown_swarm": _round(number_of(swarm.get("distance_flown")), 1),
        }
        if math.isfinite(b_swarm - b_full):
            diffs.append(abs(b_swarm - b_full))
        if "error" in swarm:
            entry["swarm_error"] = swarm["error"]
        vehicles[name] = entry
    return {
        "vehicles": vehicles,
        "battery_difference_mean_abs": _round(sum(diffs) / len(diffs)) if diffs else None,
        "battery_difference_max_abs": _round(max(diffs)) if diffs else None,
        "complete": bool(predicted.get("complete")),
        "passed": bool(predicted.get("passed")),
        "warnings": list(predicted.get("warnings") or []),
    }
