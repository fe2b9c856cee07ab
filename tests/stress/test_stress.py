"""The stress proof of the lockstep process tier: CPU load and random pauses of companions.

Opt-in (``python -m pytest -m stress``; docs/testing.md): runs the end-to-end modules (all of
tests/e2e and tests/conformance, the scenario-run modules of tests/harness) in a child pytest on
two workers, module beside module, while two busy processes load both cores and, every 3 to 6
wall seconds, one companion process, e2e client or ``mavsdk_server`` of the child's runs is
stopped (SIGSTOP) for 1 to 2 wall seconds. The lockstep (``harness.run.lockstep``) must turn every
pause into wall time, never into simulated time: the child's tests, whose waits and checks are
in simulated time, must pass.
Repeat it (``for i in 1 2 3 4 5; do python -m pytest -m stress; done``) for a pass rate.

Left out (:data:`PACED_BY_DESIGN`): the few tests of the paced mode itself (``--speed X``), in
which a paused client misses simulated time by design.
"""

from __future__ import annotations

import contextlib
import os
import random
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from harness.run.lockstep import process_state, process_table

pytestmark = pytest.mark.stress

ROOT = Path(__file__).resolve().parents[2]
LOCKSTEP_TIER = (
    "tests/harness/test_scenario_run_e2e.py",
    "tests/harness/test_companions_doc_e2e.py",
    "tests/harness/test_indoor_scenario_e2e.py",
    "tests/harness/test_swarm_fidelity_e2e.py",
    "tests/e2e",
    "tests/conformance",
)
"""Modules whose runs are in lockstep with their companions (test_lockstep_e2e stops its own
companion on purpose and is left out: a pause here would end its stop early)."""
PACED_BY_DESIGN = (
    "tests/e2e/test_e2e_external_autopilot.py::"
    "test_classic_mavsdk_takes_off_with_an_external_autopilot[paced]",
    "tests/e2e/test_e2e_first_flight.py",  # `swarmsitl first-flight --speed`: the paced demo
    "tests/e2e/test_e2e_net.py::test_net_demo_flies_messages_and_reports_links_and_energy",
)
"""Tests of the paced mode (``--speed X``): deselected in the child."""
CHILD_WORKERS = 2
"""xdist workers of the child, each taking whole modules (``--dist loadscope``: unlike the
default suite's scheduler, end-to-end modules run beside each other and beside the heavy ones,
which is more load, and the lockstep must hold under it)."""
PAUSE_WALL_S = (1.0, 2.0)
"""Length of one pause, wall s (uniform)."""
BETWEEN_WALL_S = (3.0, 6.0)
"""Time between two pauses, wall s (uniform)."""
LOAD_PROCESSES = 2
"""Busy processes beside the tests (one per core of a CI machine)."""
WATCHDOG_WALL_S = 3600.0


def descendants(root: int) -> list[int]:
    """Every process below ``root`` (from /proc's parent links)."""
    children: dict[int, list[int]] = {}
    for pid, ppid, _ in process_table():
        children.setdefault(ppid, []).append(pid)
    out, todo = [], [root]
    while todo:
        for child in children.get(todo.pop(), []):
            out.append(child)
            todo.append(child)
    return out


def is_companion(pid: int) -> bool:
    """A companion program, an e2e client or their mavsdk_server: a process given the run's
    MAVLink URL or clock file (``swarmsitl`` itself, MAVProxy and the tests are not)."""
    try:
        with open(f"/proc/{pid}/environ", "rb") as f:
            environ = f.read()
    except OSError:
        return False
    return b"SWARMSITL_MAVLINK_URL=" in environ or b"SWARMSITL_CLOCK_FILE=" in environ


class Pauser(threading.Thread):
    """Stops a random companion process of ``root``'s tree now and then, for a short while."""

    def __init__(self, root: int, rng: random.Random) -> None:
        super().__init__(name="stress-pauser", daemon=True)
        self.root, self.rng = root, rng
        self.done = threading.Event()
        self.pauses: list[tuple[int, float]] = []

    def run(self) -> None:
        while not self.done.wait(self.rng.uniform(*BETWEEN_WALL_S)):
            targets = [
                p
                for p in descendants(self.root)
                if is_companion(p) and process_state(p) not in ("T", "t", "Z", None)
            ]
            if not targets:
                continue
            pid, pause = self.rng.choice(targets), self.rng.uniform(*PAUSE_WALL_S)
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGSTOP)
                try:
                    self.done.wait(pause)
                finally:
                    os.kill(pid, signal.SIGCONT)
                self.pauses.append((pid, pause))


@pytest.mark.timeout(WATCHDOG_WALL_S + 60)
def test_the_lockstep_tier_passes_under_load_and_pauses(tmp_path):
    load = [
        subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(LOAD_PROCESSES)
    ]
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST_")}
    log = tmp_path / "child.log"
    try:
        with log.open("w") as out:
            child = subprocess.Popen(
                [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-q",
                 "-n", str(CHILD_WORKERS), "--dist", "loadscope", *LOCKSTEP_TIER,
                 *(f"--deselect={t}" for t in PACED_BY_DESIGN)],
                cwd=ROOT, stdout=out, stderr=subprocess.STDOUT, env=env,
            )  # fmt: skip
            pauser = Pauser(child.pid, random.Random())
            pauser.start()
            try:
                code = child.wait(WATCHDOG_WALL_S)
            finally:
                pauser.done.set()
                pauser.join()
                if child.poll() is None:
                    child.kill()
    finally:
        for p in load:
            p.kill()
            p.wait()
    output = log.read_text()
    print(f"{len(pauser.pauses)} pauses: {pauser.pauses}")
    print(output[-3000:])
    assert pauser.pauses, "no companion was paused: the stress did not happen"
    assert code == 0, output[-6000:]
