"""A Dask scheduler and workers as separate processes, as a user starts them (test helper).

``dask_cluster`` starts ``dask scheduler`` on an OS-picked port and N ``dask worker`` processes
(each in its own session), yields the scheduler's address, and always stops the processes it
started, by their ids.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

STARTUP_TIMEOUT_S = 60.0
"""Wall seconds the scheduler and the workers get to come up (imports on a loaded machine)."""

SRC = Path(__file__).resolve().parents[3] / "src"
HERE = Path(__file__).resolve().parent


def _stop(procs: list[subprocess.Popen]) -> None:
    for p in procs:
        if p.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(p.pid, signal.SIGTERM)
    deadline = time.monotonic() + 10
    for p in procs:
        try:
            p.wait(max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(p.pid, signal.SIGKILL)
            p.wait()


@contextlib.contextmanager
def dask_cluster(
    tmp_path: Path, workers: int = 2, nanny: bool = True, env: dict[str, str] | None = None
) -> Iterator[tuple[str, list[subprocess.Popen]]]:
    """(scheduler address, worker processes) of a freshly started scheduler + ``workers``."""
    from distributed import Client

    env = os.environ | {"PYTHONPATH": os.pathsep.join([str(SRC), str(HERE)])} | (env or {})
    scheduler_file = tmp_path / "scheduler.json"
    procs: list[subprocess.Popen] = []

    def start(argv: list[str], log: str) -> subprocess.Popen:
        with (tmp_path / log).open("w") as out:
            p = subprocess.Popen(
                [sys.executable, "-m", *argv], stdout=out, stderr=subprocess.STDOUT, env=env,
                start_new_session=True,
            )  # fmt: skip
        procs.append(p)
        return p

    try:
        scheduler_argv = ["distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0"]
        scheduler_argv += ["--no-dashboard", "--scheduler-file", str(scheduler_file)]
        start(scheduler_argv, "scheduler.log")
        deadline = time.monotonic() + STARTUP_TIMEOUT_S
        while not scheduler_file.exists() or not scheduler_file.read_text().strip():
            if time.monotonic() > deadline or procs[0].poll() is not None:
                raise RuntimeError((tmp_path / "scheduler.log").read_text())
            time.sleep(0.1)
        address = json.loads(scheduler_file.read_text())["address"]
        worker_argv = ["distributed.cli.dask_worker", address, "--nthreads", "1"]
        worker_argv += ["--no-dashboard", "--nanny" if nanny else "--no-nanny"]
        worker_procs = [
            start([*worker_argv, "--name", f"w{k}"], f"worker{k}.log") for k in range(workers)
        ]
        with Client(address, timeout="30s") as client:
            client.wait_for_workers(workers, timeout=STARTUP_TIMEOUT_S)
        yield address, worker_procs
    finally:
        _stop(procs)
