"""The sweep file: which scenario, which parameter grid, which seeds, what to plot.

``plan_sweep(path)`` reads a sweep YAML, validates it against :class:`SweepSpec` (unknown keys,
wrong types: errors naming file, line and field), resolves every grid parameter against the
scenario (a typo names the close matches), and parses the scenario of every grid point so that
a value the scenario rejects fails here, with the point's parameters, before anything is
submitted. The result, a :class:`SweepPlan`, lists every trial. docs/sweeps.md describes the file.
"""

from __future__ import annotations

import hashlib
import itertools
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from harness.scenarios import scenario_path
from harness.scenarios.spec import ScenarioError
from harness.sweep.params import ParameterError, apply_parameters, set_parameter
from harness.sweep.trial import Trial, build_scenario
from worlds.examples import EXAMPLE_PREFIX
from worlds.yaml_source import validate_yaml

Scalar = bool | int | float | str
"""A grid value: what a YAML scalar holds."""

COUPLE = "="
"""Joins the parameters of a coupled grid key (``world.agent_count = world.task_count``)."""


def coupled(key: str) -> tuple[str, ...]:
    """The dotted parameters a grid key sets: one, or several joined by `` = ``."""
    return tuple(part.strip() for part in key.split(COUPLE))


class SweepError(ValueError):
    """A sweep that cannot run; the message names the file and what is wrong."""


class SweepSpec(BaseModel):
    """The whole sweep file."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    name: str | None = None
    """Name of the sweep [default: the file's name without .yaml]; the default output directory
    is runs/sweep-NAME."""
    scenario: str
    """The scenario file, relative to the sweep file, or ``example:NAME`` for a shipped one."""
    grid: dict[str, list[Scalar]] = Field(min_length=1)
    """Dotted scenario parameter -> the values it takes; the trials are every combination. A key
    of several parameters joined by `` = `` (``world.agent_count = fleet.0.count``) sets all of
    them to each of its values (one axis of the grid)."""
    seeds: int | list[int] = 1
    """Seeds of every grid point: N means 0..N-1, or a list of seeds."""
    metrics: list[str] = Field(default_factory=list)
    """Table columns to plot (``fleet.coverage_fraction``) [default: every ``fleet.`` metric]."""
    x: str | None = None
    """The grid parameter on the plots' x axis (a grid key, or one parameter of a coupled key)
    [default: the first grid parameter]."""
    trial_timeout_s: float | None = Field(None, gt=0)
    """Full-fidelity trials: give up a run after this many wall seconds (the trial fails)."""

    @field_validator("grid")
    @classmethod
    def _values(cls, grid: dict[str, list[Scalar]]) -> dict[str, list[Scalar]]:
        seen: set[str] = set()
        for key, values in grid.items():
            parts = coupled(key)
            if not all(parts):
                raise ValueError(
                    f"{key!r}: an empty parameter name (join dotted parameters with ' = ')"
                )
            for part in parts:
                if part in seen:
                    raise ValueError(f"{key}: the parameter {part} appears twice in the grid")
                seen.add(part)
            if not values:
                raise ValueError(f"{key}: an empty list of values (give at least one)")
            if len({json.dumps(v) for v in values}) != len(values):
                raise ValueError(f"{key}: a value appears twice in {values}")
        return grid

    @field_validator("seeds")
    @classmethod
    def _seeds(cls, seeds: int | list[int]) -> int | list[int]:
        if isinstance(seeds, int):
            if seeds < 1:
                raise ValueError("seeds: at least 1")
        elif not seeds or len(set(seeds)) != len(seeds) or min(seeds) < 0:
            raise ValueError("seeds: a list of distinct seeds >= 0, not empty")
        return seeds

    @model_validator(mode="after")
    def _x(self) -> SweepSpec:
        if self.x is not None and self.x not in self.grid and self.x not in self.parameters:
            raise ValueError(f"x: {self.x!r} is not a grid parameter ({', '.join(self.grid)})")
        return self

    @property
    def parameters(self) -> list[str]:
        """Every dotted parameter the grid sets, in file order (a coupled key's each)."""
        return [part for key in self.grid for part in coupled(key)]

    @property
    def parameter_values(self) -> dict[str, list[Scalar]]:
        """Each dotted parameter -> the values it takes (a coupled key's parameters alike)."""
        return {part: values for key, values in self.grid.items() for part in coupled(key)}

    @property
    def seed_list(self) -> list[int]:
        """The seeds every grid point runs with."""
        return list(range(self.seeds)) if isinstance(self.seeds, int) else list(self.seeds)

    @property
    def x_parameter(self) -> str:
        """The plots' x axis: one dotted parameter, a column of the table.

        A coupled key (given as ``x`` or first in the grid) stands for its first parameter.
        """
        if self.x is not None and self.x not in self.grid:
            return self.x
        return coupled(self.x or next(iter(self.grid)))[0]

    @property
    def axes(self) -> dict[str, list[Scalar]]:
        """One table column per grid key -> its values (what the plots vary).

        A coupled key's column is its parameter that is the x axis, else its first one.
        """
        x = self.x_parameter
        out = {}
        for key, values in self.grid.items():
            parts = coupled(key)
            out[x if x in parts else parts[0]] = values
        return out


@dataclass(frozen=True)
class SweepPlan:
    """A checked sweep: its spec, its scenario, every trial in grid order."""

    spec: SweepSpec
    name: str
    path: Path | None
    scenario_path: Path
    scenario_text: str
    fidelity: str
    """The scenario's fidelity (``full`` or ``swarm``) at the first grid point."""
    trials: tuple[Trial, ...]

    @property
    def parameters(self) -> list[str]:
        """The grid's dotted parameter names, in file order (each of a coupled key's)."""
        return self.spec.parameters


def resolve_scenario(ref: str, base_dir: Path) -> Path:
    """The scenario file a sweep names: ``example:NAME`` or a path relative to ``base_dir``."""
    if ref.startswith(EXAMPLE_PREFIX):
        return scenario_path(ref.removeprefix(EXAMPLE_PREFIX))
    return (base_dir / ref).resolve()


def trial_id(scenario_text: str, values: dict[str, Any], seed: int) -> str:
    """Stable id of a trial: what determines its result (scenario text, parameters, seed)."""
    h = hashlib.sha256(scenario_text.encode())
    h.update(json.dumps(values, sort_keys=True).encode())
    h.update(f"seed={seed}".encode())
    return h.hexdigest()[:16]


def grid_points(grid: dict[str, list[Scalar]]) -> list[dict[str, Scalar]]:
    """Every combination of the grid's values, the first key varying slowest.

    Each point maps every dotted parameter to its value: a coupled key's parameters
    (``a = b``) all to the same one.
    """
    keys = [coupled(key) for key in grid]
    return [
        {part: value for parts, value in zip(keys, combo, strict=True) for part in parts}
        for combo in itertools.product(*grid.values())
    ]


def parse_sweep(text: str, source: str = "<string>") -> SweepSpec:
    """Validate sweep YAML ``text``: :class:`SweepError` naming file, line and field."""
    return validate_yaml(  # type: ignore[return-value]
        text,
        source,
        lambda data, root: SweepSpec,
        SweepError,
        "a sweep file is a mapping with at least scenario and grid",
    )


def plan(spec: SweepSpec, name: str, base_dir: Path, path: Path | None = None) -> SweepPlan:
    """Check ``spec`` against its scenario and list its trials; SweepError on the first problem."""
    where = str(path) if path is not None else "sweep"
    try:
        scenario_file = resolve_scenario(spec.scenario, base_dir)
    except ValueError as exc:
        raise SweepError(f"{where}: scenario: {exc}") from exc
    try:
        text = scenario_file.read_text()
    except OSError as exc:
        raise SweepError(f"{where}: scenario: cannot read {scenario_file}: {exc}") from exc
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise SweepError(f"{where}: scenario: {scenario_file} is not valid YAML: {exc}") from exc
    if not isinstance(data, dict):
        raise SweepError(f"{where}: scenario: {scenario_file} is not a scenario mapping")
    for key, values in spec.grid.items():
        for part in coupled(key):
            try:
                set_parameter(apply_parameters(data, {}), part, values[0])
            except ParameterError as exc:
                raise SweepError(f"{where}: grid: {exc}") from exc
    points = grid_points(spec.grid)
    fidelity = "full"
    trials = []
    for k, values in enumerate(points):
        probe = Trial("", str(scenario_file), text, tuple(values.items()), spec.seed_list[0])
        try:
            scenario = build_scenario(probe)
        except (ScenarioError, ParameterError) as exc:
            raise SweepError(
                f"{where}: grid point {json.dumps(values)} gives a bad scenario: {exc}"
            ) from exc
        if k == 0:
            fidelity = scenario.spec.fidelity
        for seed in spec.seed_list:
            tid = trial_id(text, values, seed)
            trials.append(
                Trial(tid, str(scenario_file), text, tuple(values.items()), seed,
                      spec.trial_timeout_s)
            )  # fmt: skip
    return SweepPlan(spec, name, path, scenario_file, text, fidelity, tuple(trials))


def plan_sweep(path: str | Path) -> SweepPlan:
    """Read, validate and plan the sweep file at ``path`` (nothing runs)."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise SweepError(f"{path}: cannot read sweep file: {exc}") from exc
    spec = parse_sweep(text, str(path))
    name = spec.name or path.name.removesuffix(".yaml").removesuffix(".yml")
    return plan(spec, name, path.parent, path)
