"""MAVSDK's camera plugin against the simulated camera (component 100, via the vehicle's links).

The simulation runs in this process in lockstep with the client, at most
:data:`e2e_support.SPEED` (its time published in a clock file, as ``swarmsitl up --lockstep``
does); the client runs in its own process with its own
mavsdk_server. Each test's UDP and gRPC ports are a block of the suite's allocator
(:func:`harness.run.ports.free_port_block`).
"""

from __future__ import annotations

import math
from pathlib import Path
from urllib.parse import unquote, urlparse

import numpy as np
import pytest
from e2e_support import (
    CLIENT_TIMEOUT_SIM_S,
    lockstep_clock,
    require_free_udp,
    run_lockstep,
    start_client,
)

from harness.run.lockstep import LOCKSTEP
from harness.run.ports import free_port_block
from harness.sim.simulation import PortPlan, Simulation, SimulationConfig
from sitl import frames
from sitl.world import WorldConfig

pytestmark = pytest.mark.e2e

PORT_BLOCK = 8
"""Ports of one test: the vehicle's links at +0..+6, the client's mavsdk_server at +7."""


def _ports() -> PortPlan:
    """A fresh block of ports of the suite's allocator for one vehicle's links."""
    b = free_port_block(PORT_BLOCK)
    return PortPlan(
        sdk_base=b,
        listen_base=b + 1,
        gcs_port=0,
        video_base=b + 4,
        payload_listen_base=b + 5,
        payload_base=b + 6,
    )


def _run_with_client(sim: Simulation, script: str, args: list[str], logs: Path, grpc: int):
    """Run the simulation in lockstep until the client ends (at most CLIENT_TIMEOUT_SIM_S
    simulated seconds, its clock published for the client); return the client's result."""
    with lockstep_clock(sim.config.out_dir / "clock") as (clock, acks):
        client = start_client(script, args, logs, clock=clock.path, grpc_port=grpc)
        try:
            run_lockstep(sim, clock, acks, client.finished, CLIENT_TIMEOUT_SIM_S)
        finally:
            result = client.result()
    return result


@pytest.mark.parametrize(
    ("script", "own_server"),
    [("classic_camera.py", True), ("native_camera.py", False)],
    ids=["classic", "native"],
)
def test_camera_plugin_takes_a_geotagged_photo(tmp_path, client_logs, script, own_server):
    """MAVSDK's camera plugin (classic mavsdk_grpc, native mavsdk 4.x): the camera is listed
    with the spec's optics, its stream URI is the simulation's, and take_photo yields a
    successful CaptureInfo whose file exists and whose position is where the vehicle stands."""
    ports = _ports()
    grpc = ports.sdk_base + PORT_BLOCK - 1 if own_server else None
    require_free_udp([ports.sdk_port(0)])
    config = SimulationConfig(
        ports=ports,
        record_hz=0,
        out_dir=tmp_path / "run",
        world=WorldConfig(cameras=True),
        ping_period_s=LOCKSTEP.ping_period_s,
    )
    with Simulation(config) as sim:
        args = ["--url", f"udpin://0.0.0.0:{ports.sdk_port(0)}"]
        if grpc is not None:
            args += ["--grpc-port", str(grpc)]
        result = _run_with_client(sim, script, args, client_logs, grpc)
        assert result.ok, result.describe()
        truth = np.asarray(sim.world.truth.position_enu_m[0], float)
        lat, lon, _ = frames.enu_to_geodetic(truth, sim.world.origin)
        spec = sim.world.camera_specs[0]
        video_uri = sim.video_uris[0]
    data = result.data
    cam = data["camera"]
    assert cam["component_id"] == 100
    assert cam["resolution"] == [spec.width_px, spec.height_px]
    hfov = math.degrees(2 * math.atan(cam["sensor_h_mm"] / (2 * cam["focal_length_mm"])))
    assert hfov == pytest.approx(spec.hfov_deg, abs=0.05)
    assert data["video"]["uri"] == video_uri
    capture = data["capture"]
    assert capture["is_success"] and capture["index"] == 0
    assert capture["component_id"] == 100
    path = Path(unquote(urlparse(capture["file_url"]).path))
    assert path.is_file() and path.stat().st_size > 1000
    assert path.parent == (tmp_path / "run" / "vehicle1" / "camera").resolve()
    # The vehicle stood still on the ground: the geotag is its true position (lens offset 0.2 m).
    north_m = (capture["lat_deg"] - float(lat)) * 111_132.0
    east_m = (capture["lon_deg"] - float(lon)) * 111_132.0 * math.cos(math.radians(float(lat)))
    assert math.hypot(north_m, east_m) < 0.5
    assert capture["rel_alt_m"] == pytest.approx(truth[2], abs=0.5)
    assert capture["pitch_deg"] == pytest.approx(spec.pitch_deg, abs=1.0)
