"""Seed 003's Caravan (ICF) on the full stack with a loss: ``swarmsitl run caravan_kill.yaml``.

Real processes as a user runs them (the runner, one MAVSDK-Python companion
``companion.scripts.caravan`` per vehicle with its mavsdk_server, the link router between their
messaging nodes, UDP), lockstep, free ports from the plugin's ``swarmsitl_ports``. Four x500s
auction the task map's tasks over their WiFi and fly them; vehicle 2 crashes with its radio
while it flies to a task it holds. The others release that task once they stop hearing its
owner (Eq. 22-25), re-auction it, one flies it, and all land at home.
"""

from __future__ import annotations

import pytest

from harness.scenarios import scenario_path
from harness.scenarios.spec import load_scenario

pytestmark = pytest.mark.e2e

SCENARIO = scenario_path("caravan_kill")
LOST = "vehicle2"
"""The vehicle the scenario's fault crashes."""


def _values(companion: dict) -> dict:
    return {name: entry["value"] for name, entry in companion.items()}


def test_a_crashed_vehicles_task_is_re_auctioned_flown_and_the_others_land(swarmsitl_run):
    """The run passes its checks; the crash is reported at its time; every task is completed,
    each by one vehicle; the task the lost vehicle held is released by the others, and completed
    by another vehicle after the crash; the lost vehicle's companion ends with status 0 as soon
    as it finds its vehicle down; the others land and disarm at home."""
    result = swarmsitl_run(SCENARIO)  # lockstep, free ports
    result.assert_passed()
    report = result.report
    spec = load_scenario(SCENARIO).spec
    (fault_entry,) = spec.faults
    (fault,) = report["faults"]
    assert fault["vehicle"] == LOST and fault["kind"] == "crash+radio" and fault["applied"], fault
    crash_s = fault["time_s"]
    assert fault_entry.at_s <= crash_s < fault_entry.at_s + 0.01, fault
    assert report["vehicles"][LOST]["fault"] == "crash+radio"

    run = {name: entry["value"] for name, entry in report["fleet"]["run"].items()}
    assert run["tasks_validated"] == run["tasks_total"] == 7, run
    assert run["tasks_completed_twice"] == 0, run
    assert run["tasks_released"] >= 1, run
    assert None not in run["completed_by"], run

    vehicles = {name: _values(v["companion"]) for name, v in report["vehicles"].items()}
    lost = vehicles.pop(LOST)
    assert lost["phase"] == "down", lost
    assert all(t < crash_s for _, t in lost["completions"]), lost
    lost_done = {j for j, _ in lost["completions"]}
    released = set().union(*(set(v["tasks_released"]) for v in vehicles.values()))
    # What the others released is what the lost vehicle held and never completed, and another
    # vehicle completed each of those after the crash.
    assert released and not released & lost_done, (released, lost_done)
    for j in released:
        after = [(name, t) for name, v in vehicles.items() for k, t in v["completions"] if k == j]
        assert len(after) == 1 and after[0][1] > crash_s, (j, after)
        assert run["completed_by"][j] == after[0][0], (j, run["completed_by"])

    companion = report["companions"][LOST]
    assert companion["exit_code"] == 0, companion
    assert crash_s <= companion["exit_time_s"] < crash_s + 5.0, companion
    for name, v in vehicles.items():
        assert v["phase"] == "done", (name, v)
        result.assert_landed_and_disarmed(int(name.removeprefix("vehicle")) - 1)
