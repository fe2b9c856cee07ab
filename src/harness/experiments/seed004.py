"""Seed 004 reproduced: MCO Plan against Boustrophedon and K-means on three workspaces.

``swarmsitl experiment seed004`` runs, on the sweep machinery (Dask, one row per trial, resume),
one swarm-fidelity scenario per workspace x planner x fleet size x seed: heterogeneous x500s
take off from the workspace's take-off point, each runs the MCO role
(``companion.scripts.mco_plan``: the whole plan, its own task) and flies its tour. The table
(``results.parquet``) has one row per run; ``tables.md`` sets our means and 95 % intervals beside
every number the paper prints; the plots show the partitions, the battery per agent and the
links over time. docs/seed004.md gives every choice.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
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
ROLE = "mav"
MODULE = "companion.scripts.mco_plan"
PLANNERS = ("mco_firefly", "mco_zigzag", "boustrophedon", "kmeans")
"""The planners compared (``companion.planning.mco.plan.PLANNERS``)."""
LINK_RANGE_FRACTION = 0.25
"""R = a quarter of the workspace's diagonal (Sec. 5.2)."""
RESERVE_SOC = 0.15
"""Charge kept in reserve when a vehicle's flight time is stated (PX4's BAT_LOW_THR)."""


@dataclass(frozen=True)
class Case:
    """One of the paper's workspaces."""

    name: str
    world: str
    """The world file (``example:NAME``)."""
    max_n: int
    """The largest fleet the paper flies there (Boustrophedon's cell count, Sec. 5)."""
    area_ha: float
    """The paper's area, ha."""


CASES = (
    Case("rejoya", "example:mco_rejoya", 12, 70.0),
    Case("urban", "example:mco_urban", 10, 54.0),
    Case("naranjos", "example:mco_naranjos", 7, 27.0),
)

FLEET_CLASSES: dict[str, tuple[float, float, float]] = {
    "hub": (3.0, 3.0, 4000.0),
    "relay": (2.0, 3.0, 4500.0),
    "worker": (1.0, 1.0, 5000.0),
}
"""Vehicle class -> (decision capacity, communication skill, pack capacity mAh). Table 4 (the
sources of each score) is missing from the text: a class per role of Table 2 (Master: high
decision and communication, intermediate flight time; Coordinator: middle decision, high
communication; Operator: low both, the longest flight time) on the x500's 4S pack sizes."""


@dataclass(frozen=True)
class Seed004Config:
    """What one experiment run covers."""

    quick: bool
    seeds: tuple[int, ...]
    n_values: dict[str, tuple[int, ...]]
    """Workspace -> the fleet sizes flown."""
    fa_population: int
    fa_iterations: int
    step_hz: float = 5.0
    decision_hz: float = 1.0
    cases: tuple[Case, ...] = CASES
    planners: tuple[str, ...] = PLANNERS
    extra_args: dict[str, Any] = field(default_factory=dict)
    """More role args for every trial (tests: a smaller camera grid)."""


def make_config(quick: bool, seeds: int | None = None) -> Seed004Config:
    """The full run (n = 2..max, 10 seeds) or ``--quick`` (n = max / 2 and max, 2 seeds).

    The Firefly TSP runs 50 fireflies for 400 iterations (40 x 200 quick), not the paper's
    500 x 5000 (its 100-cell benchmark: ``benchmarks/firefly_tsp.py``): the sub-areas here hold
    up to 1800 waypoints, where 100 x 1000 already costs about a minute per run on a loaded
    core; docs/seed004.md gives the cost.
    """
    if seeds is not None and seeds < 1:
        raise ExperimentError(f"--seeds: {seeds}; at least 1")
    if quick:
        n_values = {c.name: (c.max_n // 2, c.max_n) for c in CASES}
        return Seed004Config(True, tuple(range(seeds or 2)), n_values, 40, 200)
    n_values = {c.name: tuple(range(2, c.max_n + 1)) for c in CASES}
    return Seed004Config(False, tuple(range(seeds or 10)), n_values, 50, 400)


def fleet_classes(n: int) -> list[str]:
    """Vehicle classes of an n-vehicle fleet, in vehicle order.

    One hub and up to four relays per 16 vehicles (a partition level, Sec. 4.2.2), workers for
    the rest; the order is a fixed shuffle so that vehicle index and class are unrelated.
    """
    levels = n // 16 + 1
    hubs = min(levels, n)
    relays = min(4 * levels, n - hubs)
    kinds = ["hub"] * hubs + ["relay"] * relays + ["worker"] * (n - hubs - relays)
    order = np.random.default_rng(1000 + n).permutation(n)
    return [kinds[k] for k in order]


@functools.lru_cache(maxsize=8)
def _hover_endurance_s(capacity_mah: float) -> float:
    """Hover time of an x500 with this pack down to RESERVE_SOC, s (the flight-time trait)."""
    from harness.swarm.run import hover_power_w
    from sitl.power.battery import endurance_to_reserve_s
    from sitl.power.loads import PayloadLoads
    from sitl.power.propulsion import load_power_spec
    from sitl.vehicles.multirotor import load_airframe

    airframe = load_airframe(AIRFRAME)
    power = load_power_spec(airframe.yaml_path)
    pack = replace(power.battery, capacity_mah=capacity_mah)
    watts = hover_power_w(airframe, power) + PayloadLoads.preset("seed000_companion").total_w
    return float(endurance_to_reserve_s(pack, watts, RESERVE_SOC, dt_s=5.0))


def fleet_group(n: int) -> dict[str, Any]:
    """The scenario's fleet entry for n heterogeneous x500s (battery and traits per vehicle)."""
    kinds = fleet_classes(n)
    endurance = {k: round(_hover_endurance_s(c[2]), 1) for k, c in FLEET_CLASSES.items()}
    return {
        "role": ROLE,
        "count": n,
        "airframe": AIRFRAME,
        "battery_capacity_mah": [FLEET_CLASSES[k][2] for k in kinds],
        "traits": {
            "decision": [FLEET_CLASSES[k][0] for k in kinds],
            "communication": [FLEET_CLASSES[k][1] for k in kinds],
            "flight_time_s": [endurance[k] for k in kinds],
        },
    }


@functools.lru_cache(maxsize=8)
def _world_diagonal_m(case: Case) -> float:
    import worlds
    from worlds.examples import world_path

    world = worlds.build(worlds.load_world(world_path(case.world)))
    x0, y0, x1, y1 = world.boundary.bounds
    return math.hypot(x1 - x0, y1 - y0)


def scenario_text(case: Case, n: int, cfg: Seed004Config) -> str:
    """The swarm-fidelity scenario of ``case`` with n vehicles (the planner is a trial value)."""
    args = {"planner": PLANNERS[0], "fa_population": cfg.fa_population,
            "fa_iterations": cfg.fa_iterations} | cfg.extra_args  # fmt: skip
    data = {
        "name": f"seed004-{case.name}-n{n}",
        "description": f"seed 004: {n} x500s cover {case.name} with the MCO role",
        "fidelity": "swarm",
        "swarm": {
            "step_hz": cfg.step_hz,
            "decision_hz": cfg.decision_hz,
            "neighbours": 0,
            "link_range_m": round(LINK_RANGE_FRACTION * _world_diagonal_m(case), 3),
        },
        "seed": 0,
        "duration_s": 7200,
        "world": case.world,
        "spacing_m": 2,
        "fleet": [fleet_group(n)],
        "roles": {ROLE: {"module": MODULE, "args": args}},
        "sensors": {"cameras": False, "rangefinders": False},
        "checks": {"companions_succeeded": True, "landed_and_disarmed": True},
    }
    return yaml.safe_dump(data, sort_keys=False)


class ExperimentError(ValueError):
    """An experiment that cannot run (the message names the workspace, planner and n)."""


def check_inputs(cfg: Seed004Config) -> None:
    """Every (workspace, planner, n) can be planned (ExperimentError naming it, before any run)."""
    import worlds
    from companion.planning.mco.plan import McoParams, check_fleet_size
    from companion.planning.mco.role import workspace_of
    from worlds.examples import world_path

    for case in cfg.cases:
        world = worlds.build(worlds.load_world(world_path(case.world)))
        workspace, _ = workspace_of(world)
        for planner in cfg.planners:
            params = McoParams(planner=planner, **cfg.extra_args)
            for n in cfg.n_values[case.name]:
                try:
                    check_fleet_size(workspace, params, n)
                except ValueError as exc:
                    raise ExperimentError(f"{case.name}, {planner}, n={n}: {exc}") from exc


def sweep_plan(cfg: Seed004Config, source: Path) -> SweepPlan:
    """Every trial of the experiment as one sweep plan (``harness.sweep``)."""
    trials = []
    for case in cfg.cases:
        for n in cfg.n_values[case.name]:
            text = scenario_text(case, n, cfg)
            for planner in cfg.planners:
                values = {"world": case.world, "fleet.0.count": n,
                          "roles.mav.args.planner": planner}  # fmt: skip
                for seed in cfg.seeds:
                    trials.append(
                        Trial(trial_id(text, values, seed), str(source), text,
                              tuple(values.items()), seed)
                    )  # fmt: skip
    grid = {
        "world": [c.world for c in cfg.cases],
        "fleet.0.count": sorted({n for ns in cfg.n_values.values() for n in ns}),
        "roles.mav.args.planner": list(cfg.planners),
    }
    spec = SweepSpec(scenario=str(source), grid=grid, seeds=list(cfg.seeds))
    return SweepPlan(spec, "seed004", None, source, "", "swarm", tuple(trials))


ROLE_CODES = {"master": 0, "coordinator": 1, "operator": 2}
"""Role of an agent as a number in the table (0 Master, 1 Coordinator, 2 Operator)."""


def execute(scenario: Any, seed: int, run_dir: Path | None, timeout: float | None) -> dict:
    """A trial's body: the swarm run, and each agent's battery, links and role as numbers."""
    from harness.swarm.run import run_swarm

    report = run_swarm(scenario, seed, None)
    report["fleet"]["seed004"] = agent_numbers(report)
    return report


def agent_numbers(report: dict) -> dict[str, float]:
    """Numbers of the run a table needs besides the fleet's (per agent, and the plan's)."""
    out: dict[str, float] = {}
    plan: dict[str, float] = {}
    for k, (_, entry) in enumerate(sorted(report["vehicles"].items(), key=_vehicle_key), 1):
        companion = entry.get("companion") or {}
        out[f"battery_agent_{k}"] = number_of(entry.get("battery_remaining"))
        out[f"links_agent_{k}"] = number_of(entry.get("links_total"))
        role = (companion.get("role") or {}).get("value")
        out[f"role_agent_{k}"] = float(ROLE_CODES.get(str(role), math.nan))
        out[f"waypoints_agent_{k}"] = number_of(companion.get("task_waypoints"))
        out[f"airborne_agent_{k}"] = number_of(entry.get("airborne_time"))
        for name in ("plan_waypoints", "heterogeneity_std"):
            if name in companion:
                plan[name] = number_of(companion[name])
    out["waypoints"] = plan.get("plan_waypoints", math.nan)
    out["heterogeneity_std_pct"] = plan.get("heterogeneity_std", math.nan)
    return out


def _vehicle_key(item: tuple[str, Any]) -> int:
    return int(item[0].removeprefix("vehicle"))


COLUMNS = {
    "fleet.battery_remaining_mean": "mean_remaining_battery_pct",
    "fleet.battery_remaining_min": "min_remaining_battery_pct",
    "fleet.mission_time": "mission_time_s",
    "fleet.links_per_agent_mean": "links_per_agent_mean",
    "fleet.links_per_step_mean": "links_per_step_mean",
    "fleet.active_max": "active_max",
    "fleet.seed004.heterogeneity_std_pct": "heterogeneity_std_pct",
    "fleet.seed004.waypoints": "waypoints",
}
"""Sweep column -> the experiment's column."""


def results_table(sweep: pa.Table, cfg: Seed004Config) -> pa.Table:
    """One row per run: workspace, planner, n, seed, the issue's metrics, per-agent numbers."""
    rows = sweep.to_pylist()
    by_world = {c.world: c.name for c in cfg.cases}
    n_max = max(c.max_n for c in cfg.cases)
    out = []
    for row in rows:
        rec: dict[str, Any] = {
            "workspace": by_world.get(row.get("world"), str(row.get("world"))),
            "planner": row.get("roles.mav.args.planner"),
            "n": int(row.get("fleet.0.count") or 0),
            "seed": int(row["seed"]),
            "status": row.get("status"),
            "passed": bool(row.get("passed")),
        }
        for src, dst in COLUMNS.items():
            rec[dst] = number_of(row.get(src))
        for k in range(1, n_max + 1):
            for what in ("battery", "links", "role", "waypoints", "airborne"):
                rec[f"{what}_agent_{k}"] = number_of(row.get(f"fleet.seed004.{what}_agent_{k}"))
        waypoints = [rec[f"waypoints_agent_{k}"] for k in range(1, rec["n"] + 1)]
        rec["heterogeneity_std_waypoints"] = (
            float(np.std(waypoints)) if waypoints and all(map(math.isfinite, waypoints))
            else math.nan
        )  # fmt: skip
        rec["error"] = last_error_line(row)
        out.append(rec)
    order = {c.name: i for i, c in enumerate(cfg.cases)}
    out.sort(key=lambda r: (order.get(r["workspace"], 99), PLANNERS.index(r["planner"])
                            if r["planner"] in PLANNERS else 99, r["n"], r["seed"]))  # fmt: skip
    return pa.Table.from_pylist(out)


def run_experiment(
    cfg: Seed004Config,
    out_dir: Path,
    *,
    workers: int = 2,
    scheduler: str | None = None,
    console: Any = None,
    say: Callable[[str], None] = print,
) -> int:
    """Run (or resume) the experiment into ``out_dir``; print the tables' summary and RESULT.

    Returns the exit status: 0 when every trial ran and passed its checks, 1 otherwise.

    Raises:
        ExperimentError: a case cannot be planned (``check_inputs``): nothing ran.
    """
    from harness.experiments.pipeline import run_plan
    from harness.experiments.seed004_report import write_report

    check_inputs(cfg)
    plan = sweep_plan(cfg, Path(__file__).with_name("seed004.py"))
    config = {"quick": cfg.quick, "seeds": list(cfg.seeds), "n_values": cfg.n_values,
              "fa_population": cfg.fa_population, "fa_iterations": cfg.fa_iterations}  # fmt: skip
    return run_plan(
        plan, out_dir, execute=execute, tabulate=lambda t: results_table(t, cfg),
        report=lambda results, out, say_: write_report(results, cfg, out, say_), config=config,
        quick=cfg.quick, workers=workers, scheduler=scheduler, console=console, say=say,
    )  # fmt: skip
