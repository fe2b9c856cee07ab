"""The simulated camera as MAVLink component 100, reached through the vehicle's links over UDP.

A plain pymavlink client on the onboard link (MAVSDK's place) and one on the ground-station port
talk to a running simulation: the camera's heartbeat reaches both; VIDEO_STREAM_INFORMATION
answers with the stream URI, which OpenCV in another process opens; a photo is written and
geotagged where the vehicle is. Each simulation gets 7 ports of the suite's allocator.
"""

from __future__ import annotations

import math
import socket
from pathlib import Path
from urllib.parse import unquote, urlparse

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink2
from stream_reader import read_while_running
from udp_client import UdpClient

from harness.run.ports import free_port_block
from harness.sim.simulation import PortPlan, Simulation, SimulationConfig
from sitl import frames
from sitl.world import WorldConfig

pytestmark = pytest.mark.process

CAMERA = (1, 100)


def _ports() -> PortPlan:
    """Every link of one vehicle on a fresh block of ports (the camera's must be known)."""
    b = free_port_block(7)
    return PortPlan(
        sdk_base=b,
        listen_base=b + 1,
        gcs_port=b + 2,
        gcs_listen_base=b + 3,
        video_base=b + 4,
        payload_listen_base=b + 5,
        payload_base=b + 6,
    )


def _run(sim: Simulation, clients, seconds: float, until=None) -> None:
    """Run ``seconds`` of simulation time in 20 ms slices, reading the clients between them."""
    for _ in range(round(seconds / 0.02)):
        sim.run_lockstep(0.02)
        for c in clients:
            c.drain()
        if until is not None and until():
            return


@pytest.fixture
def rig(tmp_path):
    config = SimulationConfig(
        ports=_ports(),
        record_hz=0,
        out_dir=tmp_path / "run",
        world=WorldConfig(cameras=True),
    )
    sim = Simulation(config)
    ports = config.ports
    sdk = UdpClient(245, port=ports.sdk_port(0), to=("127.0.0.1", ports.listen_port(0)))
    gcs = UdpClient(255, port=ports.gcs_port, to=("127.0.0.1", ports.gcs_listen_port(0)))
    yield sim, sdk, gcs
    for item in (sdk, gcs, sim):
        item.close()


def _command(command: int, *params: float, target=(1, 100)):
    padded = list(params) + [0.0] * (7 - len(params))
    return mavlink2.MAVLink_command_long_message(*target, command, 0, *padded)


def test_camera_heartbeat_reaches_the_onboard_and_ground_station_links(rig):
    sim, sdk, gcs = rig
    _run(sim, (sdk, gcs), 2.5)
    for client in (sdk, gcs):
        beats = client.of("HEARTBEAT", CAMERA)
        assert len(beats) >= 2
        assert beats[0].type == mavlink2.MAV_TYPE_CAMERA
    # Each client sees the vehicle and its camera only, not the other client's system.
    assert not [m for m in sdk.inbox if m.get_srcSystem() == 255]
    assert not [m for m in gcs.inbox if m.get_srcSystem() == 245]


def test_video_stream_information_answers_with_a_uri_opencv_reads(rig):
    """The issue's "Done when": a plain pymavlink client asks component 100 for
    VIDEO_STREAM_INFORMATION and OpenCV in another process reads non-blank frames from it."""
    sim, sdk, gcs = rig
    sdk.send(_command(mavlink2.MAV_CMD_REQUEST_MESSAGE, 269))
    _run(sim, (sdk, gcs), 1.0, until=lambda: sdk.of("VIDEO_STREAM_INFORMATION", CAMERA))
    acks = sdk.of("COMMAND_ACK", CAMERA)
    assert [(a.command, a.result) for a in acks] == [(512, mavlink2.MAV_RESULT_ACCEPTED)]
    (info,) = sdk.of("VIDEO_STREAM_INFORMATION", CAMERA)
    assert (
        info.uri
        == sim.video_uris[0]
        == f"http://127.0.0.1:{sim.config.ports.video_base}/video.mjpg"
    )
    result, err = read_while_running(sim, info.uri, 3, max_duration_s=120.0, timeout_s=30)
    assert result["opened"], err
    assert len(result["stds"]) == 3 and min(result["stds"]) > 1.0


def test_photo_is_written_and_geotagged_where_the_vehicle_is(rig, tmp_path):
    sim, sdk, gcs = rig
    _run(sim, (sdk, gcs), 1.0)
    sdk.send(_command(mavlink2.MAV_CMD_IMAGE_START_CAPTURE, 0, 0, 1, 1))
    _run(sim, (sdk, gcs), 1.0, until=lambda: gcs.of("CAMERA_IMAGE_CAPTURED", CAMERA))
    (shot,) = sdk.of("CAMERA_IMAGE_CAPTURED", CAMERA)
    assert len(gcs.of("CAMERA_IMAGE_CAPTURED", CAMERA)) == 1  # the ground station sees it too
    assert shot.capture_result == 1
    path = Path(unquote(urlparse(shot.file_url).path))
    assert path == (tmp_path / "run" / "vehicle1" / "camera" / "IMG_0001.jpg").resolve()
    assert path.stat().st_size > 1000
    truth = np.asarray(sim.world.truth.position_enu_m[0], float)
    lat, lon, _ = frames.enu_to_geodetic(truth, sim.world.origin)
    north_m = (shot.lat / 1e7 - float(lat)) * 111_132.0
    east_m = (shot.lon / 1e7 - float(lon)) * 111_132.0 * math.cos(math.radians(float(lat)))
    assert math.hypot(north_m, east_m) < 0.5  # the lens is 0.16 m ahead of the centre of mass
    assert abs(shot.relative_alt / 1e3 - truth[2]) < 0.5


def test_a_command_for_the_camera_comes_out_of_the_payload_link(tmp_path):
    """With the simulated camera unplugged, a raw socket on its port receives MAVSDK's command
    for compid 100 verbatim, and what it sends as compid 100 reaches the onboard client."""
    ports = _ports()
    config = SimulationConfig(ports=ports, record_hz=0, world=WorldConfig(cameras=True))
    with Simulation(config) as sim:
        sim.camera_managers[0].close()
        sim.camera_managers[0] = None
        camera = UdpClient(
            1, 100, port=ports.payload_port(0), to=("127.0.0.1", ports.payload_listen_port(0))
        )
        sdk = UdpClient(245, port=ports.sdk_port(0), to=("127.0.0.1", ports.listen_port(0)))
        try:
            cmd = _command(mavlink2.MAV_CMD_IMAGE_START_CAPTURE, 0, 0, 1, 3)
            sdk.send(cmd)
            _run(sim, (camera, sdk), 0.5, until=lambda: camera.of("COMMAND_LONG", (245, 190)))
            (got,) = camera.of("COMMAND_LONG", (245, 190))
            assert (got.target_component, got.command, got.param4) == (100, 2000, 3.0)
            camera.send(mavlink2.MAVLink_command_ack_message(2000, 0, 0, 0, 245, 190))
            _run(sim, (camera, sdk), 0.5, until=lambda: sdk.of("COMMAND_ACK", CAMERA))
            assert [a.command for a in sdk.of("COMMAND_ACK", CAMERA)] == [2000]
            # No telemetry streams on the payload link (PX4: 4000 B/s): HEARTBEAT, and the
            # MISSION_CURRENT every link sends when the mission state changes.
            kinds = {m.get_type() for m in camera.inbox if m.get_srcComponent() == 1}
            assert "HEARTBEAT" in kinds and kinds <= {"HEARTBEAT", "MISSION_CURRENT"}
        finally:
            camera.close()
            sdk.close()


def test_a_taken_camera_port_is_a_clear_error():
    ports = _ports()
    blocker = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    blocker.bind(("127.0.0.1", ports.payload_port(0)))
    try:
        config = SimulationConfig(ports=ports, record_hz=0, world=WorldConfig(cameras=True))
        with pytest.raises(OSError, match=f"{ports.payload_port(0)}.*camera of system 1"):
            Simulation(config)
    finally:
        blocker.close()
    # Everything the failed start opened was closed: the same ports start now.
    with Simulation(config) as sim:
        assert sim.camera_managers[0] is not None
