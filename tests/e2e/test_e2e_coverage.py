"""The coverage companion (``python -m companion.scripts.coverage``) against ``swarmsitl up``.

One vehicle with its camera streaming, in lockstep with the companion (at most
:data:`e2e_support.SPEED`); the companion runs
as ``swarmsitl run`` would start it: its own process, told everything by ``SWARMSITL_*``
variables, a small rectangle at 8 m so the flight takes about a simulated minute.
Its ports come from the suite's allocator (:func:`e2e_support.module_ports`,
:func:`harness.run.ports.free_port_block`).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import signal
import subprocess
import sys

import pytest
from e2e_support import (
    REPO_ROOT,
    WaitTimeout,
    kill_mavsdk_servers,
    lockstep_clock,
    mavsdk_servers,
    module_ports,
    require_free_udp,
    run_lockstep,
    start_swarm,
    stop_swarm,
    wait_sim,
)
from pymavlink import mavutil

from harness.run.lockstep import LOCKSTEP
from harness.run.ports import free_port_block
from sitl.world import WorldConfig

pytestmark = pytest.mark.e2e

PORTS = module_ports()
EXTRA = free_port_block(3)
"""The up run's video (TCP) port, then its payload and payload-listen ports."""
VIDEO_PORT = EXTRA
AREA_ENU_M = (-10.0, -10.0, 30.0, 15.0)
ALTITUDE_M = 8.0
TIMEOUT_SIM_S = 960.0
"""Simulated seconds the companion may run."""


TLOG_TYPES = ["HEARTBEAT", "EXTENDED_SYS_STATE", "GLOBAL_POSITION_INT"]


def _flight_in_tlog(path) -> dict:
    """Highest relative altitude, east/north extent, and the last armed and landed states."""
    log = mavutil.mavlink_connection(str(path))
    out = {"max_rel_alt_m": 0.0, "armed": None, "landed_state": None, "east": [], "north": []}
    origin = None
    try:
        while (msg := log.recv_match(type=TLOG_TYPES)) is not None:
            if msg.get_srcSystem() != 1 or msg.get_srcComponent() != 1:
                continue
            kind = msg.get_type()
            if kind == "HEARTBEAT":
                out["armed"] = bool(msg.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
            elif kind == "EXTENDED_SYS_STATE":
                out["landed_state"] = msg.landed_state
            elif kind == "GLOBAL_POSITION_INT":
                out["max_rel_alt_m"] = max(out["max_rel_alt_m"], msg.relative_alt / 1000.0)
                if origin is None:
                    origin = (msg.lat, msg.lon)
                # metres east/north of the first fix (small distances: flat Earth is fine)
                out["north"].append((msg.lat - origin[0]) * 1e-7 * 111_195.0)
                out["east"].append((msg.lon - origin[1]) * 1e-7 * 111_195.0 * 0.6769)
    finally:
        log.close()
    return out


def _companion_env(out_dir, clock, duration_s: float, params: dict, video: bool) -> dict[str, str]:
    """The SWARMSITL_* variables swarmsitl run would give vehicle 1's companion."""
    cfg = WorldConfig()
    origin = (cfg.origin_lat_deg, cfg.origin_lon_deg, cfg.origin_alt_amsl_m)
    env = os.environ | {
        "PYTHONUNBUFFERED": "1",
        "SWARMSITL_CLOCK_FILE": str(clock),
        "SWARMSITL_MAVLINK_URL": PORTS.url(0),
        "SWARMSITL_GRPC_PORT": str(PORTS.grpc),
        "SWARMSITL_VEHICLE": "1",
        "SWARMSITL_VEHICLES": "1",
        "SWARMSITL_ROLE": "coverage",
        "SWARMSITL_ROLE_INDEX": "0",
        "SWARMSITL_ROLE_COUNT": "1",
        "SWARMSITL_OUT": str(out_dir),
        "SWARMSITL_ORIGIN": ",".join(str(v) for v in origin),
        "SWARMSITL_DURATION_S": str(duration_s),
        "SWARMSITL_PARAMS": json.dumps(params),
    }
    if video:
        env["SWARMSITL_VIDEO_URI"] = f"http://127.0.0.1:{VIDEO_PORT}/video.mjpg"
    return env


def _run_companion(swarm, env: dict[str, str]) -> tuple[int, str, str]:
    """Run the companion to its end (within TIMEOUT_SIM_S), then stop the swarm;
    (rc, stdout, stderr)."""
    out_path, err_path = swarm.out.parent / "companion.out", swarm.out.parent / "companion.err"
    try:
        with out_path.open("w") as out, err_path.open("w") as err:
            proc = subprocess.Popen(
                [sys.executable, "-m", "companion.scripts.coverage"],
                stdout=out, stderr=err, stdin=subprocess.DEVNULL, cwd=REPO_ROOT, env=env,
                text=True, start_new_session=True,
            )  # fmt: skip
        try:
            wait_sim(
                lambda: proc.poll() is not None, TIMEOUT_SIM_S, swarm.clock, "the companion's end"
            )
        except WaitTimeout:
            pytest.fail(
                f"coverage companion timed out\n{out_path.read_text()}\n"
                f"{err_path.read_text()[-3000:]}"
            )
        finally:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            kill_mavsdk_servers(PORTS.grpc)
    finally:
        stop_swarm(swarm)
    return proc.returncode, out_path.read_text(), err_path.read_text()


def _events(stdout: str) -> dict[str, dict]:
    """The companion's logged events by name (the last of each)."""
    out = {}
    for line in stdout.splitlines():
        if line.startswith("[coverage] "):
            name, _, data = line.removeprefix("[coverage] ").partition(" ")
            out[name] = json.loads(data) if data.strip() else {}
    return out


@pytest.mark.slow  # the demo's test (tests/harness/test_demo_e2e.py) flies it in the default run
def test_the_coverage_companion_flies_its_lanes_and_lands(tmp_path):
    """It plans the rectangle's lanes, flies them with the camera on, returns, lands, disarms
    and writes result.json: the whole rectangle under the footprint, a flown distance at least
    the lanes' length, frames used, no spill seen on a plain ground (no false positives)."""
    require_free_udp([PORTS.sdk, PORTS.listen])
    assert not mavsdk_servers(PORTS.grpc)
    extra = (
        "--camera", "--video-port", VIDEO_PORT,
        "--payload-port", EXTRA + 1, "--payload-listen-port", EXTRA + 2,
    )  # fmt: skip
    swarm = start_swarm(1, PORTS, tmp_path / "run", extra=extra)
    out_dir = tmp_path / "vehicle1"
    params = {"area_enu_m": AREA_ENU_M, "altitude_m": ALTITUDE_M, "speed_m_s": 5.0}
    rc, stdout, stderr = _run_companion(
        swarm, _companion_env(out_dir, swarm.clock, 400.0, params, True)
    )
    assert rc == 0, f"rc={rc}\n{stdout}\n{stderr[-3000:]}"
    for event in ("planned", "took_off", "mission_done", "landed", "disarmed"):
        assert f"[coverage] {event}" in stdout, stdout
    result = json.loads((out_dir / "result.json").read_text())
    assert set(result) >= {
        "spills_seen", "spills_in_footprint", "distance_flown_m", "coverage_fraction",
    }  # fmt: skip
    assert result["coverage_fraction"]["value"] >= 0.95
    # Two 40 m lanes and the step between them, plus the climb and the descent at least.
    assert result["distance_flown_m"]["value"] >= 80.0 + 2 * ALTITUDE_M
    assert result["camera_frames_used"]["value"] > 20
    assert result["spills_seen"]["value"] == 0
    assert result["spills_in_footprint"]["value"] == 0
    flight = _flight_in_tlog(swarm.tlog(0))
    assert flight["max_rel_alt_m"] >= 0.9 * ALTITUDE_M
    assert flight["armed"] is False
    assert flight["landed_state"] == mavutil.mavlink.MAV_LANDED_STATE_ON_GROUND
    # The track reached both ends of the lanes (the rectangle spans 40 m east-west).
    assert max(flight["east"]) - min(flight["east"]) >= 30.0


@pytest.mark.slow  # the demo's test checks the spills found against the world's in the default run
def test_the_coverage_companion_counts_dark_patches_where_they_lie(tmp_path):
    """Two spill-coloured slabs in the rectangle (simulation in this process, in lockstep): the
    camera thread finds exactly two spills, each within 3 m of a slab's centre (frames, poses, the
    attitude quaternion and the camera model agree)."""
    from harness.sim.simulation import PortPlan, Simulation, SimulationConfig
    from sitl.physics.obstacles import BoxObstacle

    b = free_port_block(6)
    ports = PortPlan(
        sdk_base=b, listen_base=b + 1, gcs_port=0, video_base=b + 2,
        payload_listen_base=b + 3, payload_base=b + 4,
    )  # fmt: skip
    require_free_udp([b, b + 1])
    slabs_xy = [(5.0, -3.0), (22.0, 9.0)]
    slabs = tuple(
        BoxObstacle((x, y, 0.05), (8.0, 6.0, 0.1), rgba=(0.06, 0.05, 0.05, 1.0))
        for x, y in slabs_xy
    )
    config = SimulationConfig(
        ports=ports,
        record_hz=0,
        out_dir=tmp_path / "run",
        world=WorldConfig(cameras=True, obstacles=slabs),
        ping_period_s=LOCKSTEP.ping_period_s,
    )
    grpc = b + 5
    with Simulation(config) as sim, contextlib.ExitStack() as stack:
        origin = sim.world.origin
        clock, acks = stack.enter_context(lockstep_clock(tmp_path / "run" / "clock"))
        env = os.environ | {
            "PYTHONUNBUFFERED": "1",
            "SWARMSITL_CLOCK_FILE": str(clock.path),
            "SWARMSITL_MAVLINK_URL": f"udpin://0.0.0.0:{ports.sdk_port(0)}",
            "SWARMSITL_GRPC_PORT": str(grpc),
            "SWARMSITL_VEHICLE": "1",
            "SWARMSITL_OUT": str(tmp_path / "vehicle1"),
            "SWARMSITL_ORIGIN": f"{origin.lat_deg},{origin.lon_deg},{origin.alt_amsl_m}",
            "SWARMSITL_VIDEO_URI": sim.video_uris[0],
            "SWARMSITL_DURATION_S": "400",
            "SWARMSITL_PARAMS": json.dumps(
                {"area_enu_m": AREA_ENU_M, "altitude_m": ALTITUDE_M, "speed_m_s": 5.0}
            ),
        }
        with (
            (tmp_path / "companion.out").open("w") as out,
            (tmp_path / "companion.err").open("w") as err,
        ):
            proc = subprocess.Popen(
                [sys.executable, "-m", "companion.scripts.coverage"],
                stdout=out, stderr=err, stdin=subprocess.DEVNULL, cwd=REPO_ROOT, env=env,
                text=True, start_new_session=True,
            )  # fmt: skip
        try:
            run_lockstep(sim, clock, acks, lambda: proc.poll() is not None, TIMEOUT_SIM_S)
        finally:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            kill_mavsdk_servers(grpc)
    stdout = (tmp_path / "companion.out").read_text()
    stderr = (tmp_path / "companion.err").read_text()
    assert proc.returncode == 0, f"rc={proc.returncode}\n{stdout}\n{stderr[-3000:]}"
    result = json.loads((tmp_path / "vehicle1" / "result.json").read_text())
    assert result["spills_seen"]["value"] == 2, stdout
    line = next(x for x in stdout.splitlines() if x.startswith("[coverage] spills "))
    seen = json.loads(line.removeprefix("[coverage] spills "))["positions_enu_m"]
    for x, y in slabs_xy:
        assert min(math.hypot(p[0] - x, p[1] - y) for p in seen) < 3.0, seen


def test_the_coverage_companion_goes_home_in_time_when_it_is_late(tmp_path):
    """A 200 m strip, a short run and a budget that assumes the full speed throughout: the
    vehicle falls behind, goes home before the end of its lanes, and has landed and disarmed
    before the run's end."""
    require_free_udp([PORTS.sdk, PORTS.listen])
    assert not mavsdk_servers(PORTS.grpc)
    swarm = start_swarm(1, PORTS, tmp_path / "run")
    duration_s = 75.0
    params = {
        "area_enu_m": [-10.0, -10.0, 190.0, 10.0],
        "altitude_m": ALTITUDE_M,
        "speed_m_s": 8.0,
        "mean_speed_fraction": 1.0,
    }
    env = _companion_env(tmp_path / "vehicle1", swarm.clock, duration_s, params, False)
    rc, stdout, stderr = _run_companion(swarm, env)
    assert rc == 0, f"rc={rc}\n{stdout}\n{stderr[-3000:]}"
    events = _events(stdout)
    assert "time_up" in events and "mission_done" not in events, stdout
    assert events["disarmed"]["vehicle_time_s"] <= duration_s, stdout
    flight = _flight_in_tlog(swarm.tlog(0))
    assert flight["armed"] is False
    assert flight["landed_state"] == mavutil.mavlink.MAV_LANDED_STATE_ON_GROUND
    # Landed back at home (within a few metres), not where it gave up.
    assert abs(flight["east"][-1]) < 3.0 and abs(flight["north"][-1]) < 3.0
