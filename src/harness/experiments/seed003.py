"""Seed 003 reproduced: the Caravan auction (ICF) against ICA and GBAA on a degraded fleet.

``swarmsitl experiment seed003`` runs, on the sweep machinery (Dask, one row per trial, resume),
one swarm-fidelity scenario per solution S x scale AT (N agents = N tasks) x communication range
CL x run: N x500s start at uniform points of a task map (a new map per run), each runs the
Caravan role (``companion.scripts.caravan``: the allocator of S over ``companion.net``, flying to
the tasks it holds), and 10 % of the fleet is lost (crashed, radio silent) at a random time. The
run seed fixes the map and the losses, so the three solutions meet the same ones (common random
numbers). ``results.parquet`` has one row per run; ``tables.md`` sets our mean / sd beside
Tables 1-3, the full-factorial ANOVA beside Tables 4-6 and a Tukey HSD; docs/seed003.md gives
every choice.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import yaml

from harness.experiments.pipeline import last_error_line
from harness.report.totals import number_of
from harness.sweep.spec import SweepPlan, SweepSpec, trial_id
from harness.sweep.trial import Trial

AIRFRAME = "x500"
ROLE = "caravan"
MODULE = "companion.scripts.caravan"
ALGORITHMS = ("ica", "gbaa", "icf")
"""The solutions S (Sec. 4.2), in the paper's table order."""
LABEL = {"ica": "ICA", "gbaa": "GBAA", "icf": "ICF"}
SCALES = (5, 15, 30)
"""AT: N agents = N tasks (5x5, 15x15, 30x30)."""
RANGE_FRACTIONS = (0.1, 0.5, 1.0)
"""CL: the communication range as a fraction of the map's diagonal D."""
MAP_SIZE_M = 10.0
"""The map's side, m (not given; the digest: execution times of 5-18 suggest order 10 units)."""
GRID_SPACING_M = 0.5
"""The path-planning lattice's spacing, m (the task map's grid; tasks sit on its vertices)."""
SPEED_M_S = 1.0
"""Constant speed (Sec. 4.1: unit speed), m/s."""
ALTITUDE_M = 2.0
"""Every vehicle's flight height, m: one height, so range is the paper's 2-D disk (the swarm
engine does not collide vehicles; the paper assumes staggered altitudes)."""
LOSS_FRACTION = 0.1
"""Vehicles lost during the mission (Sec. 4.1: 10 %), stochastically rounded per run (5 agents:
one lost in half the runs, none in the others; the mean is 10 %)."""
CLIMB_S = 0.8
"""When the vehicles are at their height and the allocation starts, s (the take-off to
ALTITUDE_M; the role's ``mission_start``)."""
LOSS_STREAM = 3003
"""Mixed into the run seed for the losses' draws (they depend on nothing else)."""
RANGE_EDGE_M = 0.01
"""Half-width of the link's range edge, m: a sharp disk (the paper's connectivity model)."""
DURATION_S = 150.0
"""Simulated seconds a run lasts at most (every task is done long before)."""


def diagonal_m() -> float:
    """D, the map's diagonal, m."""
    return math.hypot(MAP_SIZE_M, MAP_SIZE_M)


@dataclass(frozen=True)
class Seed003Config:
    """What one experiment run covers."""

    quick: bool
    runs: tuple[int, ...]
    """Run indices (each is the run's seed: map and losses)."""
    scales: tuple[int, ...] = SCALES
    ranges: tuple[float, ...] = RANGE_FRACTIONS
    algorithms: tuple[str, ...] = ALGORITHMS
    step_hz: float = 10.0
    decision_hz: float = 5.0
    """Consensus steps per simulated second (one message exchange with the neighbours each)."""


class ExperimentError(ValueError):
    """An experiment that cannot run (the message names the option)."""


def make_config(quick: bool, runs: int | None = None) -> Seed003Config:
    """The full design or ``--quick``.

    Full: 3 x 3 x 3 cells, 31 runs each (837); quick: 5x5 and 15x15, 5 runs per cell (90).
    """
    if runs is not None and runs < 1:
        raise ExperimentError(f"--runs: {runs}; at least 1")
    if quick:
        return Seed003Config(True, tuple(range(runs or 5)), scales=(5, 15))
    return Seed003Config(False, tuple(range(runs or 31)))


def range_m(fraction: float) -> float:
    """The communication range CL = fraction x D, m."""
    return round(fraction * diagonal_m(), 4)


def scenario_text(n: int, cfg: Seed003Config, faults: list[dict[str, Any]]) -> str:
    """The swarm-fidelity scenario of N agents and N tasks (S and CL are trial values)."""
    data = {
        "name": f"seed003-n{n}",
        "description": f"seed 003: {n} x500s share {n} tasks; 10 % of them lost",
        "fidelity": "swarm",
        "swarm": {"step_hz": cfg.step_hz, "decision_hz": cfg.decision_hz, "neighbours": 0},
        "seed": 0,
        "duration_s": DURATION_S,
        "reseed_world": True,
        "world": {
            "kind": "taskmap",
            "seed": 0,
            "size_m": [MAP_SIZE_M, MAP_SIZE_M],
            "grid_spacing_m": GRID_SPACING_M,
            "task_count": n,
            "agent_count": n,
        },
        "fleet": [{"role": ROLE, "count": n, "airframe": AIRFRAME}],
        "roles": {
            ROLE: {
                "module": MODULE,
                "args": {
                    "algorithm": ALGORITHMS[-1],
                    "speed_m_s": SPEED_M_S,
                    "altitude_m": ALTITUDE_M,
                    "altitude_step_m": 0.0,
                },
            }
        },
        "links": {
            "presets": {
                "mesh": {
                    "base": "wifi",
                    "loss": {"model": "bernoulli", "mean_loss": 0.0},
                    "range_m": range_m(RANGE_FRACTIONS[-1]),
                    "range_width_m": RANGE_EDGE_M,
                }
            },
            "classes": {"edge-edge": "mesh"},
        },
        "faults": faults,
        "sensors": {"cameras": False, "rangefinders": False},
        "checks": {"companions_succeeded": True, "landed_and_disarmed": True},
    }
    return yaml.safe_dump(data, sort_keys=False)


def task_map(n: int, run: int) -> tuple[np.ndarray, np.ndarray]:
    """(agent starts, tasks), (N, 2) m each, of run ``run``'s map (the world the run builds)."""
    import worlds

    spec = worlds.parse_world(
        yaml.safe_dump(
            {"kind": "taskmap", "seed": run, "size_m": [MAP_SIZE_M, MAP_SIZE_M],
             "grid_spacing_m": GRID_SPACING_M, "task_count": n, "agent_count": n}
        ),
        "seed003 task map",
    )  # fmt: skip
    world = worlds.build(spec)
    starts = np.array([a.center_enu_m[:2] for a in world.launch_areas], dtype=float)
    tasks = np.array([t.position_xy_m for t in world.targets], dtype=float)
    return starts, tasks


def losses(n: int, run: int) -> list[dict[str, Any]]:
    """The run's lost vehicles, each lost while it flies to its task of the optimal assignment.

    The count is LOSS_FRACTION x n stochastically rounded; the vehicles are drawn without
    repeats; each is lost at CLIMB_S + u x its straight travel time to the task J* gives it
    (Hungarian on the full information, ``companion.planning.caravan.optimum``), u uniform:
    the loss always orphans a task of the best plan (the loss-time distribution is not given).
    Every draw comes from the run seed alone, so the three solutions meet the same losses.
    """
    from companion.planning.caravan.optimum import optimal_assignment, score_matrix
    from companion.planning.caravan.scores import CaravanParams
    from harness.scenarios.faults import fault_count

    rng = np.random.default_rng([run, LOSS_STREAM])
    u = float(rng.uniform())
    order = rng.permutation(n)
    when = rng.uniform(0.0, 1.0, n)
    starts, tasks = task_map(n, run)
    rows, cols = optimal_assignment(score_matrix(None, starts, tasks, CaravanParams()))
    travel_s = np.linalg.norm(starts[rows] - tasks[cols], axis=1) / SPEED_M_S
    own = dict(zip(rows.tolist(), travel_s.tolist(), strict=True))
    lost = sorted(int(k) for k in order[: fault_count(LOSS_FRACTION, n, "stochastic", u)])
    return [
        {"kind": ["crash", "radio"], "vehicle": k + 1,
         "at_s": round(CLIMB_S + float(when[k]) * own[k], 3)}
        for k in lost
    ]  # fmt: skip


RANGE_KEY = "links.presets.mesh.range_m"
ALGORITHM_KEY = f"roles.{ROLE}.args.algorithm"


def sweep_plan(cfg: Seed003Config, source: Path) -> SweepPlan:
    """Every trial of the experiment as one sweep plan (``harness.sweep``)."""
    trials = []
    for n in cfg.scales:
        texts = {run: scenario_text(n, cfg, losses(n, run)) for run in cfg.runs}
        for fraction in cfg.ranges:
            for algorithm in cfg.algorithms:
                values = {"fleet.0.count": n, RANGE_KEY: range_m(fraction),
                          ALGORITHM_KEY: algorithm}  # fmt: skip
                for run in cfg.runs:
                    text = texts[run]
                    trials.append(
                        Trial(trial_id(text, values, run), str(source), text,
                              tuple(values.items()), run)
                    )  # fmt: skip
    grid = {
        "fleet.0.count": list(cfg.scales),
        RANGE_KEY: [range_m(f) for f in cfg.ranges],
        ALGORITHM_KEY: list(cfg.algorithms),
    }
    spec = SweepSpec(scenario=str(source), grid=grid, seeds=list(cfg.runs))
    return SweepPlan(spec, "seed003", None, source, "", "swarm", tuple(trials))


def execute(scenario: Any, seed: int, run_dir: Path | None, timeout: float | None) -> dict:
    """A trial's body: the swarm run, plus the vehicles its faults took."""
    from harness.swarm.run import run_swarm

    report = run_swarm(scenario, seed, None)
    lost = sum(1 for f in report.get("faults", []) if f.get("applied"))
    report["fleet"]["seed003"] = {"vehicles_lost": {"value": lost, "unit": "count"}}
    return report


METRICS = (
    "optimality_gap",
    "convergence_steps",
    "execution_time",
    "tasks_assigned",
    "tasks_released",
    "tasks_validated",
    "tasks_total",
    "tasks_completed_twice",
)
"""The run-level metrics of the Caravan role (``companion.scripts.caravan.run_metrics``)."""


def results_table(sweep: pa.Table, cfg: Seed003Config) -> pa.Table:
    """One row per run: the issue's columns, then the run's status and its other numbers."""
    by_range = {range_m(f): f for f in cfg.ranges}
    out = []
    for row in sweep.to_pylist():
        rec: dict[str, Any] = {
            "algorithm": row.get(ALGORITHM_KEY),
            "agents": int(row.get("fleet.0.count") or 0),
            "range_frac": by_range.get(row.get(RANGE_KEY), math.nan),
            "run": int(row["seed"]),
        }
        for name in METRICS:
            rec[name] = number_of(row.get(f"fleet.run.{name}"))
        rec["vehicles_lost"] = number_of(row.get("fleet.seed003.vehicles_lost"))
        rec["status"] = row.get("status")
        rec["passed"] = bool(row.get("passed"))
        rec["error"] = last_error_line(row)
        out.append(rec)
    order = {a: i for i, a in enumerate(ALGORITHMS)}
    out.sort(key=lambda r: (order.get(r["algorithm"], 99), r["agents"], r["range_frac"], r["run"]))
    return pa.Table.from_pylist(out)


def run_experiment(
    cfg: Seed003Config,
    out_dir: Path,
    *,
    workers: int = 2,
    scheduler: str | None = None,
    console: Any = None,
    say: Callable[[str], None] = print,
) -> int:
    """Run (or resume) the experiment into ``out_dir``; write the tables, plots and RESULT.

    Returns the exit status: 0 when every trial ran and passed its checks, 1 otherwise.
    """
    from harness.experiments.pipeline import run_plan
    from harness.experiments.seed003_report import write_report

    plan = sweep_plan(cfg, Path(__file__).with_name("seed003.py"))
    config = {"quick": cfg.quick, "runs": list(cfg.runs), "scales": list(cfg.scales),
              "range_fractions": list(cfg.ranges), "algorithms": list(cfg.algorithms),
              "map_size_m": MAP_SIZE_M, "speed_m_s": SPEED_M_S,
              "decision_hz": cfg.decision_hz}  # fmt: skip
    return run_plan(
        plan, out_dir, execute=execute, tabulate=lambda t: results_table(t, cfg),
        report=lambda results, out, say_: write_report(results, cfg, out, say_), config=config,
        quick=cfg.quick, workers=workers, scheduler=scheduler, console=console, say=say,
    )  # fmt: skip
