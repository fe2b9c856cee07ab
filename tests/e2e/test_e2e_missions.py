"""Missions, raw mission/geofence/rally items and the geofence plugin with classic MAVSDK-Python.

Each test starts its own ``swarmsitl up`` (one vehicle, in lockstep, at most
:data:`e2e_support.SPEED` x real time) so
plans and flight state never leak between tests, and runs one client of ``clients/`` with its own
``mavsdk_server``. What each report must show is in :mod:`mission_checks`.
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


def run_classic(script: str, swarm, client_logs, timeout_sim_s: float):
    args = ["--url", PORTS.url(), "--grpc-port", str(PORTS.grpc)]
    return run_client(
        script, args, client_logs, clock=swarm.clock, timeout_sim_s=timeout_sim_s,
        grpc_port=PORTS.grpc,
    )  # fmt: skip


def test_mission_upload_fly_pause_resume_rtl_and_clear(swarm, client_logs):
    """3 waypoints + RTL: download as uploaded, progress to 3/3 across a pause, lands home."""
    data = require_ok(run_classic("classic_mission.py", swarm, client_logs, 600), swarm)
    check_mission_flight(data)


def test_mission_raw_mission_geofence_rally_round_trip_and_rejections(swarm, client_logs):
    """Raw mission/fence/rally download field by field as uploaded; infeasible missions refused."""
    data = require_ok(run_classic("classic_mission_raw.py", swarm, client_logs, 360), swarm)
    check_raw_plans(data)


def test_geofence_plugin_upload_download_clear(swarm, client_logs):
    """GeofenceData (inclusion polygon, exclusion circle) reads back raw and via the plugin."""
    data = require_ok(run_classic("classic_geofence.py", swarm, client_logs, 360), swarm)
    check_geofence(data)
