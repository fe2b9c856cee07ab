"""The sweep's worker settings, and the same settings as environment variables for own workers."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from harness.sweep.runner import TRIAL_WORKER_CONFIG, worker_environment

pytestmark = pytest.mark.process

READ_BACK = (
    "import dask, json\n"
    "keys = {keys!r}\n"
    "print(json.dumps({{k: dask.config.get(k) for k in keys}}))\n"
)


def test_the_environment_gives_a_worker_the_same_settings() -> None:
    env = worker_environment()
    assert all(name.startswith("DASK_DISTRIBUTED__") for name in env)
    code = READ_BACK.format(keys=list(TRIAL_WORKER_CONFIG))
    out = subprocess.run(
        [sys.executable, "-c", code],
        env=os.environ | env,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert json.loads(out.strip().splitlines()[-1]) == TRIAL_WORKER_CONFIG


def test_no_malloc_trim_threshold_and_no_profiler() -> None:
    environ = TRIAL_WORKER_CONFIG["distributed.nanny.pre-spawn-environ"]
    assert "MALLOC_TRIM_THRESHOLD_" not in environ
    assert environ["OMP_NUM_THREADS"] == 1
    assert TRIAL_WORKER_CONFIG["distributed.worker.profile.enabled"] is False
