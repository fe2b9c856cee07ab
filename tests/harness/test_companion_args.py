"""A role's ``args`` are read as its program reads them when the scenario loads (exit 2 if not).

Only a module that declares ``PARAMS`` is imported; a program that declares nothing, a script or
another command keeps its ``args`` unchecked.
"""

from __future__ import annotations

import datetime
import re
import sys
import textwrap
import uuid
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
from typer.testing import CliRunner

from companion.planning.coverage_role import CoverageParams
from companion.scripts.indoor_search import SearchParams
from harness.cli import app
from harness.run.companion_args import (
    ArgsProblem,
    DeclarationError,
    check_args,
    declared_params,
    program_module,
)
from harness.scenarios import runner as scenario_run
from harness.scenarios.spec import ScenarioError, load_scenario

SCENARIO = """\
name: misspelt
duration_s: 30
fleet:
  - role: survey
    count: 3
roles:
  survey:
    module: companion.scripts.coverage
    args:
      altitude_m: 20
      sped_m_s: 8
"""


@dataclass(frozen=True)
class _Params:
    speed_m_s: float = 5.0
    when: object = None

    def __post_init__(self) -> None:
        if self.speed_m_s <= 0:
            raise ValueError(f"PARAMS speed_m_s must be positive, got {self.speed_m_s!r}")


@pytest.fixture
def module_name() -> Iterator[str]:
    """A fresh module name (a user's program in the test's folder), forgotten afterwards."""
    name = f"user_program_{uuid.uuid4().hex}"
    yield name
    for key in [k for k in sys.modules if k == name or k.startswith(f"{name}.")]:
        del sys.modules[key]


def test_the_module_a_role_runs_is_its_module_or_its_python_dash_m_command():
    assert program_module("companion.scripts.coverage", None) == "companion.scripts.coverage"
    assert program_module(None, ["{python}", "-m", "mine", "--fast"]) == "mine"
    assert program_module(None, ["{python}", "mine.py"]) is None
    assert program_module(None, ["python3", "-m", "mine"]) is None  # another interpreter
    assert program_module(None, None) is None


def test_the_shipped_programs_declare_their_parameter_dataclasses(tmp_path):
    assert declared_params("companion.scripts.coverage", tmp_path) is CoverageParams
    assert declared_params("companion.scripts.indoor_search", tmp_path) is SearchParams
    assert declared_params("companion.scripts.demo_flight", tmp_path) is None


def test_a_user_module_in_the_scenario_folder_declares_params(tmp_path, module_name):
    (tmp_path / f"{module_name}.py").write_text(
        textwrap.dedent(
            """\
            from dataclasses import dataclass

            @dataclass(frozen=True)
            class Mine:
                gain: float = 1.0

            PARAMS = Mine

            if __name__ == "__main__":
                raise SystemExit("flies only when run")
            """
        )
    )
    params = declared_params(module_name, tmp_path)
    assert params is not None and params.__name__ == "Mine"
    assert str(tmp_path) not in sys.path  # the folder was on the path only for the look-up


def test_a_module_that_declares_nothing_is_never_imported(tmp_path, module_name):
    flown = tmp_path / "flown"
    (tmp_path / f"{module_name}.py").write_text(f"open({str(flown)!r}, 'w').close()\n")
    assert declared_params(module_name, tmp_path) is None
    assert not flown.exists() and module_name not in sys.modules
    assert declared_params(f"{module_name}_absent", tmp_path) is None


def test_a_package_run_with_dash_m_declares_in_its_main(tmp_path, module_name):
    package = tmp_path / module_name
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "__main__.py").write_text(
        "from dataclasses import dataclass\n\n\n@dataclass\nclass P:\n    k: int = 1\n\n\n"
        "PARAMS = P\n"
    )
    params = declared_params(module_name, tmp_path)
    assert params is not None and params.__name__ == "P"


@pytest.mark.parametrize(
    ("body", "says"),
    [
        ("PARAMS = 3\n", "must be a dataclass"),
        ("import no_such_module_anywhere\nPARAMS = None\n", "cannot import"),
    ],
)
def test_a_bad_declaration_is_an_error(tmp_path, module_name, body, says):
    (tmp_path / f"{module_name}.py").write_text(body)
    with pytest.raises(DeclarationError, match=says):
        declared_params(module_name, tmp_path)


def test_args_are_read_as_the_program_reads_them():
    assert check_args(_Params, {"speed_m_s": 3}, "mine") is None
    assert check_args(_Params, {"sped_m_s": 3}, "mine") == ArgsProblem(
        "sped_m_s", "unknown argument of mine; did you mean speed_m_s?"
    )
    unknown = check_args(_Params, {"zzz": 3}, "mine")
    assert unknown is not None and unknown.message.endswith("; known: speed_m_s, when")
    bad = check_args(_Params, {"speed_m_s": -1}, "mine")
    assert bad is not None and bad.key is None and "speed_m_s must be positive" in bad.message
    dated = check_args(_Params, {"when": datetime.date(2024, 1, 1)}, "mine")
    assert dated is not None and "not JSON" in dated.message


def test_a_misspelt_argument_of_a_shipped_program_names_role_key_and_suggestion(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(SCENARIO)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert str(info.value) == (
        f"{path}:11: roles.survey.args.sped_m_s: unknown argument of companion.scripts.coverage; "
        "did you mean speed_m_s or descent_m_s?"
    )


def test_undeclared_script_and_command_programs_pass_their_args_unchecked(tmp_path, module_name):
    (tmp_path / "mine.py").write_text("print('hi')\n")
    (tmp_path / f"{module_name}.py").write_text("print('hi')\n")
    for program in ("script: mine.py", f"command: ['{{python}}', '-m', '{module_name}']"):
        path = tmp_path / "s.yaml"
        path.write_text(SCENARIO.replace("module: companion.scripts.coverage", program))
        assert load_scenario(path).spec.roles["survey"].args["sped_m_s"] == 8


def test_run_refuses_a_misspelt_argument_with_one_message_before_anything_starts(
    tmp_path, monkeypatch
):
    """The issue: one traceback per vehicle and exit 1; now one line, exit 2, nothing started."""

    def no_process(*args, **kwargs):
        raise AssertionError("a companion process was started")

    monkeypatch.setattr(scenario_run.subprocess, "Popen", no_process)
    path = tmp_path / "s.yaml"
    path.write_text(SCENARIO)
    out = tmp_path / "run"
    result = CliRunner().invoke(app, ["run", str(path), "--out", str(out)])
    flat = " ".join(result.output.split())
    assert result.exit_code == 2, result.output
    assert flat.count("error:") == 1 and flat.count("did you mean speed_m_s") == 1
    assert "roles.survey.args.sped_m_s" in flat and "Traceback" not in flat
    assert not out.exists()  # no run directory, no vehicle logs


def test_the_declaring_example_of_companions_md_is_checked_at_load(tmp_path, monkeypatch):
    """docs/companions.md's ``# my_survey.py:`` block, as written, declares its parameters."""
    doc = Path(__file__).resolve().parents[2] / "docs" / "companions.md"
    fence = re.compile(r"^```python\n(# my_survey\.py:.*?)^```[ \t]*$", re.S | re.M)
    (program,) = fence.findall(doc.read_text())
    (tmp_path / "my_survey.py").write_text(program)
    monkeypatch.delitem(sys.modules, "my_survey", raising=False)
    path = tmp_path / "s.yaml"
    text = SCENARIO.replace("companion.scripts.coverage", "my_survey")
    path.write_text(text.replace("sped_m_s: 8", "side_m: 8"))
    assert load_scenario(path).spec.roles["survey"].args == {"altitude_m": 20, "side_m": 8}
    path.write_text(text.replace("sped_m_s: 8", "sid_m: 8"))
    with pytest.raises(ScenarioError, match=r"args.sid_m: unknown argument of my_survey; did"):
        load_scenario(path)
    path.write_text(text.replace("altitude_m: 20", "altitude_m: -1").replace("sped_m_s", "side_m"))
    with pytest.raises(ScenarioError, match="altitude_m must be positive"):
        load_scenario(path)
