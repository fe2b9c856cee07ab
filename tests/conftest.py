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
"""

from __future__ import annotations

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
