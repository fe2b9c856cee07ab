"""MAVSDK conformance: offboard control (position, velocity, body velocity, attitude).

One ``swarmsitl up`` and one ``clients/offboard_conformance.py`` run per API (classic port slot
15, native slot 16), flown as MAVSDK-Python's offboard examples fly: a setpoint before start(),
then setpoints held for windows of simulated time.
"""

from __future__ import annotations

import math

import pytest
from conformance_support import Run, run_conformance_client
from e2e_support import module_ports, running_swarm

pytestmark = [pytest.mark.e2e, pytest.mark.conformance]

APIS = ("classic", "native")
"""The client APIs the suite runs (each run on its own block of ports from module_ports)."""


@pytest.fixture(scope="module", params=APIS)
def run(request, tmp_path_factory) -> Run:
    api = request.param
    ports = module_ports()
    out = tmp_path_factory.mktemp(f"offboard-{api}")
    with running_swarm(1, ports, out / "run") as swarm:
        return run_conformance_client(
            "offboard_conformance.py", api, ports, out / "clients", [], swarm.clock,
            timeout_sim_s=1300,
        )  # fmt: skip


def yaw_error(yaw_deg: float, want_deg: float) -> float:
    return abs((yaw_deg - want_deg + 180.0) % 360.0 - 180.0)


def test_client_run_completes(run):
    """The client finished, and every group it stopped stopped at a failed check (whose test
    fails). Checks a stop left unreached are skipped, pointing here or at that check."""
    problem = run.incomplete()
    assert problem is None, problem


def test_start_without_a_setpoint_is_refused(run):
    """offboard.start() before any set_*(): NO_SETPOINT_SET (MAVSDK refuses it client-side)."""
    assert run.check("offboard_start_without_setpoint")["start"] == "NO_SETPOINT_SET"


def test_start_on_the_ground_after_a_setpoint(run):
    """arm, set_position_ned(0, 0, 0, 0), start(): OFFBOARD in the HEARTBEAT."""
    c = run.check("offboard_start")
    assert c["flight_mode"] == "OFFBOARD"
    assert c["is_active"] is True


def test_position_ned_climb(run):
    """set_position_ned(0, 0, -5, 0): 5 m above the start point within 0.5 m."""
    c = run.check("offboard_position_climb")
    assert math.dist(c["ned_m"], [0.0, 0.0, -5.0]) < 0.5
    assert c["flight_mode"] == "OFFBOARD"


def test_position_ned_move_and_turn(run):
    """set_position_ned(5, 0, -5, 90): there within 0.5 m, heading east within 5 deg."""
    c = run.check("offboard_position_move_turn")
    assert math.dist(c["ned_m"], [5.0, 0.0, -5.0]) < 0.5
    assert yaw_error(c["yaw_deg"], 90.0) < 5.0


def test_velocity_ned(run):
    """set_velocity_ned(1, 0, 0, 90): 1 m/s north (+-0.2), level, heading east."""
    c = run.check("offboard_velocity_ned")
    north, east, down = c["mean_velocity_m_s"]
    assert north == pytest.approx(1.0, abs=0.2)
    assert abs(east) < 0.2 and abs(down) < 0.2
    assert yaw_error(c["yaw_deg"], 90.0) < 5.0


def test_velocity_body(run):
    """set_velocity_body(1, 0, 0, 0) heading east: 1 m/s east (forward), none north."""
    c = run.check("offboard_velocity_body")
    north, east, down = c["mean_velocity_m_s"]
    assert east == pytest.approx(1.0, abs=0.2)
    assert abs(north) < 0.2 and abs(down) < 0.3


def test_attitude(run):
    """set_attitude(roll 5, pitch 0, yaw 90, hover thrust): that attitude within 1.5 / 5 deg."""
    c = run.check("offboard_attitude")
    assert c["roll_deg"] == pytest.approx(5.0, abs=1.5)
    assert abs(c["pitch_deg"]) < 1.5
    assert yaw_error(c["yaw_deg"], 90.0) < 5.0


def test_stop_holds_then_land(run):
    """stop(): HOLD, streaming ends; land() brings it down."""
    c = run.check("offboard_stop_land")
    assert c["mode_after_stop"] == "HOLD"
    assert c["is_active"] is False
