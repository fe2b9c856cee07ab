"""The whole indoor-positioning chain over real sockets: simulated motion capture -> UDP ->
companion bridge -> VISION_POSITION_ESTIMATE -> the vehicle's onboard endpoint -> the fleet."""

from __future__ import annotations

import socket
import threading
import time

import numpy as np
import pytest

from companion.scripts import mocap_bridge
from harness.sim.simulation import PortPlan, Simulation, SimulationConfig
from sitl import frames
from sitl.world import WorldConfig

pytestmark = pytest.mark.sockets


def _bound_socket() -> socket.socket:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    return sock


def test_mocap_pose_reaches_the_fleet_as_external_vision(monkeypatch):
    """Vehicle 0's pose arrives at fleet.handle_vision with its NED position (within a few mm of
    the truth), the published variances, a heading near north and the endpoint's clock."""
    telemetry_sink, mocap_probe = _bound_socket(), _bound_socket()
    mocap_port = mocap_probe.getsockname()[1]
    mocap_probe.close()  # the bridge binds it
    config = SimulationConfig(
        record_hz=0,
        ports=PortPlan(listen_base=0, sdk_base=telemetry_sink.getsockname()[1], gcs_port=0),
        world=WorldConfig(mocap_hz=50.0),
        mocap_port=mocap_port,
    )
    calls: list[tuple] = []
    with Simulation(config) as sim:
        monkeypatch.setattr(sim.fleet, "handle_vision", lambda *a: calls.append(a), raising=False)
        onboard_port = sim.endpoints[0].local_address[1]
        listen, link = f"127.0.0.1:{mocap_port}", f"udpout:127.0.0.1:{onboard_port}"
        bound = ["--duration", "30"]  # for a failing run only
        args = mocap_bridge.build_parser().parse_args(
            ["--listen", listen, "--mavlink", link, "--vehicle", "0", "--count", "3", *bound]
        )
        bridge = threading.Thread(target=mocap_bridge.run, args=(args,), daemon=True)
        bridge.start()
        try:
            for _ in range(3000):  # bounded: lockstep chunks of 20 ms while the bridge works
                sim.run_lockstep(0.02)
                if len(calls) >= 3:
                    break
                time.sleep(0.002)
            truth_ned = frames.enu_to_ned(sim.world.truth.position_enu_m[0])
            now_usec = round(sim.time_s * 1e6)
        finally:
            bridge.join(timeout=10)
            telemetry_sink.close()
    assert len(calls) >= 3
    index, time_usec, position, variance, yaw, yaw_var, velocity = calls[0]
    assert index == 0 and 0 < time_usec <= now_usec
    np.testing.assert_allclose(position, truth_ned, atol=0.01)  # resting on the ground
    np.testing.assert_allclose(variance, [1e-6] * 3, rtol=1e-3)  # (1 mm)^2
    assert abs(yaw) < 0.05 and yaw_var > 0 and velocity is None
