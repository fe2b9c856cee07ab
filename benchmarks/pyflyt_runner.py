"""Run the PyFlyt peer benchmark in its own venv (PyFlyt pins numpy < 2) and return its JSON.

Importable from the main venv::

    from pyflyt_runner import PeerUnavailable, run_pyflyt

or run directly: ``python benchmarks/pyflyt_runner.py --vehicles 10 --sim-seconds 30``.
"""

from __future__ import annotations

import argparse
import fcntl
import json
import math
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import IO, Any

BENCH_DIR = Path(__file__).resolve().parent
PEER_SCRIPT = BENCH_DIR / "pyflyt_peer.py"
DEFAULT_VENV_DIR = BENCH_DIR / ".venvs" / "pyflyt"

# The one place the peer's environment is pinned: a set verified to install and fly together
# on CPython 3.11 (PyFlyt 0.29.0 itself requires numpy < 2).
PYFLYT_REQUIREMENTS: tuple[str, ...] = (
    "pyflyt==0.29.0",
    "numpy==1.26.4",
    "pybullet==3.2.7",
    "numba==0.68.1",
    "llvmlite==0.50.0",
    "scipy==1.17.1",
)

# Physics rate handed to the peer: nearest to our simulator's 500 Hz that PyFlyt accepts
# (any int works; control runs at 125 Hz, the divisor of 500 nearest PyFlyt's default 120).
DEFAULT_PHYSICS_HZ = 500

PIP_LOG = "pip.log"
PEER_LOG = "peer-last.log"
STAMP = "requirements.installed"
REQUIRED_KEYS = frozenset(
    {"vehicles", "sim_seconds", "wall_seconds", "rtf", "physics_hz", "control_hz"}
)


class PeerUnavailable(RuntimeError):
    """The PyFlyt peer could not produce a number; ``str(exc)`` is a one-line reason."""


def _one_line(text: str, limit: int = 300) -> str:
    line = " ".join(text.split())
    return line if len(line) <= limit else line[: limit - 3] + "..."


def _venv_python(venv_dir: Path) -> Path:
    return venv_dir / "bin" / "python"


def _base_python() -> str:
    """Interpreter used to create the venv: python3.11, else python3, else this one."""
    return shutil.which("python3.11") or shutil.which("python3") or sys.executable


def _remaining(deadline: float, what: str) -> float:
    left = deadline - time.monotonic()
    if left <= 0:
        raise PeerUnavailable(f"timed out before {what}")
    return left


def _run_logged(cmd: list[str], log: Path, timeout: float, what: str) -> None:
    """Run ``cmd`` appending its output to ``log``; raise PeerUnavailable on failure."""
    with log.open("a", encoding="utf-8") as fh:
        fh.write(f"\n$ {' '.join(cmd)}\n")
        fh.flush()
        start = fh.tell()
        try:
            proc = subprocess.run(
                cmd,
                stdout=fh,
                stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL,
                timeout=timeout,
                check=False,
            )
        except subprocess.TimeoutExpired:
            raise PeerUnavailable(f"{what} timed out after {timeout:.0f} s; see {log}") from None
        except OSError as exc:
            raise PeerUnavailable(f"{what} could not start: {exc}") from None
    if proc.returncode != 0:
        with log.open(encoding="utf-8", errors="replace") as fh:
            fh.seek(start)
            lines = [ln.strip() for ln in fh if ln.strip()]
        errors = [ln for ln in lines if ln.startswith("ERROR")]
        hint = _one_line((errors or lines or ["no output"])[-1], 200)
        raise PeerUnavailable(f"{what} failed (exit {proc.returncode}): {hint} (log: {log})")


def _lock(fh: IO[str], deadline: float) -> None:
    """Take an exclusive flock on ``fh``, giving up at ``deadline``."""
    while True:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return
        except BlockingIOError:
            _remaining(deadline, "another process finished building the PyFlyt venv")
            time.sleep(0.5)


def ensure_venv(venv_dir: Path = DEFAULT_VENV_DIR, timeout_s: float = 900) -> Path:
    """Create/refresh the PyFlyt venv if missing or pinned differently; return its python."""
    deadline = time.monotonic() + timeout_s
    venv_dir = Path(venv_dir)
    venv_dir.parent.mkdir(parents=True, exist_ok=True)
    wanted = "\n".join(PYFLYT_REQUIREMENTS) + "\n"
    py = _venv_python(venv_dir)
    stamp = venv_dir / STAMP
    lock_path = venv_dir.parent / f".{venv_dir.name}.lock"
    with lock_path.open("w") as lock:
        _lock(lock, deadline)  # two benchmarks must not build the same venv at once
        if py.exists() and stamp.exists() and stamp.read_text(encoding="utf-8") == wanted:
            return py
        log = venv_dir / PIP_LOG
        if not py.exists():
            venv_dir.mkdir(parents=True, exist_ok=True)
            _run_logged(
                [_base_python(), "-m", "venv", str(venv_dir)],
                log,
                _remaining(deadline, "creating the venv"),
                "python -m venv",
            )
        if not py.exists():
            raise PeerUnavailable(f"venv creation left no interpreter at {py}")
        stamp.unlink(missing_ok=True)
        try:
            probe = subprocess.run(
                [str(py), "-m", "pip", "--version"],
                capture_output=True,
                text=True,
                stdin=subprocess.DEVNULL,
                timeout=_remaining(deadline, "probing pip"),
                check=False,
            )
        except subprocess.TimeoutExpired:
            raise PeerUnavailable(f"pip probe in {venv_dir} timed out") from None
        if probe.returncode != 0:
            raise PeerUnavailable(
                f"pip unavailable in {venv_dir}: {_one_line(probe.stderr or probe.stdout)}"
            )
        _run_logged(
            [
                str(py),
                "-m",
                "pip",
                "install",
                "--disable-pip-version-check",
                "--no-input",
                *PYFLYT_REQUIREMENTS,
            ],
            log,
            _remaining(deadline, "pip install"),
            "pip install pyflyt",
        )
        stamp.write_text(wanted, encoding="utf-8")
    return py


def _parse_peer_output(stdout: str) -> dict[str, Any]:
    """Return the last JSON object printed by the peer."""
    for line in reversed(stdout.splitlines()):
        line = line.strip()
        if not line.startswith("{"):
            continue
        try:
            data = json.loads(line)
        except json.JSONDecodeError as exc:
            raise PeerUnavailable(f"peer printed bad JSON: {exc}") from None
        if not isinstance(data, dict):
            break
        return data
    raise PeerUnavailable("peer printed no JSON line")


def run_pyflyt(
    vehicles: int,
    sim_seconds: float,
    venv_dir: Path = DEFAULT_VENV_DIR,
    timeout_s: float = 900,
    *,
    physics_hz: int = DEFAULT_PHYSICS_HZ,
    seed: int = 0,
) -> dict[str, Any]:
    """Run PyFlyt with ``vehicles`` QuadX drones for ``sim_seconds``; return the peer's record.

    ``timeout_s`` bounds the whole call, including a first-time venv build. Any failure
    raises :class:`PeerUnavailable` with a one-line reason.
    """
    deadline = time.monotonic() + timeout_s
    venv_dir = Path(venv_dir)
    py = ensure_venv(venv_dir, timeout_s)
    cmd = [
        str(py),
        str(PEER_SCRIPT),
        "--vehicles",
        str(vehicles),
        "--sim-seconds",
        str(sim_seconds),
        "--physics-hz",
        str(physics_hz),
        "--seed",
        str(seed),
    ]
    env = {k: v for k, v in os.environ.items() if k not in {"PYTHONPATH", "PYTHONHOME"}}
    timeout = _remaining(deadline, "running the peer")
    try:
        proc = subprocess.run(
            cmd,
            capture_output=True,
            text=True,
            stdin=subprocess.DEVNULL,
            env=env,
            timeout=timeout,
            check=False,
        )
    except subprocess.TimeoutExpired:
        raise PeerUnavailable(f"PyFlyt peer timed out after {timeout:.0f} s") from None
    except OSError as exc:
        raise PeerUnavailable(f"PyFlyt peer could not start: {exc}") from None
    (venv_dir / PEER_LOG).write_text(
        f"$ {' '.join(cmd)}\nexit {proc.returncode}\n--- stdout\n{proc.stdout}"
        f"--- stderr\n{proc.stderr}",
        encoding="utf-8",
    )
    try:
        data = _parse_peer_output(proc.stdout)
    except PeerUnavailable:
        if proc.returncode != 0:
            tail = proc.stderr.strip().splitlines()[-1:] or ["no stderr"]
            raise PeerUnavailable(
                f"PyFlyt peer exited {proc.returncode}: {_one_line(tail[0])}"
            ) from None
        raise
    if "error" in data:
        raise PeerUnavailable(_one_line(str(data["error"])))
    missing = REQUIRED_KEYS - data.keys()
    if missing:
        raise PeerUnavailable(f"peer JSON lacks {', '.join(sorted(missing))}")
    if not (isinstance(data["rtf"], int | float) and math.isfinite(data["rtf"])):
        raise PeerUnavailable(f"peer reported a non-finite rtf: {data['rtf']!r}")
    return data


def main(argv: list[str] | None = None) -> int:
    """CLI: print ``pyflyt_rtf_N=<rtf>`` and the peer's JSON, or ``nan`` and the reason."""
    ap = argparse.ArgumentParser(description="Run the PyFlyt peer benchmark in its own venv.")
    ap.add_argument("--vehicles", type=int, default=10)
    ap.add_argument("--sim-seconds", type=float, default=30.0)
    ap.add_argument("--physics-hz", type=int, default=DEFAULT_PHYSICS_HZ)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--venv-dir", type=Path, default=DEFAULT_VENV_DIR)
    ap.add_argument("--timeout", type=float, default=900.0)
    args = ap.parse_args(argv)
    key = f"pyflyt_rtf_{args.vehicles}"
    try:
        data = run_pyflyt(
            args.vehicles,
            args.sim_seconds,
            args.venv_dir,
            args.timeout,
            physics_hz=args.physics_hz,
            seed=args.seed,
        )
    except PeerUnavailable as exc:
        print(f"{key}=nan")
        print(f"pyflyt unavailable: {exc}")
        return 1
    print(f"{key}={data['rtf']:.3f}")
    print(json.dumps(data))
    return 0


if __name__ == "__main__":
    sys.exit(main())
