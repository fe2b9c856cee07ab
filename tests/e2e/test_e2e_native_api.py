"""MAVSDK 4.x native API (ctypes, in-process C++ core) against ``swarmsitl up``.

The simulation runs in lockstep with the client, at most :data:`e2e_support.SPEED` x real time;
MAVSDK's wall-clock command
timeouts are unaffected because the emulator ACKs at once. Only states and positions are asserted.
"""

from __future__ import annotations

import pytest
from e2e_support import module_ports, run_client, running_swarm

pytestmark = pytest.mark.e2e

PORTS = module_ports()


@pytest.fixture(scope="module")
def swarm(tmp_path_factory):
    with running_swarm(1, PORTS, tmp_path_factory.mktemp("native") / "run") as s:
        yield s


def test_native_api_takeoff_and_land(swarm, client_logs):
    """first_autopilot finds system 1 (PX4); arm, take off (>= 90 %), land, in_air False, disarm."""
    result = run_client(
        "native_flight.py", ["--url", PORTS.url()], client_logs, clock=swarm.clock,
        timeout_sim_s=720,
    )  # fmt: skip
    assert result.ok, result.describe()
    data = result.data
    assert data["mavsdk_version"].lstrip("v").startswith("4.")
    assert data["sysid"] == 1
    assert data["autopilot_type"] == "PX4"
    assert data["takeoff_alt_param"] == pytest.approx(4.0)
    assert data["rel_alt_reached_m"] >= 0.9 * 4.0
    assert data["in_air_after_takeoff"] is True
    final = data["final"]
    assert final["in_air"] is False
    assert final["armed"] is False
    assert abs(final["rel_alt_m"]) < 0.5
