"""``swarmsitl sweep``: the end-of-sweep counts and the exit status (issue 25)."""

from pathlib import Path

import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from harness.cli import app
from harness.commands.sweep import (
    EXIT_BAD_INPUT,
    EXIT_CHECKS_FAILED,
    EXIT_ERRORED,
    EXIT_OK,
    exit_status,
)
from harness.sweep.runner import SweepOutcome
from harness.sweep.table import RESULTS_FILE

pytestmark = pytest.mark.heavy

CHECKED_SCENARIO = """\
# Two survey vehicles at most, 30 simulated s; the check allows one vehicle only.
name: tiny-checked
fidelity: swarm
seed: 0
duration_s: 30
fleet:
  - role: survey
    count: 1
roles:
  survey:
    module: companion.scripts.coverage
    args: {altitude_m: 15, speed_m_s: 8}
checks:
  companions_succeeded: false   # 30 s is too short for the survey to finish
  metrics:
    fleet.vehicles: [null, 1]
"""


def checked_sweep(tmp_path: Path) -> Path:
    """A sweep of the checked scenario over fleets of 1 (passes) and 2 (fails its check)."""
    (tmp_path / "scenario.yaml").write_text(CHECKED_SCENARIO)
    path = tmp_path / "sweep.yaml"
    path.write_text("scenario: scenario.yaml\ngrid:\n  fleet.0.count: [1, 2]\n")
    return path


def flat(text: str) -> str:
    return " ".join(text.split())


def test_a_sweep_whose_checks_failed_counts_them_and_exits_non_zero(tmp_path):
    """Issue 25: it printed "ok" and exited 0 although a trial's checks failed."""
    out = tmp_path / "out"
    args = ["sweep", str(checked_sweep(tmp_path)), "--workers", "1", "--out", str(out)]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == EXIT_CHECKS_FAILED == 3, result.output
    output = flat(result.output)
    assert "results: 1 passed, 1 failed checks, 0 errored, 0 not run (of 2 trials)" in output
    assert '{"fleet.0.count": 2} seed 0 failed checks: metric fleet.vehicles' in output
    assert "1 trial(s) failed their checks" in output
    rows = {r["fleet.0.count"]: r for r in pq.read_table(out / RESULTS_FILE).to_pylist()}
    assert rows[1]["status"] == rows[2]["status"] == "ok"
    assert (rows[1]["passed"], rows[2]["passed"]) == (True, False)
    assert (rows[1]["failed_checks"], rows[2]["failed_checks"]) == ("", "metric fleet.vehicles")
    # run again: nothing reruns (no cluster starts), and the failure is still the exit status
    again = CliRunner().invoke(app, args)
    assert again.exit_code == EXIT_CHECKS_FAILED, again.output
    assert "0 finished, 0 errored, 2 skipped" in flat(again.output)
    assert "results: 1 passed, 1 failed checks" in flat(again.output)


def test_a_sweep_whose_trials_all_passed_exits_zero(tmp_path):
    sweep = checked_sweep(tmp_path)
    sweep.write_text("scenario: scenario.yaml\ngrid:\n  fleet.0.count: [1]\n")
    result = CliRunner().invoke(
        app, ["sweep", str(sweep), "--workers", "1", "--out", str(tmp_path / "out")]
    )
    assert result.exit_code == EXIT_OK, result.output
    assert "results: 1 passed, 0 failed checks, 0 errored, 0 not run" in flat(result.output)


def test_errored_trials_decide_the_exit_status_before_failed_checks():
    assert exit_status(SweepOutcome(passed=3)) == EXIT_OK == 0
    assert exit_status(SweepOutcome(passed=3, missing=5)) == EXIT_OK  # --max-trials
    assert exit_status(SweepOutcome(passed=1, checks_failed=2)) == EXIT_CHECKS_FAILED
    assert exit_status(SweepOutcome(checks_failed=2, errored=1)) == EXIT_ERRORED == 1
    assert len({EXIT_OK, EXIT_ERRORED, EXIT_BAD_INPUT, EXIT_CHECKS_FAILED}) == 4


def test_the_help_names_the_exit_statuses_and_an_example_that_exists():
    result = CliRunner().invoke(app, ["sweep", "--help"], terminal_width=200)
    assert result.exit_code == 0
    text = flat(result.output)
    assert "3 when no trial errored but one failed its checks" in text
    assert "1 when a trial errored" in text
    examples = [line.split()[3] for line in result.output.splitlines() if "Example:" in line]
    assert examples
    root = Path(__file__).parents[2]
    assert all((root / path).is_file() for path in examples), examples
