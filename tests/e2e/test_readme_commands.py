"""The README's commands as a new user types them, from the root of a clean copy of the project.

The copy is a ``git clone`` of this checkout (what a user gets), so files the checkout holds
but git does not (runs/, caches) cannot help. Its ``.venv`` is the environment running these
tests, linked in: the README's set-up part (``python3 -m venv .venv && .venv/bin/pip install
-e ".[test]"``) is what ``.ci/run`` itself ran before the suite started, so what is left to run
is each command's part after it, verbatim. The demo uses its default ports and output directory
(``runs/<timestamp>`` under the copy), so this module is in the serial group of tests/e2e.

Replaces the earlier demo test that passed ``--out`` and ports: those options hid that the
runner handed companions paths relative to the caller's directory (issue 25).
"""

from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from harness.report.flight_log import FlightLog

pytestmark = pytest.mark.e2e

ROOT = Path(__file__).resolve().parents[2]
SETUP = 'python3 -m venv .venv && .venv/bin/pip install -e ".[test]" && '
"""The set-up part both README commands start with."""
WATCHDOG_WALL_S = 1200.0
"""A hung command fails the test after this long (the demo takes about two minutes)."""


def readme_commands() -> tuple[str, str]:
    """The README's first two ``bash`` blocks: the demo command and the test command."""
    blocks = re.findall(r"```bash\n(.*?)```", (ROOT / "README.md").read_text(), re.S)
    assert len(blocks) >= 2, "the README starts with two bash blocks"
    demo, tests = (b.strip() for b in blocks[:2])
    return demo, tests


def runnable_part(command: str) -> str:
    """What a README command runs after its set-up part."""
    assert command.startswith(SETUP), command
    return command.removeprefix(SETUP)


def user_env() -> dict[str, str]:
    """The environment of a user's shell: none of this pytest run's own variables."""
    return {k: v for k, v in os.environ.items() if not k.startswith(("PYTEST_", "COLUMNS"))}


@pytest.fixture(scope="module")
def clean_copy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A clone of this checkout with the running environment as its ``.venv``."""
    if sys.prefix == sys.base_prefix:
        pytest.skip("the suite does not run in a virtual environment (the README's .venv)")
    copy = tmp_path_factory.mktemp("clean") / "swarmsitl"
    if (ROOT / ".git").exists():
        subprocess.run(["git", "clone", "-q", str(ROOT), str(copy)], check=True, timeout=120)
    else:  # an exported tree: copy it as it is, without outputs
        shutil.copytree(ROOT, copy, ignore=shutil.ignore_patterns(".venv", "runs", ".*cache*"))
    (copy / ".venv").symlink_to(Path(sys.prefix), target_is_directory=True)
    return copy


def run_shell(command: str, cwd: Path, **env: str) -> subprocess.CompletedProcess[str]:
    """``command`` in bash, in ``cwd``, as a user would run it (output kept for the message)."""
    return subprocess.run(
        ["bash", "-c", command],
        cwd=cwd,
        capture_output=True,
        text=True,
        env=user_env() | env,
        timeout=WATCHDOG_WALL_S,
        check=False,
    )


def test_the_readme_test_command_is_what_ci_runs():
    """``.ci/run`` runs the README's test command (pip's ``-q`` aside) and nothing else."""
    _, tests = readme_commands()
    ci = (ROOT / ".ci" / "run").read_text()
    assert tests.replace("pip install -e", "pip install -q -e") in ci


@pytest.mark.timeout(WATCHDOG_WALL_S + 60)
def test_the_readme_demo_command_flies_and_passes_from_a_clean_copy(clean_copy):
    """The demo's report passes, lies under the copy's runs/, and its flight makes sense."""
    demo, _ = readme_commands()
    proc = run_shell(runnable_part(demo), clean_copy)
    output = proc.stdout + proc.stderr
    assert proc.returncode == 0, output
    reports = list((clean_copy / "runs").glob("*/report.json"))
    assert len(reports) == 1, output
    out = reports[0].parent
    report = json.loads(reports[0].read_text())
    assert report["passed"] and report["complete"], output
    assert report["scenario"] == "offshore-demo" and len(report["vehicles"]) == 3
    assert [c["exit_code"] for c in report["companions"].values()] == [0, 0, 0], output
    fleet = report["fleet"]["companions"]
    # the distinct spills the cameras could have seen (the world's, under the recorded
    # footprints once present) and the ones the detector found: most of them, and only those
    could = set(fleet["spills_in_footprint_names"]["items"])
    seen = set(fleet["spills_seen_names"]["items"])
    assert len(could) >= 3, fleet
    assert len(seen & could) >= 0.6 * len(could), fleet
    assert len(seen - could) <= 1, fleet  # a frame and its pose are paired within ~1 m
    assert (out / "plots" / "map.png").is_file()
    assert len(list((out / "camera").glob("vehicle*_t*.png"))) >= 3
    log = FlightLog.load(out)
    for i in range(3):
        up = log.vehicle(i).track["up_m"]
        assert up[0] > 25.0 and up[-1] > 25.0  # started and ended on the rig's 30 m deck
    # nothing was written beside the scenario, in the package's folder
    assert not list((clean_copy / "src" / "harness" / "scenarios").glob("**/result.json"))


def test_the_readme_test_command_collects_the_suite_from_a_clean_copy(clean_copy):
    """The test command runs from the copy's root; collecting only (running the suite inside
    itself would take its whole time again), so configuration, plugins and imports are real."""
    _, tests = readme_commands()
    proc = run_shell(runnable_part(tests), clean_copy, PYTEST_ADDOPTS="--collect-only -q")
    output = proc.stdout + proc.stderr
    assert proc.returncode == 0, output
    counts = re.findall(r"(\d+) tests? collected", output)
    assert counts and int(counts[-1]) > 1000, output[-3000:]


def test_a_readme_run_example_works_from_another_directory_with_a_relative_out(
    clean_copy, tmp_path, swarmsitl_ports
):
    """``swarmsitl run src/harness/scenarios/city.yaml --out runs/city`` from elsewhere: the
    scenario path and ``--out`` relative to that directory (free ports added)."""
    example = "swarmsitl run src/harness/scenarios/city.yaml --out runs/city"
    assert example in (ROOT / "README.md").read_text()
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    to_copy = os.path.relpath(clean_copy, elsewhere)
    ports = swarmsitl_ports
    command = (
        f"{to_copy}/.venv/bin/swarmsitl run {to_copy}/src/harness/scenarios/city.yaml "
        f"--out runs/city --sdk-port {ports.sdk} --listen-port {ports.listen} "
        f"--grpc-port {ports.grpc} --payload-port {ports.payload}"
    )
    proc = run_shell(command, elsewhere)
    output = proc.stdout + proc.stderr
    assert proc.returncode == 0, f"{shlex.quote(command)}\n{output}"
    report = json.loads((elsewhere / "runs" / "city" / "report.json").read_text())
    assert report["passed"] and report["complete"], output
    for name, companion in report["companions"].items():
        assert companion["exit_code"] == 0, name
        assert (elsewhere / "runs" / "city" / name / "result.json").is_file(), name
