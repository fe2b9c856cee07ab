"""Scheduling of the suite on parallel workers: ``pytest -n 2 --dist loadgroup`` (``.ci/run``).

With ``--dist loadgroup`` this conftest's scheduler sends each test module whole to one worker
(its module-scoped fixtures are built once; the fixed ports a module uses are used by one
process at a time), and every module of ``tests/e2e`` and ``tests/conformance`` (paced
``swarmsitl up`` runs, real MAVSDK clients with wall-clock timeouts) to one and the same worker,
one module after another as in a serial run: two paced runs never compete for the CPU. The other
worker runs the lockstep tests, whose outcome does not depend on the load. Without ``-n`` (or
with another ``--dist``) nothing changes.

pytest-xdist's own ``xdist_group`` markers are not used: with pytest 9 the group suffix it
writes into the node id is lost, and the groups are silently ignored.

Before any test runs, the main process fills the cache of the compiled kernels (numba) in a
subprocess, ``python -m harness.kernels`` (``harness.kernels.compile_all``: every kernel in
``src/``, with every signature the stack calls it with): the workers, and every ``swarmsitl up``
or scenario subprocess a test starts, then load them instead of compiling them (tens of seconds
on a cold machine, which would eat into an end-to-end test's wall-clock timeouts).

The process tier (``tests/e2e``, ``tests/conformance``) then forbids compiling: around each of
its tests ``SWARMSITL_FORBID_JIT_COMPILE=1`` is set (every ``swarmsitl`` process started from
then on raises on a kernel compile, and appends the kernel to ``SWARMSITL_JIT_COMPILE_LOG``) and
the same guard runs in the test's own process. A compile during the test, in any of them, fails
it at teardown with the kernel's name, instead of a timeout somewhere else. Loading from the
warm cache is not a compile (numba's ``numba:compile`` event fires on cache misses only).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from collections.abc import Generator
from pathlib import Path

import pytest

from harness.kernels import (
    COMPILE_LOG_ENV,
    FORBID_COMPILE_ENV,
    CompileGuard,
    allow_compiles,
    forbid_compiles,
)

pytest_plugins = ["pytester"]
"""pytester runs a user's test file in a subprocess (the swarmsitl pytest plugin's own tests)."""

PACED_DIRS = ("tests/e2e/", "tests/conformance/")
"""Node-id prefixes (relative to the repository root) of the modules in the paced group."""
PACED_GROUP = "paced"


def scope_of(nodeid: str) -> str:
    """The work unit of a test: the paced group, or its module."""
    module = nodeid.split("::", 1)[0]
    return PACED_GROUP if module.startswith(PACED_DIRS) else module


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log: object) -> object | None:
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class ModuleAndPacedScheduling(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return scope_of(nodeid)

    return ModuleAndPacedScheduling(config, log)


WARM_KERNELS = [sys.executable, "-m", "harness.kernels"]
"""Loads (or compiles and caches) every kernel of the stack: ``harness.kernels.compile_all``."""


def pytest_sessionstart(session: pytest.Session) -> None:
    """Fill the kernel cache once, in the main process, before xdist starts the workers."""
    if hasattr(session.config, "workerinput"):  # an xdist worker: the main process did it
        return
    env = {k: v for k, v in os.environ.items() if k != FORBID_COMPILE_ENV}
    try:
        subprocess.run(WARM_KERNELS, capture_output=True, timeout=900, check=True, env=env)
    except (subprocess.CalledProcessError, subprocess.TimeoutExpired) as exc:
        # Not fatal here: the process tier's tests will fail naming the kernels they compiled.
        stderr = exc.stderr.decode(errors="replace") if isinstance(exc.stderr, bytes) else ""
        print(f"warming the kernel cache failed: {exc}\n{stderr}", file=sys.stderr)


def is_paced(item: pytest.Item) -> bool:
    """Whether a test belongs to the process tier (tests/e2e, tests/conformance)."""
    return scope_of(item.nodeid) == PACED_GROUP


COMPILE_LOG = Path(tempfile.gettempdir()) / f"swarmsitl-jit-compiles-{os.getpid()}.log"
"""This test process's log of forbidden compiles (its own and its subprocesses')."""
_LOG_START = pytest.StashKey[int]()
_guard: CompileGuard | None = None
"""The in-process compile guard of the running process-tier test."""


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item: pytest.Item) -> None:
    """Forbid kernel compiles for a process-tier test: in the processes it starts, and here.

    Set before the test's fixtures run (module-scoped ones start ``swarmsitl up`` processes,
    which keep the setting for their lifetime) and kept until its teardown ends.
    """
    global _guard
    if not is_paced(item):
        return
    COMPILE_LOG.touch()
    item.stash[_LOG_START] = COMPILE_LOG.stat().st_size
    os.environ[FORBID_COMPILE_ENV] = "1"
    os.environ[COMPILE_LOG_ENV] = str(COMPILE_LOG)
    if _guard is None:
        _guard = forbid_compiles(COMPILE_LOG)


@pytest.hookimpl(wrapper=True)
def pytest_runtest_teardown(item: pytest.Item, nextitem: pytest.Item | None) -> Generator:
    """Fail a process-tier test in whose processes a kernel compiled (names the kernels)."""
    global _guard
    result = yield
    if _LOG_START not in item.stash:
        return result
    if _guard is not None:
        allow_compiles(_guard)
        _guard = None
    os.environ.pop(FORBID_COMPILE_ENV, None)
    os.environ.pop(COMPILE_LOG_ENV, None)
    with COMPILE_LOG.open() as log:
        log.seek(item.stash[_LOG_START])
        compiles = log.read().splitlines()
    if compiles:
        pytest.fail(
            "numba compiled a kernel during this test; the cache filled at the session's start "
            "(harness.kernels.compile_all) should have held it: " + "; ".join(compiles),
            pytrace=False,
        )
    return result


def pytest_sessionfinish(session: pytest.Session) -> None:
    """Remove this process's compile log (its entries failed their tests already)."""
    COMPILE_LOG.unlink(missing_ok=True)
