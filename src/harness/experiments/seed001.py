"""Seed 001 reproduced: ACO path planning with priority avoidance and formation keeping.

``swarmsitl experiment seed001`` runs, on the sweep machinery (Dask, one row per trial, resume),
one swarm-fidelity scenario per case x swarm size x parameter x run: N x500s stand on a lattice
in the start zone of a 1 km x 1 km ``arena_aco`` world (Sec. 4.1), each runs seed 001's role
(``companion.scripts.aco_swarm``: its own ACO plan, Alg. 2's avoidance by priority, option 2's
formation keeping, positions broadcast over ``companion.net``) to the goal zone, and lands. The
obstacles are drums flying random straight lines in the corridor between the zones, at the
flight's heights (a new layout per run: the run seed fixes it, so the planners and options of a
run meet the same drums). The cases:

* ``safe_distance`` (Sec. 4.2, Figs. 3-5): option 1, no obstacles, D_min 1, 2, 3 m;
* ``obstacles`` (Sec. 4.3, Figs. 6, 8, 9): option 1, D_min 1 m, the drum count swept;
* ``threshold`` (Sec. 4.4, Figs. 10-12): option 2, D_min 1 m, the allowable change swept;
* ``fig13`` (Fig. 13): option 2, 20 UAVs, threshold 0.1 m, 10 to 100 drums;
* ``table2`` (Table 2): option 2, threshold 0.1 m, D_min 1 m, the nine (drums, UAVs) rows.

The first two also fly the A* baseline on the same roadmaps (``planner: astar``): the paper has
no baseline (digest 004_001, 001 §3). ``results.parquet`` has one row per run; ``tables.md``
sets ours (mean and 95 % interval) beside Table 2 and states each sweep's trend against the
paper's text; docs/seed001.md gives every choice.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pyarrow as pa
import yaml

from harness.experiments.pipeline import last_error_line
from harness.report.totals import number_of
from harness.sweep.spec import SweepPlan, SweepSpec, trial_id
from harness.sweep.trial import Trial

AIRFRAME = "x500"
ROLE = "aco"
MODULE = "companion.scripts.aco_swarm"
ARENA_M = 1000.0
"""The arena's side, m (Sec. 4.1: 1 km x 1 km)."""
ZONE_SEPARATION_M = 300.0
"""Start zone centre to goal zone centre, m. Not given; Table 2's FT (makespan / 60 s) of
0.6-2.5 at 6 m/s says a few hundred metres (digest 004_001, 001 §5)."""
ZONE_RADIUS_M = 40.0
"""Radius of the start and goal zones, m (80 UAVs at SPACING_M fit with room)."""
SPACING_M = 5.0
"""The start formation's lattice spacing, m (= R_s: neighbours start at the sensing range)."""
CORRIDOR_M = (-110.0, -70.0, 110.0, 70.0)
"""Where the drums start and bounce (east_min, north_min, east_max, north_max), m: between the
zones' edges, as wide as the formations' paths."""
DRUM_DIAMETER_M = (2.0, 6.0)
"""Drum diameters (and heights), m."""
DRUM_SPEED_M_S = (1.0, 4.0)
"""Drum speeds, m/s (below the UAVs' 6 m/s)."""
DRUM_ALTITUDE_M = (12.0, 28.0)
"""Drum centre heights, m: across the UAVs' flight band (15-25 m)."""
DRUM_BOB_M = 3.0
"""Amplitude of the drums' vertical motion, m."""
STEP_HZ = 20.0
"""Kinematic steps per simulated second."""
DECISION_HZ = 10.0
"""Alg. 2/4 decisions per simulated second (0.6 m of flight at 6 m/s)."""
SPEED_M_S = 6.0
"""The UAVs' speed and the engine's speed cap, m/s (Sec. 4.1)."""
TURN_RATE_DEG_S = 30.0
"""theta_max, 30 deg (Sec. 4.1, Eq. 13), read as the largest change of course per second."""
DURATION_S = 400.0
"""Simulated seconds a run lasts at most (a run ends when every UAV has landed)."""

SAFE_DISTANCES_M = (1.0, 2.0, 3.0)
"""Sec. 4.2's D_min values."""
THRESHOLDS_M = (0.1, 0.25, 0.5, 1.0)
"""Sec. 4.4's allowable changes (the paper's list is not in the text; Table 2 uses 0.1)."""
SWEEP_DRONES = (5, 10, 20, 40)
"""Swarm sizes of the sweeps (the paper: 5 to 80)."""
SWEEP_OBSTACLES = (0, 10, 25, 50)
"""Drum counts of the obstacle sweep (the paper: "gradually increased", up to more than N)."""
FIG13_OBSTACLES = (10, 25, 50, 75, 100)
"""Fig. 13's drum counts (20 UAVs: 10 to 100)."""
TABLE2 = ((6, 5), (12, 10), (25, 20), (40, 30), (45, 40), (60, 50), (65, 60), (75, 70), (85, 80))
"""Table 2's rows: (obstacles, drones)."""
CASES = ("safe_distance", "obstacles", "threshold", "fig13", "table2")
PLANNERS = ("aco", "astar")


@dataclass(frozen=True)
class Case:
    """One cell of the design (every run of it differs only by its seed)."""

    case: str
    option: int
    planner: str
    drones: int
    obstacles: int
    d_min_m: float
    threshold_m: float


@dataclass(frozen=True)
class Seed001Config:
    """What one experiment run covers."""

    quick: bool
    table_runs: tuple[int, ...]
    """Run indices (seeds) of Table 2's cases (the paper: 35)."""
    sweep_runs: tuple[int, ...]
    """Run indices of the sweeps and Fig. 13."""
    sweep_drones: tuple[int, ...] = SWEEP_DRONES
    safe_distances_m: tuple[float, ...] = SAFE_DISTANCES_M
    obstacles: tuple[int, ...] = SWEEP_OBSTACLES
    thresholds_m: tuple[float, ...] = THRESHOLDS_M
    fig13_obstacles: tuple[int, ...] = FIG13_OBSTACLES
    table2: tuple[tuple[int, int], ...] = TABLE2

    def cases(self) -> list[Case]:
        """Every cell, in table order."""
        out = []
        for n in self.sweep_drones:
            for d in self.safe_distances_m:
                out += [Case("safe_distance", 1, p, n, 0, d, 0.1) for p in PLANNERS]
        for n in self.sweep_drones:
            for k in self.obstacles:
                out += [Case("obstacles", 1, p, n, k, 1.0, 0.1) for p in PLANNERS]
        for n in self.sweep_drones:
            for t in self.thresholds_m:
                out.append(Case("threshold", 2, "aco", n, n, 1.0, t))
        for k in self.fig13_obstacles:
            out.append(Case("fig13", 2, "aco", 20, k, 1.0, 0.1))
        for k, n in self.table2:
            out.append(Case("table2", 2, "aco", n, k, 1.0, 0.1))
        return out

    def runs_of(self, case: Case) -> tuple[int, ...]:
        """The run indices of ``case``."""
        return self.table_runs if case.case == "table2" else self.sweep_runs


class ExperimentError(ValueError):
    """An experiment that cannot run (the message names the option)."""


def make_config(quick: bool, runs: int | None = None) -> Seed001Config:
    """The full design or ``--quick``.

    Full: Table 2's nine rows with 35 runs each (``--runs``), the sweeps (sizes 5-40) and Fig. 13
    with min(runs, 10). Quick (28 runs): 5 UAVs, two levels per sweep, Fig. 13's 10 and 40 drums,
    Table 2's first two rows, 2 runs each.
    """
    if runs is not None and runs < 1:
        raise ExperimentError(f"--runs: {runs}; at least 1")
    if quick:
        r = tuple(range(runs or 2))
        return Seed001Config(
            True, r, r, sweep_drones=(5,), safe_distances_m=(1.0, 3.0), obstacles=(0, 10),
            thresholds_m=(0.1, 1.0), fig13_obstacles=(10, 40), table2=TABLE2[:2],
        )  # fmt: skip
    table = tuple(range(runs or 35))
    return Seed001Config(False, table, table[:10])


def scenario_text(case: Case) -> str:
    """The swarm-fidelity scenario of one cell (the run's seed goes in per trial)."""
    data = {
        "name": f"seed001-{case.case}",
        "description": (
            f"seed 001 {case.case}: {case.drones} UAVs, {case.obstacles} drums, option "
            f"{case.option}, {case.planner}, D_min {case.d_min_m} m, threshold {case.threshold_m} m"
        ),
        "fidelity": "swarm",
        "swarm": {
            "step_hz": STEP_HZ,
            "decision_hz": DECISION_HZ,
            "neighbours": 0,
            "max_speed_m_s": SPEED_M_S,
            "max_turn_rate_deg_s": TURN_RATE_DEG_S,
        },
        "seed": 0,
        "duration_s": DURATION_S,
        "reseed_world": True,
        "world": {
            "kind": "arena_aco",
            "seed": 0,
            "size_m": [ARENA_M, ARENA_M],
            "static_obstacle_count": 0,
            "moving_obstacle_count": case.obstacles,
            "moving_obstacle_diameter_m": list(DRUM_DIAMETER_M),
            "moving_obstacle_speed_m_s": list(DRUM_SPEED_M_S),
            "moving_obstacle_altitude_m": list(DRUM_ALTITUDE_M),
            "moving_obstacle_vertical_amplitude_m": DRUM_BOB_M,
            "moving_obstacle_region_m": list(CORRIDOR_M),
            "zone_radius_m": ZONE_RADIUS_M,
            "zone_separation_m": ZONE_SEPARATION_M,
        },
        "launch_area": "start",
        "spacing_m": SPACING_M,
        "fleet": [{"role": ROLE, "count": case.drones, "airframe": AIRFRAME}],
        "roles": {
            ROLE: {
                "module": MODULE,
                "args": {
                    "option": case.option,
                    "planner": case.planner,
                    "d_min_m": case.d_min_m,
                    "threshold_m": case.threshold_m,
                    "speed_m_s": SPEED_M_S,
                },
            }
        },
        "sensors": {"cameras": False, "rangefinders": False},
        "checks": {"companions_succeeded": True},
    }
    return yaml.safe_dump(data, sort_keys=False)


COUNT_KEY = "fleet.0.count"
OBSTACLES_KEY = "world.moving_obstacle_count"


def _trials(cfg: Seed001Config, source: Path) -> list[tuple[Case, Trial]]:
    out = []
    for case in cfg.cases():
        text = scenario_text(case)
        values = {COUNT_KEY: case.drones, OBSTACLES_KEY: case.obstacles}
        for run in cfg.runs_of(case):
            tid = trial_id(text, values, run)
            out.append((case, Trial(tid, str(source), text, tuple(values.items()), run)))
    return out


def sweep_plan(cfg: Seed001Config, source: Path) -> SweepPlan:
    """Every trial of the experiment as one sweep plan (``harness.sweep``)."""
    pairs = _trials(cfg, source)
    cases = cfg.cases()
    grid = {
        COUNT_KEY: sorted({c.drones for c in cases}),
        OBSTACLES_KEY: sorted({c.obstacles for c in cases}),
    }
    seeds = sorted(set(cfg.table_runs) | set(cfg.sweep_runs))
    spec = SweepSpec(scenario=str(source), grid=grid, seeds=seeds)
    return SweepPlan(spec, "seed001", None, source, "", "swarm", tuple(t for _, t in pairs))


@functools.cache
def _warm_planner() -> None:
    """Load the colony's compiled kernels once per process, so no run's plan_ms carries it."""
    import numpy as np

    from companion.planning.aco.plan import plan_path
    from companion.planning.aco.roadmap import RoadmapParams

    params = RoadmapParams(nodes=20, min_enu_m=(0.0, 0.0, 10.0), max_enu_m=(100.0, 100.0, 10.0))
    plan_path(np.array([1.0, 1.0, 10.0]), np.array([90.0, 90.0, 10.0]), params,
              np.random.default_rng(0))  # fmt: skip


def execute(scenario: Any, seed: int, run_dir: Path | None, timeout: float | None) -> dict:
    """A trial's body: the swarm run (the planner's kernels loaded before it)."""
    from harness.swarm.run import run_swarm

    _warm_planner()
    return run_swarm(scenario, seed, None)


COLUMNS = ("pq_pct", "mc_pct", "ad", "ft", "fc_pct", "cf")
_RUN_METRIC = {"pq_pct": "pq", "mc_pct": "mc", "ad": "ad", "ft": "ft", "fc_pct": "fc", "cf": "cf"}


def results_table(sweep: pa.Table, cfg: Seed001Config, source: Path) -> pa.Table:
    """One row per run: the issue's columns, then the run's status and its other numbers."""
    case_of = {t.trial_id: c for c, t in _trials(cfg, source)}
    out = []
    for row in sweep.to_pylist():
        case = case_of.get(row["trial_id"])
        if case is None:  # a trial of an older design left in the directory
            continue
        rec: dict[str, Any] = {
            "case": case.case,
            "option": case.option,
            "planner": case.planner,
            "drones": case.drones,
            "obstacles": case.obstacles,
            "d_min_m": case.d_min_m,
            "threshold_m": case.threshold_m if case.option == 2 else math.nan,
            "run": int(row["seed"]),
        }
        for col in COLUMNS:
            rec[col] = number_of(row.get(f"fleet.run.{_RUN_METRIC[col]}"))
        rec["collisions"] = number_of(row.get("fleet.collisions"))
        rec["plan_ms"] = number_of(row.get("fleet.run.plan_ms_mean"))
        rec["collisions_vehicle"] = number_of(row.get("fleet.collisions_vehicle"))
        rec["collisions_solid"] = number_of(row.get("fleet.collisions_solid"))
        rec["reached"] = number_of(row.get("fleet.run.reached"))
        rec["divergences"] = number_of(row.get("fleet.run.divergences"))
        rec["status"] = row.get("status")
        rec["passed"] = bool(row.get("passed"))
        rec["error"] = last_error_line(row)
        out.append(rec)
    order = {c: i for i, c in enumerate(CASES)}
    out.sort(
        key=lambda r: (order[r["case"]], r["drones"], r["obstacles"], r["d_min_m"],
                       0.0 if math.isnan(r["threshold_m"]) else r["threshold_m"],
                       r["planner"], r["run"])
    )  # fmt: skip
    return pa.Table.from_pylist(out)


def run_experiment(
    cfg: Seed001Config,
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
    from harness.experiments.seed001_report import write_report

    source = Path(__file__).with_name("seed001.py")
    plan = sweep_plan(cfg, source)
    config = {
        "quick": cfg.quick, "table_runs": list(cfg.table_runs), "sweep_runs": list(cfg.sweep_runs),
        "sweep_drones": list(cfg.sweep_drones), "safe_distances_m": list(cfg.safe_distances_m),
        "obstacles": list(cfg.obstacles), "thresholds_m": list(cfg.thresholds_m),
        "fig13_obstacles": list(cfg.fig13_obstacles), "table2": [list(r) for r in cfg.table2],
        "arena_m": ARENA_M, "zone_separation_m": ZONE_SEPARATION_M, "spacing_m": SPACING_M,
        "decision_hz": DECISION_HZ, "turn_rate_deg_s": TURN_RATE_DEG_S,
    }  # fmt: skip
    return run_plan(
        plan, out_dir, execute=execute, tabulate=lambda t: results_table(t, cfg, source),
        report=lambda results, out, say_: write_report(results, cfg, out, say_), config=config,
        quick=cfg.quick, workers=workers, scheduler=scheduler, console=console, say=say,
    )  # fmt: skip
