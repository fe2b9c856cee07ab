"""One small coverage scenario at both fidelities: the outcomes agree within stated tolerances.

Full stack (PyBullet, two emulated autopilots, two MAVSDK coverage programs with their
``mavsdk_server``) against swarm scale (kinematic vehicles, the same role's swarm program): the
same plan, budget and return rule, so the same strips are swept and about the same distance is
flown. The full stack takes longer to land (connecting, arming, the land detector, auto-disarm):
its run ends later, within the stated share.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

pytestmark = pytest.mark.e2e

SCENARIO = {
    "name": "fidelity-compare",
    "fidelity": "full",
    "seed": 1,
    "duration_s": 130,
    "spacing_m": 6,
    "fleet": [{"role": "survey", "count": 2, "airframe": "typhoon_h480"}],
    "roles": {
        "survey": {
            "module": "companion.scripts.coverage",
            "args": {
                "altitude_m": 8,
                "altitude_step_m": 3,
                "speed_m_s": 6,
                "sweep_deg": 0,
                "area_enu_m": [-10, 10, 70, 50],
            },
        }
    },
    "sensors": {"cameras": False, "rangefinders": False},
    "camera_samples": 0,
    "checks": {"companions_succeeded": True, "landed_and_disarmed": True},
}
COVERAGE_TOLERANCE = 0.10
"""Largest difference of the fleet's mean coverage fraction (of each strip)."""
DISTANCE_TOLERANCE = 0.20
"""Largest relative difference of the distance the fleet flew."""
END_TOLERANCE = 0.35
"""Largest relative difference of the simulated time the run took to end (all landed)."""


def test_coverage_agrees_between_full_stack_and_swarm_scale(swarmsitl_run, tmp_path: Path) -> None:
    reports = {}
    for fidelity in ("full", "swarm"):
        path = tmp_path / f"{fidelity}.yaml"
        path.write_text(yaml.safe_dump(SCENARIO | {"fidelity": fidelity}, sort_keys=False))
        result = swarmsitl_run(path)
        result.assert_passed()
        reports[fidelity] = result.report
    full, swarm = reports["full"], reports["swarm"]
    assert full["stop_reason"] == swarm["stop_reason"] == "done"
    cf, cs = (r["fleet"]["companions"] for r in (full, swarm))
    assert cf["coverage_fraction"]["value"] > 0.9
    assert abs(cs["coverage_fraction"]["value"] - cf["coverage_fraction"]["value"]) <= (
        COVERAGE_TOLERANCE
    )
    df, ds = cf["distance_flown_m"]["value"], cs["distance_flown_m"]["value"]
    assert abs(ds - df) <= DISTANCE_TOLERANCE * df, (df, ds)
    tf, ts = full["sim_time_s"], swarm["sim_time_s"]
    assert abs(ts - tf) <= END_TOLERANCE * tf, (tf, ts)
