"""The sweep file is checked completely, against its scenario, before anything is submitted."""

from pathlib import Path

import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from harness.cli import app
from harness.sweep import runner
from harness.sweep.spec import SweepError, grid_points, plan_sweep
from harness.sweep.table import value_type, write_row
from harness.sweep.trial import build_scenario, run_trial

DATA = Path(__file__).with_name("data")


def write_sweep(tmp_path, body):
    path = tmp_path / "sweep.yaml"
    path.write_text(f"scenario: {DATA / 'tiny.yaml'}\n" + body)
    return path


def test_a_good_sweep_lists_every_grid_point_times_every_seed(tmp_path):
    path = write_sweep(
        tmp_path,
        "grid:\n  fleet.0.count: [1, 10]\n  roles.survey.args.speed_m_s: [8, 12, 16]\nseeds: 2\n",
    )
    plan = plan_sweep(path)
    assert plan.name == "sweep"
    assert plan.fidelity == "swarm"
    assert len(plan.trials) == 2 * 3 * 2
    assert [t.parameters for t in plan.trials[:2]] == [
        {"fleet.0.count": 1, "roles.survey.args.speed_m_s": 8}
    ] * 2
    assert [t.seed for t in plan.trials[:4]] == [0, 1, 0, 1]
    assert len({t.trial_id for t in plan.trials}) == len(plan.trials)
    again = plan_sweep(path)
    assert [t.trial_id for t in again.trials] == [t.trial_id for t in plan.trials]
    assert plan.spec.x_parameter == "fleet.0.count"


def test_a_seed_list_and_the_x_axis_are_taken_as_given(tmp_path):
    path = write_sweep(
        tmp_path,
        "grid:\n  fleet.0.count: [1, 2]\n  duration_s: [10, 20]\nseeds: [5, 9]\nx: duration_s\n",
    )
    plan = plan_sweep(path)
    assert {t.seed for t in plan.trials} == {5, 9}
    assert plan.spec.x_parameter == "duration_s"


def test_the_trial_id_changes_with_the_scenario_text_the_parameters_and_the_seed(tmp_path):
    scenario = tmp_path / "s.yaml"
    scenario.write_text((DATA / "tiny.yaml").read_text())
    sweep = tmp_path / "sw.yaml"
    sweep.write_text("scenario: s.yaml\ngrid:\n  fleet.0.count: [1, 2]\nseeds: 2\n")
    first = [t.trial_id for t in plan_sweep(sweep).trials]
    text = (DATA / "tiny.yaml").read_text()
    scenario.write_text(text.replace("duration_s: 30", "duration_s: 31"))
    second = [t.trial_id for t in plan_sweep(sweep).trials]
    assert len(set(first)) == 4
    assert not set(first) & set(second)


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ("grid:\n  fleet.0.cout: [1, 2]\n", "grid: fleet.0.cout: fleet.0 has no 'cout'; did you"),
        ("grid: {}\n", "grid"),
        ("grid:\n  fleet.0.count: []\n", "fleet.0.count: an empty list of values"),
        ("grid:\n  fleet.0.count: [1, 0]\n", 'grid point {"fleet.0.count": 0} gives a bad'),
        ("grid:\n  fleet.0.count: [1]\nseeds: 0\n", "seeds: at least 1"),
        ("grid:\n  fleet.0.count: [1]\nx: duration_s\n", "x: 'duration_s' is not a grid"),
        ("grid:\n  fleet.0.count: [1]\ncolour: red\n", "colour"),
        ("grid:\n  roles.survey.module: [nope.x]\nscenario: missing.yaml\n", "scenario"),
    ],
)
def test_a_bad_sweep_fails_naming_the_problem(tmp_path, body, message):
    with pytest.raises(SweepError) as err:
        plan_sweep(write_sweep(tmp_path, body))
    assert message in str(err.value)


def test_a_scenario_the_sweep_names_must_exist(tmp_path):
    path = tmp_path / "sweep.yaml"
    path.write_text("scenario: nowhere.yaml\ngrid:\n  duration_s: [1]\n")
    with pytest.raises(SweepError, match="cannot read"):
        plan_sweep(path)
    path.write_text("scenario: example:no_such_scenario\ngrid:\n  duration_s: [1]\n")
    with pytest.raises(SweepError, match="no shipped scenario"):
        plan_sweep(path)
    (tmp_path / "broken.yaml").write_text("name: [unclosed\n")
    path.write_text("scenario: broken.yaml\ngrid:\n  duration_s: [1]\n")
    with pytest.raises(SweepError, match=r"broken\.yaml is not valid YAML"):
        plan_sweep(path)


def test_the_cli_rejects_a_bad_sweep_before_any_dask_client_exists(tmp_path, monkeypatch):
    def no_client(*args, **kwargs):
        raise AssertionError("a Dask client was created for a bad sweep")

    monkeypatch.setattr(runner, "Client", no_client)
    monkeypatch.setattr(runner, "LocalCluster", no_client)
    path = write_sweep(tmp_path, "grid:\n  fleet.0.count: [1, 100000]\n")
    result = CliRunner().invoke(app, ["sweep", str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2, result.output
    assert 'grid point {"fleet.0.count": 100000}' in " ".join(result.output.split())
    assert not (tmp_path / "out").exists()


def test_dry_run_lists_the_trials_and_runs_nothing(tmp_path):
    path = write_sweep(tmp_path, "grid:\n  fleet.0.count: [1, 3]\nseeds: 2\n")
    result = CliRunner().invoke(app, ["sweep", str(path), "--dry-run", "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert result.output.count("to run") == 5  # 4 trials + the total line
    assert "4 trial(s), 4 to run" in result.output


def test_grid_points_vary_the_first_parameter_slowest():
    assert grid_points({"a": [1, 2], "b": ["x", "y"]}) == [
        {"a": 1, "b": "x"},
        {"a": 1, "b": "y"},
        {"a": 2, "b": "x"},
        {"a": 2, "b": "y"},
    ]


def test_sweep_help_documents_every_option_with_an_example():
    result = CliRunner().invoke(app, ["sweep", "--help"], terminal_width=200)
    assert result.exit_code == 0
    assert "Example:  swarmsitl sweep" in result.output
    for option in ("--out", "--workers", "--scheduler", "--max-trials", "--dry-run"):
        assert option in result.output


COUPLED = "fleet.0.count = duration_s"


def test_a_coupled_key_sets_each_of_its_parameters_to_the_same_value(tmp_path):
    """Issue (seed 003, N_u = N_m): one axis, a column per parameter, first key slowest."""
    path = write_sweep(
        tmp_path,
        f"grid:\n  {COUPLED}: [10, 20]\n  roles.survey.args.speed_m_s: [8, 12]\n",
    )
    plan = plan_sweep(path)
    assert plan.parameters == ["fleet.0.count", "duration_s", "roles.survey.args.speed_m_s"]
    assert [t.parameters for t in plan.trials] == [
        {"fleet.0.count": n, "duration_s": n, "roles.survey.args.speed_m_s": v}
        for n in (10, 20)
        for v in (8, 12)
    ]
    scenario = build_scenario(plan.trials[-1])
    assert (scenario.spec.n_vehicles, scenario.spec.duration_s) == (20, 20)
    assert plan.spec.x_parameter == "fleet.0.count"
    assert plan.spec.axes == {"fleet.0.count": [10, 20], "roles.survey.args.speed_m_s": [8, 12]}
    assert plan.spec.parameter_values["duration_s"] == [10, 20]
    # a row, and so results.parquet, has a column per parameter
    row = run_trial(plan.trials[0], lambda *a: {"fleet": {}, "passed": True})
    kinds = {k: value_type(v) for k, v in plan.spec.parameter_values.items()}
    written = pq.read_table(write_row(tmp_path / "out", kinds, row)).to_pylist()[0]
    assert (written["fleet.0.count"], written["duration_s"]) == (10, 10)


@pytest.mark.parametrize(
    ("x", "column"), [(COUPLED, "fleet.0.count"), ("duration_s", "duration_s")]
)
def test_x_names_a_coupled_key_or_one_of_its_parameters(tmp_path, x, column):
    path = write_sweep(
        tmp_path, f"grid:\n  swarm.step_hz: [10, 20]\n  {COUPLED}: [10, 20]\nx: {x}\n"
    )
    spec = plan_sweep(path).spec
    assert spec.x_parameter == column
    assert spec.axes == {"swarm.step_hz": [10, 20], column: [10, 20]}


def test_every_parameter_of_a_coupled_key_must_resolve(tmp_path):
    path = write_sweep(tmp_path, "grid:\n  fleet.0.count = fleet.0.cout: [1, 2]\n")
    with pytest.raises(SweepError, match=r"grid: fleet.0.cout: fleet.0 has no 'cout'.*count"):
        plan_sweep(path)


@pytest.mark.parametrize(
    ("grid", "message"),
    [
        ("  fleet.0.count = : [1]\n", "an empty parameter name"),
        ("  duration_s: [10]\n  fleet.0.count = duration_s: [1]\n", "duration_s appears twice"),
        (f"  {COUPLED}: [1]\nx: fleet.0\n", "x: 'fleet.0' is not a grid parameter"),
    ],
)
def test_a_malformed_coupled_key_is_an_error(tmp_path, grid, message):
    with pytest.raises(SweepError, match=message):
        plan_sweep(write_sweep(tmp_path, "grid:\n" + grid))


def test_grid_points_of_a_coupled_key_set_all_its_parameters():
    assert grid_points({"a = b": [1, 2], "c": ["x", "y"]}) == [
        {"a": 1, "b": 1, "c": "x"},
        {"a": 1, "b": 1, "c": "y"},
        {"a": 2, "b": 2, "c": "x"},
        {"a": 2, "b": 2, "c": "y"},
    ]
