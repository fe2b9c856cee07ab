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

Before any test runs, the main process flies one simulated second in a subprocess so that the
compiled kernels (numba) are in their cache: the workers, and every ``swarmsitl up`` or scenario
subprocess a test starts, then load them instead of compiling them (tens of seconds on a cold
machine, which would eat into an end-to-end test's wall-clock timeouts).
"""

from __future__ import annotations

import subprocess
import sys

import pytest

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


WARM_KERNELS = (
    "from harness.simulation import Simulation, SimulationConfig\n"
    "with Simulation(SimulationConfig(mavlink=False, record_hz=0.0, mocap_port=0)) as sim:\n"
    "    sim.run_lockstep(1.0)\n"
)
"""One simulated second of one vehicle: calls every kernel of the flight loop once."""


def pytest_sessionstart(session: pytest.Session) -> None:
    """Fill the kernel cache once, in the main process, before xdist starts the workers."""
    if hasattr(session.config, "workerinput"):  # an xdist worker: the main process did it
        return
    try:
        subprocess.run(
            [sys.executable, "-c", WARM_KERNELS], capture_output=True, timeout=900, check=True
        )
    except (subprocess.CalledProcessError, subprocess.TimeoutExpired) as exc:
        # Not fatal: the tests compile what they need themselves (and will show the error).
        print(f"warming the kernel cache failed: {exc}", file=sys.stderr)
