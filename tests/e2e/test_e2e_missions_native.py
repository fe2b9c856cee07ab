"""Missions, raw mission/geofence/rally items and the geofence plugin with MAVSDK 4.x native.

The same flows and checks as :mod:`test_e2e_missions`, through ``mavsdk.asyncio`` (MissionAsync,
MissionRawAsync, GeofenceAsync; MAVSDK's C++ core in the client process, no mavsdk_server).
"""

from __future__ import annotations

import pytest
from e2e_support import module_ports, run_client, running_swarm
from mission_checks import check_geofence, check_mission_flight, check_raw_plans, require_ok

pytestmark = pytest.mark.e2e

PORTS = module_ports()


@pytest.fixture
def swarm(tmp_path):
    with running_swarm(1, PORTS, tmp_path / "run") as s:
        yield s


def run_native(script: str, swarm, client_logs, timeout_sim_s: float):
    return run_client(
        script, ["--url", PORTS.url()], client_logs, clock=swarm.clock, timeout_sim_s=timeout_sim_s
    )


def test_native_mission_upload_fly_pause_resume_rtl_and_clear(swarm, client_logs):
    """3 waypoints + RTL: download as uploaded, progress to 3/3 across a pause, lands home."""
    data = require_ok(run_native("native_mission.py", swarm, client_logs, 600), swarm)
    assert data["mavsdk_version"].lstrip("v").startswith("4.")
    check_mission_flight(data)


def test_native_mission_raw_mission_geofence_rally_round_trip_and_rejections(swarm, client_logs):
    """Raw mission/fence/rally download field by field as uploaded; infeasible missions refused."""
    data = require_ok(run_native("native_mission_raw.py", swarm, client_logs, 360), swarm)
    check_raw_plans(data)


def test_native_geofence_plugin_upload_download_clear(swarm, client_logs):
    """GeofenceData (inclusion polygon, exclusion circle) reads back raw and via the plugin."""
    data = require_ok(run_native("native_geofence.py", swarm, client_logs, 360), swarm)
    check_geofence(data)
