"""Three vehicles in one ``swarmsitl up``, flown concurrently by three classic MAVSDK clients.

Client i listens on sdk port + i (PX4 SITL's 14540 + i convention) and runs its own
``mavsdk_server`` on its own gRPC port. The simulation runs in lockstep with the clients, at
most :data:`e2e_support.SPEED` x real time (three vehicles and three servers on two cores may
run it slower; the clients only wait on states, and MAVSDK's wall-clock command timeouts are
unaffected because the emulator ACKs at once). Only states and positions are asserted.
"""

from __future__ import annotations

import pytest
from e2e_support import module_ports, running_swarm, start_client

pytestmark = pytest.mark.e2e

PORTS = module_ports()
N = 3
ALT_M = 5.0


@pytest.fixture(scope="module")
def swarm(tmp_path_factory):
    with running_swarm(N, PORTS, tmp_path_factory.mktemp("swarm") / "run") as s:
        yield s


def test_three_clients_fly_their_own_vehicles(swarm, client_logs):
    """Each client sees only its own system id (1, 2, 3), arms, and reaches >= 90 % of 5 m."""
    clients = [
        start_client(
            "classic_takeoff.py",
            ["--url", PORTS.url(i), "--grpc-port", str(PORTS.grpc + i), "--alt", str(ALT_M)],
            client_logs,
            clock=swarm.clock,
            grpc_port=PORTS.grpc + i,
        )
        for i in range(N)
    ]
    results = [c.result() for c in clients]
    for res in results:
        assert res.ok, res.describe()
    for i, res in enumerate(results):
        data = res.data
        assert set(data["heartbeat_sysids"]) == {i + 1}, data
        assert data["mav_sys_id"] == i + 1
        assert data["rel_alt_reached_m"] >= 0.9 * ALT_M
        assert data["in_air"] is True
    # Vehicles are spawned 5 m apart along east: distinct homes, increasing longitude.
    lons = [res.data["home"][1] for res in results]
    assert lons == sorted(lons) and len(set(lons)) == N, lons
