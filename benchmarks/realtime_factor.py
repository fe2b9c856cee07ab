"""Real-time factor of the full stack (physics + sensors + autopilots + MAVLink endpoints).

Runs, in lockstep (no pacing, no clients), a takeoff + hover + goto scenario for N = 1, 3, 10
vehicles and measures simulated seconds per wall second; then runs PyFlyt (its own venv, as a
subprocess) with the same vehicle counts and simulated time for comparison.

    python benchmarks/realtime_factor.py --vehicles 1,3,10
    python benchmarks/realtime_factor.py --vehicles 1,3,10,100     # PyFlyt is not run at 100
    python benchmarks/realtime_factor.py --vehicles 1 --profile      # where the time goes

Before the runs it times the start-up of a fresh process (imports, world, one simulated
second) twice: cold, with an empty numba cache (every compiled kernel compiles), and warm (the
kernels load from that cache). The last line is
``RESULT rtf_1=... rtf_3=... rtf_10=... [rtf_100=...] pyflyt_rtf_1=... ... startup_cold_s=...
startup_warm_s=... up_warm_s=...``
(``up_warm_s``: ``swarmsitl up`` with one vehicle, from launch until it says it is ready).
"""

from __future__ import annotations

import argparse
import cProfile
import io
import math
import os
import platform
import pstats
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pybullet
import pymap3d

sys.path.insert(0, str(Path(__file__).resolve().parent))

from harness.sim.simulation import PortPlan, Simulation, SimulationConfig
from sitl.world import WorldConfig

TAKEOFF_AT_S = 3.0
GOTO_AT_S = 12.0
GOTO_NORTH_M = 20.0
MAX_VEHICLES = 200
"""Port block size: vehicle counts up to this fit in 2 x MAX_VEHICLES ports from --port-base."""
PYFLYT_MAX_VEHICLES = 10
"""PyFlyt is compared up to this many vehicles (the issue's comparison; larger runs are ours)."""

STARTUP_SCRIPT = """
import time
t0 = time.perf_counter()
from harness.sim.simulation import Simulation, SimulationConfig
t1 = time.perf_counter()
with Simulation(SimulationConfig(n_vehicles=1, mavlink=False, record_hz=0.0, mocap_port=0)) as sim:
    t2 = time.perf_counter()
    sim.run_lockstep(1.0)
    t3 = time.perf_counter()
print(f"{t1 - t0:.3f} {t2 - t1:.3f} {t3 - t2:.3f}")
"""


def up_startup_seconds(cache_dir: Path, port_base: int) -> float:
    """Wall s from launching ``swarmsitl up`` (1 vehicle, its defaults) to its "Press Ctrl-C".

    That line is printed once the simulation is built and every endpoint listens; the process
    is then interrupted (as a user would stop it).
    """
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir), COLUMNS="200")
    cmd = [
        sys.executable,
        "-c",
        "from harness.cli import app; app()",
        "up",
        "--sdk-port",
        str(port_base),
        "--listen-port",
        str(port_base + 1),
        "--gcs-port",
        "0",
        "--gcs-listen-port",
        str(port_base + 2),
        "--payload-port",
        str(port_base + 3),
        "--payload-listen-port",
        str(port_base + 4),
        "--video-port",
        "0",
        "--mocap-port",
        "0",
        "--out",
        str(cache_dir / "up-run"),
    ]
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )
    try:
        assert proc.stdout is not None
        for line in proc.stdout:
            if "Press Ctrl-C" in line:
                return time.perf_counter() - t0
        raise RuntimeError(f"swarmsitl up exited ({proc.wait()}) before it was ready")
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()


def startup_seconds(cache_dir: Path) -> tuple[float, float, float]:
    """Import, world build and first simulated second of a fresh process, wall s each.

    ``cache_dir`` is the numba cache the process uses (``NUMBA_CACHE_DIR``): an empty one makes
    every kernel compile, a filled one makes them load.
    """
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir))
    out = subprocess.run(
        [sys.executable, "-c", STARTUP_SCRIPT],
        env=env,
        capture_output=True,
        text=True,
        check=True,
        timeout=600,
    ).stdout.split()
    imports, build, first = (float(x) for x in out[-3:])
    return imports, build, first


def machine() -> str:
    """One line describing this machine and the library versions."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (
        f"{cpu}; {os.cpu_count()} cores; Python {platform.python_version()}; "
        f"numpy {np.__version__}; pybullet API {pybullet.getAPIVersion()}"
    )


def fly_scenario(
    n: int,
    sim_seconds: float,
    port_base: int,
    breakdown: bool = False,
    world: WorldConfig | None = None,
) -> tuple[float, dict]:
    """Run the scenario for n vehicles; return wall seconds and a flight summary.

    ``world``: the world beyond the defaults (e.g. cameras, rangefinders).
    """
    # One onboard link per vehicle (listening on listen_base + i, sending to sdk_base + i); no
    # ground-station or payload link.
    ports = PortPlan(
        sdk_base=port_base,
        listen_base=port_base + MAX_VEHICLES,
        gcs_port=0,
        video_base=0,
        payload_listen_base=0,
        payload_base=0,
    )
    cfg = SimulationConfig(n_vehicles=n, ports=ports, record_hz=0.0, world=world)
    with Simulation(cfg) as sim:
        vehicles = [sim.fleet.vehicle(i) for i in range(n)]
        start = sim.world.truth.position_enu_m.copy()
        if breakdown:
            sim.time_phases()
        t0 = time.perf_counter()
        sim.run_lockstep(TAKEOFF_AT_S)
        for v in vehicles:
            v.arm(False)
            v.takeoff(None)
        sim.run_lockstep(GOTO_AT_S - TAKEOFF_AT_S)
        for v in vehicles:
            tel = v.telemetry()
            home = tel.home
            if home is None:
                continue
            lat, lon, _ = pymap3d.ned2geodetic(
                GOTO_NORTH_M, 0.0, 0.0, home.lat_deg, home.lon_deg, home.alt_amsl_m
            )
            v.reposition(float(lat), float(lon), tel.alt_amsl_m, 0.0, math.nan)
        sim.run_lockstep(sim_seconds - sim.time_s)
        wall = time.perf_counter() - t0
        truth = sim.world.truth
        moved = truth.position_enu_m - start
        summary = {
            "north_m_mean": float(moved[:, 1].mean()),
            "up_m_mean": float(moved[:, 2].mean()),
            "armed": int(sum(c.armed for c in sim.fleet.commanders)),
        }
        if sim.phase_seconds is not None:
            summary["phases"] = dict(sim.phase_seconds)
    return wall, summary


def main() -> int:
    """Run the benchmark and print the RESULT line."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--vehicles", default="1,3,10", help="comma-separated vehicle counts")
    ap.add_argument("--sim-seconds", type=float, default=30.0)
    ap.add_argument("--no-pyflyt", action="store_true", help="skip the PyFlyt comparison")
    ap.add_argument("--profile", action="store_true", help="print the top functions by time")
    ap.add_argument("--port-base", type=int, default=24540, help="UDP ports to use")
    args = ap.parse_args()
    counts = [int(c) for c in args.vehicles.split(",") if c.strip()]
    print(f"machine: {machine()}")
    print(
        f"scenario: boot {TAKEOFF_AT_S:g} s, takeoff to MIS_TAKEOFF_ALT, hover, goto "
        f"{GOTO_NORTH_M:g} m north at {GOTO_AT_S:g} s, until {args.sim_seconds:g} s; "
        f"500 Hz physics, lockstep, MAVLink endpoints open, no clients"
    )
    if max(counts) > MAX_VEHICLES:
        ap.error(f"at most {MAX_VEHICLES} vehicles")
    with tempfile.TemporaryDirectory(prefix="swarmsitl-numba-") as cache:
        cold = startup_seconds(Path(cache))
        warm = startup_seconds(Path(cache))
        up_warm = up_startup_seconds(Path(cache), args.port_base + 2 * MAX_VEHICLES)
    for label, (imports, build, first) in (("cold", cold), ("warm", warm)):
        print(
            f"start-up {label} (numba cache {'empty' if label == 'cold' else 'filled'}): "
            f"{imports + build + first:.2f} s = imports {imports:.2f} s + world {build:.2f} s "
            f"+ first simulated second {first:.2f} s"
        )
    print(f"swarmsitl up (1 vehicle, its default sensors) ready after {up_warm:.2f} s (warm)")
    # Load every compiled kernel once in this process (start-up is reported above), so that the
    # runs below time the steady state.
    fly_scenario(1, 1.0, args.port_base)
    results: dict[str, str] = {}
    for n in counts:
        prof = cProfile.Profile() if args.profile else None
        if prof:
            prof.enable()
        wall, summary = fly_scenario(n, args.sim_seconds, args.port_base)
        # A second, instrumented run says where the time goes (timers cost a little).
        _, timed = fly_scenario(n, args.sim_seconds, args.port_base, breakdown=True)
        if prof:
            prof.disable()
        rtf = args.sim_seconds / wall
        steps = args.sim_seconds * 500
        print(
            f"swarmsitl N={n:3d}: {wall:7.2f} s wall for {args.sim_seconds:g} s sim -> "
            f"rtf {rtf:7.2f}  ({1e6 * wall / steps:7.1f} us per physics step)  "
            f"flight: {summary}"
        )
        results[f"rtf_{n}"] = f"{rtf:.2f}"
        phases = timed["phases"]
        total = sum(phases.values())
        print(
            "    where the time goes: "
            + ", ".join(
                f"{k} {100 * v / total:.0f}% ({1e6 * v / steps:.0f} us/step)"
                for k, v in phases.items()
            )
        )
        if prof:
            buf = io.StringIO()
            pstats.Stats(prof, stream=buf).sort_stats("tottime").print_stats(20)
            print(buf.getvalue())
    if not args.no_pyflyt:
        from pyflyt_runner import PeerUnavailable, run_pyflyt

        for n in (c for c in counts if c <= PYFLYT_MAX_VEHICLES):
            key = f"pyflyt_rtf_{n}"
            try:
                peer = run_pyflyt(n, args.sim_seconds)
                results[key] = f"{peer['rtf']:.2f}"
                print(
                    f"PyFlyt    N={n:3d}: {peer['wall_seconds']:7.2f} s wall -> rtf "
                    f"{peer['rtf']:7.2f} (PyFlyt {peer.get('pyflyt_version')}, physics "
                    f"{peer.get('physics_hz')} Hz, control {peer.get('control_hz')} Hz)"
                )
            except PeerUnavailable as exc:
                results[key] = "nan"
                print(f"PyFlyt    N={n:3d}: unavailable: {exc}")
    for n in counts:
        if f"pyflyt_rtf_{n}" in results and results[f"pyflyt_rtf_{n}"] != "nan":
            ratio = float(results[f"rtf_{n}"]) / float(results[f"pyflyt_rtf_{n}"])
            print(f"ratio swarmsitl/PyFlyt at N={n}: {ratio:.2f}")
    results["startup_cold_s"] = f"{sum(cold):.2f}"
    results["startup_warm_s"] = f"{sum(warm):.2f}"
    results["up_warm_s"] = f"{up_warm:.2f}"
    print("RESULT " + " ".join(f"{k}={v}" for k, v in results.items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
