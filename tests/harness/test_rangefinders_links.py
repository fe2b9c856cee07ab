"""Issue 8, done when: a plain pymavlink ground station sees the range finders, the downward one
reads the ground; the onboard (offboard API) link too; HAGL goes out in ALTITUDE."""

from __future__ import annotations

import dataclasses
from collections import defaultdict

import pytest
from pymavlink.dialects.v20 import common as mavlink2
from udp_client import UdpClient

from harness.run.ports import free_port_block
from harness.sim.simulation import PortPlan, Simulation, SimulationConfig
from sitl.physics.obstacles import BoxObstacle
from sitl.world import WorldConfig

pytestmark = pytest.mark.sockets

_CLIENTS = free_port_block(2)
PORTS = PortPlan(sdk_base=_CLIENTS, listen_base=0, gcs_port=_CLIENTS + 1, gcs_listen_base=0)
"""The clients' ports from the suite's allocator; the vehicle's own listen ports OS-chosen."""
ON = WorldConfig(rangefinders=True)
"""The rangefinders are off by default in the Python API."""


def _command(client: UdpClient, command: int, *params: float) -> None:
    """COMMAND_LONG to the autopilot, back where its stream comes from."""
    p = [*params, 0, 0, 0, 0, 0, 0, 0][:7]
    client.send(mavlink2.MAVLink_command_long_message(1, 1, command, 0, *p))


@pytest.fixture
def clients():
    gcs, onboard = UdpClient(port=PORTS.gcs_port), UdpClient(port=PORTS.sdk_port(0))
    yield gcs, onboard
    gcs.close()
    onboard.close()


def _run(sim: Simulation, clients, seconds: float) -> None:
    for _ in range(round(seconds * sim.config.physics_hz / 10)):
        for _ in range(10):
            sim.step()
        for c in clients:
            c.drain()


def test_ground_station_and_onboard_links_see_every_rangefinder(clients):
    gcs, onboard = clients
    with Simulation(SimulationConfig(ports=PORTS, record_hz=0, world=ON)) as sim:
        _run(sim, clients, 2.0)
        true_height = sim.world.truth.position_enu_m[0, 2]
    mount = sim.world.airframe.rangefinders[6].position_frd_m[2]
    for client in (gcs, onboard):
        by_id = defaultdict(list)
        for m in client.of("DISTANCE_SENSOR"):
            by_id[m.id].append(m)
        assert len(by_id) >= 6
        assert {m[0].orientation for m in by_id.values()} >= {0, 25}
        assert all(38 <= len(v) <= 41 for v in by_id.values())  # 20 Hz for 2 s
        down = [m for m in by_id[6] if m.signal_quality == 100]
        assert down and all(m.orientation == 25 and m.type == 1 for m in down)
        mean_cm = sum(m.current_distance for m in down) / len(down)
        assert abs(mean_cm - 100 * (true_height - mount)) < 2.0
        clearance = [m.bottom_clearance for m in client.of("ALTITUDE")][-1]
        assert abs(clearance - true_height) < 0.05


def test_message_interval_and_request_message_for_distance_sensor(clients):
    gcs, onboard = clients
    with Simulation(SimulationConfig(ports=PORTS, record_hz=0, world=ON)) as sim:
        _run(sim, clients, 0.5)
        _command(gcs, mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL, 132, -1)
        _run(sim, clients, 0.1)
        gcs.inbox.clear()
        onboard.inbox.clear()
        _run(sim, clients, 1.0)
        assert gcs.of("DISTANCE_SENSOR") == []
        assert len(onboard.of("DISTANCE_SENSOR")) >= 6 * 19
        _command(gcs, mavlink2.MAV_CMD_REQUEST_MESSAGE, 132)
        _run(sim, clients, 0.1)
        assert len({m.id for m in gcs.of("DISTANCE_SENSOR")}) == 7
        _command(gcs, mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL, 132, 0)  # back to the default
        _run(sim, clients, 0.1)
        gcs.inbox.clear()
        _run(sim, clients, 1.0)
        assert len(gcs.of("DISTANCE_SENSOR")) >= 6 * 19


def test_hagl_over_a_box_and_no_rangefinders(clients):
    """Resting on a 1 m box: ALTITUDE's terrain is the box top, the clearance the height over it."""
    gcs, onboard = clients
    box = BoxObstacle((0.0, 0.0, 0.5), (2.0, 2.0, 1.0))
    world = dataclasses.replace(ON, obstacles=(box,), spawn_altitude_m=1.3)
    with Simulation(SimulationConfig(ports=PORTS, record_hz=0, world=world)) as sim:
        _run(sim, clients, 3.0)
        height_over_box = sim.world.truth.position_enu_m[0, 2] - 1.0
    altitude = onboard.of("ALTITUDE")[-1]
    assert abs(altitude.bottom_clearance - height_over_box) < 0.05
    assert altitude.altitude_terrain == pytest.approx(
        altitude.altitude_amsl - altitude.bottom_clearance, abs=1e-3
    )
    gcs.inbox.clear()
    onboard.inbox.clear()
    config = SimulationConfig(ports=PORTS, record_hz=0, world=WorldConfig(rangefinders=False))
    with Simulation(config) as sim:
        _run(sim, clients, 1.0)
    assert onboard.of("DISTANCE_SENSOR") == [] and gcs.of("DISTANCE_SENSOR") == []
    assert onboard.of("ALTITUDE") and all(
        m.bottom_clearance != m.bottom_clearance for m in onboard.of("ALTITUDE")
    )
