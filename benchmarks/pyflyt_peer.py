"""PyFlyt side of the speed benchmark; runs inside the PyFlyt venv (numpy < 2).

Usage: ``python pyflyt_peer.py --vehicles N --sim-seconds T [--physics-hz 240] [--seed 0]``

Builds a DIRECT-mode (headless) PyFlyt ``Aviary`` of N QuadX drones on a grid, flies them in
position mode (mode 7: setpoint ``[x, y, yaw, z]``) through our benchmark scenario -- take off
to 5 m, hover, then move 20 m in +x at one third of the run -- and prints exactly one JSON line
on stdout. Everything else (pybullet's banner, PyFlyt's prints, warnings) goes to stderr.

Imports only PyFlyt, numpy and the standard library.

Two PyFlyt 0.29 details this script works around (see its ``core/aviary.py``):

* ``physics_hz`` only sets PyFlyt's own bookkeeping; the Aviary never calls ``setTimeStep``,
  so pybullet keeps integrating 1/240 s per step. We set the pybullet time step ourselves,
  otherwise any rate other than 240 Hz would silently run the physics at the wrong speed.
* ``Aviary(seed=0)`` is treated as "no seed" (``if seed``), so we pass ``np_random`` instead.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from typing import Any, TextIO

TAKEOFF_ALTITUDE_M = 5.0
MOVE_X_M = 20.0
SPACING_M = 3.0
PYFLYT_DEFAULT_CONTROL_HZ = 120


def _claim_stdout() -> TextIO:
    """Point fd 1 at stderr (C-level prints too) and return a handle on the real stdout."""
    sys.stdout.flush()
    real = os.fdopen(os.dup(1), "w", encoding="utf-8")
    os.dup2(2, 1)
    return real


def _emit(out: TextIO, payload: dict[str, Any]) -> None:
    out.write(json.dumps(payload, separators=(",", ":")) + "\n")
    out.flush()


def default_control_hz(physics_hz: int) -> int:
    """Divisor of ``physics_hz`` nearest PyFlyt's default 120 Hz (ties go to the faster one)."""
    divisors = [d for d in range(1, physics_hz + 1) if physics_hz % d == 0]
    return min(divisors, key=lambda d: (abs(d - PYFLYT_DEFAULT_CONTROL_HZ), -d))


def grid_positions(n: int, spacing: float) -> list[tuple[float, float]]:
    """Return ``n`` (x, y) ground positions on a square grid ``spacing`` metres apart."""
    cols = max(1, math.ceil(math.sqrt(n)))
    return [((i % cols) * spacing, (i // cols) * spacing) for i in range(n)]


def _build(n: int, physics_hz: int, control_hz: int, seed: int) -> Any:
    """Construct an armed Aviary with ``n`` QuadX drones on the ground, pybullet dt fixed."""
    import numpy as np
    from PyFlyt.core import Aviary

    xy = grid_positions(n, SPACING_M)
    start_pos = np.array([[x, y, 0.05] for x, y in xy], dtype=float)
    env = Aviary(
        start_pos=start_pos,
        start_orn=np.zeros_like(start_pos),
        drone_type="quadx",
        drone_options={"control_hz": control_hz},
        render=False,
        physics_hz=physics_hz,
        np_random=np.random.default_rng(seed),
    )
    env.setTimeStep(1.0 / physics_hz)
    env.set_mode(7)
    return env


def _set_targets(env: Any, dx: float) -> None:
    import numpy as np

    for i, (x, y) in enumerate(grid_positions(env.num_drones, SPACING_M)):
        env.set_setpoint(i, np.array([x + dx, y, 0.0, TAKEOFF_ALTITUDE_M]))


def _warm_up(physics_hz: int, control_hz: int, seed: int) -> float:
    """Fly a throwaway one-drone Aviary briefly so numba JIT compilation is not timed."""
    t0 = time.perf_counter()
    env = _build(1, physics_hz, control_hz, seed)
    _set_targets(env, 1.0)
    for _ in range(10):
        env.step()
    env.disconnect()
    return time.perf_counter() - t0


def run(vehicles: int, sim_seconds: float, physics_hz: int, control_hz: int, seed: int) -> dict:
    """Run the scenario and return the result record."""
    import numpy as np
    import PyFlyt

    try:
        from importlib.metadata import version

        pyflyt_version = version("PyFlyt")
    except Exception:
        pyflyt_version = getattr(PyFlyt, "__version__", "unknown")

    warmup_s = _warm_up(physics_hz, control_hz, seed)
    env = _build(vehicles, physics_hz, control_hz, seed)
    dt_bullet = float(env.getPhysicsEngineParameters()["fixedTimeStep"])
    control_hz_used = round(1.0 / env.drones[0].control_period)
    step_period = float(env.step_period)  # one Aviary.step() == one control period
    n_steps = round(sim_seconds / step_period)
    move_step = round(n_steps / 3)
    start = [list(env.state(i)[3]) for i in range(vehicles)]
    _set_targets(env, 0.0)

    t0 = time.perf_counter()
    for k in range(n_steps):
        if k == move_step:
            _set_targets(env, MOVE_X_M)
        env.step()
    wall = time.perf_counter() - t0

    sim_done = float(env.elapsed_time)
    final = [[round(float(v), 3) for v in env.state(i)[3]] for i in range(vehicles)]
    record = {
        "vehicles": vehicles,
        "sim_seconds": sim_done,
        "wall_seconds": wall,
        "rtf": sim_done / wall if wall > 0 else float("inf"),
        "physics_hz": physics_hz,
        "control_hz": control_hz_used,
        "pyflyt_version": pyflyt_version,
        "numpy_version": np.__version__,
        "final_positions": final,
        "start_positions": [[round(float(v), 3) for v in p] for p in start],
        "bullet_time_step": dt_bullet,
        "physics_steps": int(env.physics_steps),
        "move_at_s": move_step * step_period,
        "warmup_wall_seconds": warmup_s,
        "python_version": platform.python_version(),
    }
    env.disconnect()
    return record


def _parse(argv: list[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vehicles", type=int, required=True)
    ap.add_argument("--sim-seconds", type=float, required=True)
    ap.add_argument("--physics-hz", type=int, default=240)
    ap.add_argument(
        "--control-hz", type=int, default=None, help="default: divisor of physics-hz nearest 120"
    )
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    if args.vehicles < 1 or args.sim_seconds <= 0 or args.physics_hz < 1:
        ap.error("--vehicles, --sim-seconds and --physics-hz must be positive")
    if args.control_hz is None:
        args.control_hz = default_control_hz(args.physics_hz)
    if args.physics_hz % args.control_hz:
        ap.error(f"PyFlyt needs physics-hz ({args.physics_hz}) to be a multiple of control-hz")
    return args


def main(argv: list[str] | None = None) -> int:
    """Entry point: exactly one JSON line on stdout, ``{"error": ...}`` on failure."""
    args = _parse(argv)
    out = _claim_stdout()
    try:
        import numpy  # noqa: F401
        import PyFlyt.core  # noqa: F401
    except Exception as exc:
        _emit(out, {"error": f"PyFlyt import failed: {type(exc).__name__}: {exc}"})
        return 3
    try:
        record = run(args.vehicles, args.sim_seconds, args.physics_hz, args.control_hz, args.seed)
    except Exception as exc:
        _emit(out, {"error": f"PyFlyt run failed: {type(exc).__name__}: {exc}"})
        return 4
    _emit(out, record)
    return 0


if __name__ == "__main__":
    sys.exit(main())
