"""Camera streams of a running simulation: OpenCV reads them in another process; bad clients
never hold the simulation up."""

from __future__ import annotations

import socket
import urllib.request

import pytest
from stream_reader import read_while_running

from harness.run.ports import free_port_block
from harness.sim.simulation import PortPlan, Simulation, SimulationConfig
from sitl.physics.obstacles import BoxObstacle
from sitl.sensors.camera import CameraSpec, with_mount
from sitl.world import WorldConfig

pytestmark = pytest.mark.process

WALL = BoxObstacle((0.0, 4.0, 1.5), (6.0, 0.2, 3.0), rgba=(0.8, 0.3, 0.1, 1.0))


def _config(video_base: int, n: int = 1, frames=("typhoon_h480",), **world) -> SimulationConfig:
    return SimulationConfig(
        n_vehicles=n,
        frames=frames,
        mavlink=False,
        record_hz=0,
        ports=PortPlan(video_base=video_base),
        world=WorldConfig(cameras=True, obstacles=(WALL,), **world),
    )


def test_opencv_reads_each_vehicles_stream_while_the_simulation_runs():
    """Two Typhoons with forward cameras facing a wall: a separate OpenCV process reads
    non-blank 320x240 frames from vehicle 2's URI (video_base + 1) while the simulation steps."""
    camera = with_mount(CameraSpec(hfov_deg=90.0, rate_hz=10.0), "forward")
    base = free_port_block(2)
    with Simulation(_config(base, n=2, camera=camera)) as sim:
        assert sim.video_uris == [
            f"http://127.0.0.1:{base}/video.mjpg",
            f"http://127.0.0.1:{base + 1}/video.mjpg",
        ]
        result, err = read_while_running(
            sim, sim.video_uris[1], 5, max_duration_s=240.0, timeout_s=60
        )
        assert sim.video_servers[1].frames_published >= 5
    assert result["opened"], err
    assert result["shapes"] == [[240, 320, 3]] * 5
    assert min(result["stds"]) > 10.0  # wall, ground and sky: not blank


def test_clients_that_vanish_or_never_read_do_not_stall_the_simulation():
    """With a silent, a non-reading and a vanished client attached, the simulation completes
    its steps, and a new client is served afterwards."""
    with Simulation(_config(0, camera=CameraSpec(width_px=640, height_px=480))) as sim:
        port = sim.video_servers[0].port
        silent = socket.create_connection(("127.0.0.1", port))
        stalled = socket.create_connection(("127.0.0.1", port))
        stalled.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        stalled.sendall(b"GET /video.mjpg HTTP/1.1\r\nHost: x\r\n\r\n")
        vanished = socket.create_connection(("127.0.0.1", port))
        vanished.sendall(b"GET /video.mjpg HTTP/1.1\r\nHost: x\r\n\r\n")
        vanished.close()
        try:
            steps = round(3.0 * sim.config.physics_hz)
            for _ in range(steps):
                sim.step()
            assert sim.time_s == pytest.approx(3.0)
            assert sim.video_servers[0].frames_published == round(3.0 * 5.0)
            with urllib.request.urlopen(sim.video_uris[0], timeout=10) as reply:
                assert reply.headers["Content-Type"].startswith("multipart/x-mixed-replace")
                sim.step()  # no frame is due: the client waits for the next one
                for _ in range(round(0.2 * sim.config.physics_hz)):
                    sim.step()
                assert reply.readline() == b"--frame\r\n"
        finally:
            silent.close()
            stalled.close()


def test_no_streams_without_cameras_or_for_vehicles_without_one():
    config = SimulationConfig(n_vehicles=1, mavlink=False, record_hz=0)
    with Simulation(config) as sim:
        assert sim.video_uris == [None]
        assert sim.world.poll_cameras() is None
    mixed = _config(0, n=2, frames=("x500", "typhoon_h480"))
    with Simulation(mixed) as sim:
        assert sim.video_uris[0] is None
        assert sim.video_uris[1].startswith("http://127.0.0.1:")


def test_a_taken_video_port_is_a_clear_error():
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        with pytest.raises(OSError, match="camera stream of vehicle 1"):
            Simulation(_config(taken.getsockname()[1]))
