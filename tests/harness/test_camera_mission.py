"""A mission's camera item on the full stack: the autopilot sends IMAGE_START_CAPTURE to its
camera (compid 100) over the payload link and the camera's CAMERA_IMAGE_CAPTURED reaches the
client, geotagged where the item was reached. Lockstep; waits in simulated time. Ports:
the payload link's from the suite's allocator (the camera's port must be known), the others
OS-chosen."""

from __future__ import annotations

import math

import pytest
from mission_link import SimLink, free_udp_port, mission_cmd, offset_deg, waypoint
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.modes import AutoSubMode
from harness.run.ports import free_port_block
from harness.sim.simulation import PortPlan, Simulation, SimulationConfig
from sitl.world import WorldConfig

pytestmark = pytest.mark.sockets

AUTO = 4
M_PER_DEG = 111_195.0


@pytest.fixture
def link(tmp_path):
    port = free_udp_port()
    sim = Simulation(
        SimulationConfig(
            seed=3,
            record_hz=0,
            out_dir=tmp_path / "run",
            ports=PortPlan(
                listen_base=0,
                sdk_base=port,
                gcs_port=0,
                video_base=0,
                payload_listen_base=0,
                payload_base=free_port_block(),
            ),
            world=WorldConfig(cameras=True),
        )
    )
    lk = SimLink(sim, port)
    lk.wait_ready()
    yield lk
    lk.close()


def test_mission_camera_item_produces_a_geotagged_image(link, tmp_path):
    items = [
        waypoint(12, 0, 8, hold_s=1.0),
        mission_cmd(mavlink2.MAV_CMD_IMAGE_START_CAPTURE, 0, 0, 1, 0),
        waypoint(12, 12, 8),
    ]
    assert link.upload(items) == mavlink2.MAV_MISSION_ACCEPTED
    assert link.arm() == 0
    assert link.set_mode(AUTO, AutoSubMode.MISSION) == 0
    shot = link.wait_type("CAMERA_IMAGE_CAPTURED", timeout_s=90.0)
    assert (shot.get_srcSystem(), shot.get_srcComponent()) == (1, 100)
    assert (shot.image_index, shot.capture_result) == (0, 1)
    assert (tmp_path / "run" / "vehicle1" / "camera" / "IMG_0001.jpg").is_file()
    lat, lon = offset_deg(12, 0)
    north_m = (shot.lat / 1e7 - lat) * M_PER_DEG
    east_m = (shot.lon / 1e7 - lon) * M_PER_DEG * math.cos(math.radians(lat))
    assert math.hypot(north_m, east_m) < 1.5  # taken at the first waypoint (1 m acceptance)
    assert shot.relative_alt / 1e3 == pytest.approx(8.0, abs=1.0)
    # The camera ACKed the autopilot's command; that ACK is for the autopilot, not forwarded.
    assert not [
        m for m in link.inbox if m.get_type() == "COMMAND_ACK" and m.get_srcComponent() == 100
    ]
    camera = link.sim.camera_managers[0].protocol
    assert camera.stats.commands == 1 and camera.stats.images == 1
