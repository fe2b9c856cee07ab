"""Trial bodies for the sweep tests (``run_trial``'s ``execute`` hook), run on Dask workers.

They stand in for the scenario run so that the scheduling, table, resume and retry machinery is
tested with trials whose outcome the test controls: a seeded synthetic coverage report, a trial
that raises for one grid value, a trial whose worker dies the first time it runs it.
"""

from __future__ import annotations

import math
import os
import signal
import time
from pathlib import Path

import numpy as np

KILL_MARKER_ENV = "SWEEP_TEST_KILL_MARKER"
"""A file path: the first trial to run creates it and kills its own worker process."""


def synthetic_report(scenario, seed, run_dir, timeout_wall_s):
    """A report whose numbers depend only on the scenario's parameters and the seed."""
    spec = scenario.spec
    n = spec.n_vehicles
    speed = spec.roles["survey"].args["speed_m_s"]
    rng = np.random.default_rng(seed)
    noise = rng.normal(0.0, 0.02, size=n).mean()
    coverage = 1.0 - math.exp(-n * speed * spec.duration_s / 2000.0) + noise
    return {
        "passed": True,
        "complete": True,
        "sim_time_s": spec.duration_s,
        "wall_time_s": 0.01,
        "fleet": {
            "vehicles": {"value": n, "unit": "count"},
            "coverage_fraction": {"value": coverage, "unit": "1"},
            "events": {"value": int(rng.integers(0, 10)), "unit": "count"},
            "companions": {"detected": {"value": int(rng.integers(0, 5)), "unit": "count"}},
        },
    }


def failing_for_speed_12(scenario, seed, run_dir, timeout_wall_s):
    """Raises for the grid point whose survey speed is 12 m/s, else ``synthetic_report``."""
    if scenario.spec.roles["survey"].args["speed_m_s"] == 12:
        raise RuntimeError("trial body failed on purpose at 12 m/s")
    return synthetic_report(scenario, seed, run_dir, timeout_wall_s)


def dies_once(scenario, seed, run_dir, timeout_wall_s):
    """The first trial to run kills its worker process (SIGKILL); every later run reports."""
    marker = Path(os.environ[KILL_MARKER_ENV])
    try:
        fd = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
    except FileExistsError:
        return synthetic_report(scenario, seed, run_dir, timeout_wall_s)
    os.write(fd, str(os.getpid()).encode())
    os.close(fd)
    time.sleep(0.2)
    os.kill(os.getpid(), signal.SIGKILL)
    raise AssertionError("unreachable: the worker was killed")


def dies_for_two_vehicles(scenario, seed, run_dir, timeout_wall_s):
    """Kills its worker process every time it runs with a fleet of two; else reports."""
    if scenario.spec.n_vehicles == 2:
        os.kill(os.getpid(), signal.SIGKILL)
    return synthetic_report(scenario, seed, run_dir, timeout_wall_s)


def checks_fail_for_speed_12_errors_for_100(scenario, seed, run_dir, timeout_wall_s):
    """Fails a check at 12 m/s, raises with a fleet of 100, else ``synthetic_report``.

    The three outcomes of a trial: passed, ran but failed its checks, errored.
    """
    if scenario.spec.n_vehicles == 100:
        raise RuntimeError("trial body failed on purpose with 100 vehicles")
    report = synthetic_report(scenario, seed, run_dir, timeout_wall_s)
    bad = scenario.spec.roles["survey"].args["speed_m_s"] == 12
    report["checks"] = {
        "companions_succeeded": {"ok": True, "value": 0},
        "metric fleet.coverage_fraction": {"ok": not bad, "value": 0.1},
    }
    report["passed"] = not bad
    return report
