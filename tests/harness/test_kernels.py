"""harness.kernels: compile_all readies every kernel in src/; the compile guard refuses compiles.

The coverage check and the flights run in fresh interpreters (what a ``swarmsitl`` process or an
xdist worker starts with): in this process other tests have called kernels already. With the
cache filled at the session's start they load in about a second.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numba
import pytest
from typer.testing import CliRunner

from harness import cli
from harness.kernels import (
    COMPILE_LOG_ENV,
    FORBID_COMPILE_ENV,
    KernelCompileError,
    compile_all,
    compiles_forbidden,
)

pytestmark = pytest.mark.process

SRC = Path(__file__).resolve().parents[2] / "src"

EVERY_DISPATCHER = textwrap.dedent(
    """
    import importlib, json, pkgutil, sys
    from pathlib import Path
    from numba.core.registry import CPUDispatcher
    from harness.kernels import compile_all

    compile_all()
    kernels, helpers, unready = [], [], []
    for pkg in sorted(p.parent.name for p in Path(sys.argv[1]).glob("*/__init__.py")):
        names = [pkg] + [
            m.name for m in pkgutil.walk_packages(importlib.import_module(pkg).__path__, pkg + ".")
        ]
        for name in names:
            module = importlib.import_module(name)
            for attr, value in vars(module).items():
                if not isinstance(value, CPUDispatcher) or value.py_func.__module__ != name:
                    continue
                if value.targetoptions.get("no_cpython_wrapper", False):
                    helpers.append(f"{name}:{attr}")
                    continue
                kernels.append(f"{name}:{attr}")
                if not value.signatures:
                    unready.append(f"{name}:{attr}")
    print(json.dumps({"kernels": kernels, "helpers": helpers, "unready": unready}))
    """
)
"""After compile_all, imports every module under src/ and lists the numba dispatchers."""


def run_python(script: str, *args: str, **env: str) -> subprocess.CompletedProcess[str]:
    """``script`` in a fresh interpreter (this environment plus ``env``, no compile guard)."""
    base = {k: v for k, v in os.environ.items() if k not in (FORBID_COMPILE_ENV, COMPILE_LOG_ENV)}
    return subprocess.run(
        [sys.executable, "-c", script, *args],
        capture_output=True,
        text=True,
        env=base | env,
        timeout=600,
        check=False,
    )


def test_compile_all_readies_every_kernel_in_src():
    """Every dispatcher callable from Python has a signature after compile_all (a new kernel
    must be added to harness.kernels.SIGNATURES); helpers are compiled into their callers."""
    proc = run_python(EVERY_DISPATCHER, str(SRC))
    assert proc.returncode == 0, proc.stderr[-3000:]
    found = json.loads(proc.stdout.splitlines()[-1])
    assert found["unready"] == [], (
        "kernels compile_all does not load (add them to harness.kernels.SIGNATURES with the "
        f"argument types their callers pass): {found['unready']}"
    )
    assert len(found["kernels"]) >= 20 and len(found["helpers"]) >= 25, found
    assert "autopilot_emu.control.trajectory_kernel:hold_point_kernel" in found["kernels"]


FLIGHTS = textwrap.dedent(
    """
    from autopilot_emu.modes import AutoSubMode, MainMode
    from harness.kernels import compile_all, forbid_compiles
    from harness.sim.simulation import Simulation, SimulationConfig
    from sitl.physics.wind import WindConfig

    compile_all()
    guard = forbid_compiles()
    fleets = [
        ("typhoon_h480",),
        ("x500", "x500"),  # several vehicles of one airframe: strided sensor views
        ("typhoon_h480", "x500", "x500"),  # mixed: a one-vehicle group and a sliced group
        ("x500", "typhoon_h480", "x500"),  # mixed: a gathered group
    ]
    for frames in fleets:
        config = SimulationConfig(
            n_vehicles=len(frames), frames=frames, mavlink=False, record_hz=0.0, mocap_port=0,
            wind=WindConfig(speed_m_s=4.0, turbulence_w20_m_s=3.0),
        )
        with Simulation(config) as sim:
            sim.run_lockstep(2.0)  # the estimator settles: arming is accepted
            for i in range(sim.fleet.n):
                assert sim.fleet.vehicle(i).arm(False) == 0
                assert sim.fleet.vehicle(i).takeoff(None) == 0
            sim.run_lockstep(5.0)
            for i in range(sim.fleet.n):  # Hold: the hold-point search
                sim.fleet.vehicle(i).set_mode(MainMode.AUTO, AutoSubMode.LOITER)
            sim.run_lockstep(1.0)
            assert all(c.in_air for c in sim.fleet.commanders)
    print("compiles:", guard.violations)
    """
)


def test_flights_after_compile_all_compile_nothing():
    """Fleets of one and both airframes, wind, take-off and Hold under the compile guard: every
    signature they call was loaded by compile_all (the guard would raise and name it)."""
    proc = run_python(FLIGHTS)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.strip().endswith("compiles: []"), proc.stdout


CACHED_KERNEL = textwrap.dedent(
    """
    import numba

    @numba.njit(cache=True)
    def plus_one(x):
        return x + 1.0
    """
)
CALL_UNDER_GUARD = (
    "from harness.kernels import forbid_compiles_if_requested\n"
    "forbid_compiles_if_requested()\n"
    "import cached_kernel\n"
    "print(cached_kernel.plus_one(1.0))\n"
)


def test_the_guard_refuses_a_compile_and_passes_a_cache_load(tmp_path):
    """Numba fires ``numba:compile`` on a cache miss only: with the guard requested, a cold
    cache fails naming the kernel (and logs it); once cached, the same call loads and passes."""
    (tmp_path / "cached_kernel.py").write_text(CACHED_KERNEL)
    log = tmp_path / "compiles.log"
    env = {"PYTHONPATH": str(tmp_path), "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    guarded = env | {FORBID_COMPILE_ENV: "1", COMPILE_LOG_ENV: str(log)}

    cold = run_python(CALL_UNDER_GUARD, **guarded)
    assert cold.returncode != 0
    assert "KernelCompileError" in cold.stderr and "cached_kernel.plus_one(float64)" in cold.stderr
    assert log.read_text().split(maxsplit=1)[1] == "cached_kernel.plus_one(float64)\n"

    fill = run_python(CALL_UNDER_GUARD, **env)  # no guard: compiles and caches
    assert fill.returncode == 0 and fill.stdout.strip() == "2.0", fill.stderr

    log.unlink()
    warm = run_python(CALL_UNDER_GUARD, **guarded)
    assert warm.returncode == 0 and warm.stdout.strip() == "2.0", warm.stderr
    assert not log.exists()


def test_the_guard_raises_in_process_and_is_removed_after_the_block(tmp_path):
    """A compile inside ``compiles_forbidden`` raises KernelCompileError naming the kernel."""

    @numba.njit
    def twice(x: float) -> float:
        return 2.0 * x

    log = tmp_path / "compiles.log"
    with compiles_forbidden(log) as guard, pytest.raises(KernelCompileError, match="twice"):
        twice(1.5)
    assert len(guard.violations) == 1 and "twice(float64)" in guard.violations[0]
    assert "twice(float64)" in log.read_text()
    assert twice(1.5) == 3.0  # allowed again


def test_compile_all_is_idempotent():
    """A second call finds every signature loaded: nothing compiles, and it is quick."""
    compile_all()
    again = compile_all()
    assert again.compiled == ()
    assert again.signatures >= 25


def test_swarmsitl_installs_the_guard_before_any_command(monkeypatch):
    """The command line's top-level callback asks for the guard (it reads the variable)."""
    calls = []
    monkeypatch.setattr(cli, "forbid_compiles_if_requested", lambda: calls.append(1))
    result = CliRunner().invoke(cli.app, ["replay", "--help"])
    assert result.exit_code == 0, result.output
    assert calls == [1]
