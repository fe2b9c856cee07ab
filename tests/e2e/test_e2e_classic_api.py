"""Classic MAVSDK-Python (``mavsdk_grpc`` + a real ``mavsdk_server``) against ``swarmsitl up``.

The simulation runs in lockstep with the client, at most :data:`e2e_support.SPEED` x real time.
MAVSDK's wall-clock command
and parameter timeouts (0.5 s x retries) are unaffected by the speed-up, because the emulator
ACKs commands and echoes parameters at once (on its next poll) instead of after a manoeuvre.
Nothing here asserts wall-clock timings: only states and positions.
"""

from __future__ import annotations

import pytest
from e2e_support import module_ports, run_client, running_swarm

pytestmark = pytest.mark.e2e

PORTS = module_ports()


@pytest.fixture(scope="module")
def swarm(tmp_path_factory):
    with running_swarm(1, PORTS, tmp_path_factory.mktemp("classic") / "run") as s:
        yield s


@pytest.fixture(scope="module")
def flight(swarm, tmp_path_factory):
    """One complete classic-API flight; the tests below check different parts of its report."""
    result = run_client(
        "classic_flight.py",
        ["--url", PORTS.url(), "--grpc-port", str(PORTS.grpc)],
        tmp_path_factory.mktemp("classic-client"),
        clock=swarm.clock,
        grpc_port=PORTS.grpc,
    )
    assert result.ok, result.describe()
    return result.data


def test_firmware_version_is_reported(flight):
    """info.get_version() returns the PX4-packed AUTOPILOT_VERSION (a release 1.x)."""
    version = flight["version"]
    assert version["major"] == 1
    assert version["minor"] > 0
    assert version["type"] == "RELEASE"


def test_float_param_get_set_and_takeoff_altitude(flight):
    """MIS_TAKEOFF_ALT (REAL32) reads the PX4 default, echoes sets, and follows Action's setter."""
    p = flight["params"]
    assert p["takeoff_alt_default"] == pytest.approx(2.5)
    assert p["takeoff_alt_after_set_7_5"] == pytest.approx(7.5)
    assert p["takeoff_alt_after_action_set_5"] == pytest.approx(5.0)
    assert p["action_get_takeoff_alt"] == pytest.approx(5.0)
    assert p["rtl_alt"] == pytest.approx(10.0)


def test_int_param_get_set_restore(flight):
    """NAV_RCL_ACT (INT32, bytewise-encoded) can be read, changed, and restored."""
    p = flight["params"]
    assert p["nav_rcl_act_initial"] == 2
    assert p["nav_rcl_act_read_back"] == p["nav_rcl_act_set"]
    assert p["nav_rcl_act_restored"] == p["nav_rcl_act_initial"]
    assert p["int_get_of_float_param"] == "WRONG_TYPE"


def test_takeoff_settles_at_takeoff_altitude(flight):
    """After takeoff and a few simulated seconds the relative altitude is 5 m +- 0.3 m, in Hold."""
    takeoff = flight["takeoff"]
    assert takeoff["rel_alt_max_error_m"] < 0.3, takeoff
    assert takeoff["mode_after_settle"] == "HOLD"
    assert "TAKEOFF" in flight["modes"]


def test_goto_location_arrives(flight):
    """goto_location 20 m north at home + 5 m AMSL ends within 1 m (client telemetry), in Hold."""
    goto = flight["goto"]
    assert goto["distance_m"] < 1.0, goto
    assert goto["mode_at_target"] == "HOLD"


def test_return_to_launch_lands_home_and_disarms(flight):
    """RTL (return altitude 10 m) lands within 1.5 m of home, then in_air and armed go False."""
    assert "RETURN_TO_LAUNCH" in flight["modes"]
    landing = flight["landing"]
    assert landing["horizontal_from_home_m"] < 1.5, landing
    assert abs(landing["rel_alt_m"]) < 0.5, landing
    assert flight["final"] == {"in_air": False, "armed": False}
