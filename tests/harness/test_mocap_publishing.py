"""The simulation publishes motion-capture datagrams of every vehicle to its own UDP port."""

from __future__ import annotations

import socket

import numpy as np
import pytest

from companion import mocap_wire
from harness.sim.simulation import Simulation, SimulationConfig
from sitl import frames
from sitl.world import WorldConfig

pytestmark = pytest.mark.sockets


def _free_port_pair() -> tuple[socket.socket, socket.socket]:
    """Sockets bound to two consecutive free loopback ports b and b + 1."""
    for _ in range(50):
        a = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        a.bind(("127.0.0.1", 0))
        b = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            b.bind(("127.0.0.1", a.getsockname()[1] + 1))
        except OSError:
            a.close()
            b.close()
            continue
        return a, b
    raise RuntimeError("no pair of consecutive free UDP ports")


def test_each_vehicle_gets_its_poses_on_its_port():
    """--mocap 50 with two vehicles: 50 datagrams per simulated second on base and base + 1,
    each the vehicle's own pose (NED from the world origin) within a few mm of the truth."""
    sock0, sock1 = _free_port_pair()
    base = sock0.getsockname()[1]
    config = SimulationConfig(
        n_vehicles=2,
        record_hz=0,
        mavlink=False,
        world=WorldConfig(mocap_hz=50.0),
        mocap_port=base,
    )
    poses: dict[int, list] = {0: [], 1: []}
    try:
        with Simulation(config) as sim:
            sim.run_lockstep(1.0)
            truth_ned = frames.enu_to_ned(sim.world.truth.position_enu_m)
            for i, sock in enumerate((sock0, sock1)):
                sock.setblocking(False)
                while True:
                    try:
                        poses[i].append(mocap_wire.decode(sock.recv(128)))
                    except BlockingIOError:
                        break
    finally:
        sock0.close()
        sock1.close()
    for i in (0, 1):
        # Measured at 0.02 ... 0.98 s (the simulation polls after each step, so not at 0),
        # released 10 ms later.
        assert len(poses[i]) == 49
        assert all(p.vehicle == i for p in poses[i])
        assert [p.sequence for p in poses[i]] == list(range(49))
        assert poses[i][0].time_usec == 20_000
        assert poses[i][1].time_usec - poses[i][0].time_usec == 20_000
        mean = np.mean([p.position_ned_m for p in poses[i]], axis=0)
        np.testing.assert_allclose(mean, truth_ned[i], atol=0.005)
    assert poses[1][0].position_ned_m[1] == pytest.approx(5.0, abs=0.01)
