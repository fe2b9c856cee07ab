"""Seed 004's plots: partition maps, battery per agent, links over time, metrics against n.

The maps and the time series come from one run per workspace and planner at the largest fleet
and the first seed, run again here with its files (a sweep's trials keep only their rows).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from harness.experiments.seed004_report import LABEL, _mean, _select


def _representative(cfg: Any, case: Any, planner: str, runs_dir: Path) -> tuple[Any, dict]:
    """The plan and the report of the first seed's run of ``case`` at its largest n."""
    from harness.experiments.seed004 import scenario_text
    from harness.swarm.run import run_swarm
    from harness.sweep.trial import Trial, build_scenario

    n = max(cfg.n_values[case.name])
    seed = cfg.seeds[0]
    values = (("roles.mav.args.planner", planner),)
    trial = Trial("", str(Path(__file__)), scenario_text(case, n, cfg), values, seed)
    scenario = build_scenario(trial)
    run_dir = runs_dir / f"{case.name}-{planner}"
    report = run_swarm(scenario, seed, run_dir)
    plan = _plan(run_dir, scenario, seed)
    return plan, report


def _plan(run_dir: Path, scenario: Any, seed: int) -> Any:
    """The plan the run flew, computed again from its inputs as its vehicles computed it."""
    from companion.planning.mco.plan import McoParams
    from companion.planning.mco.role import cached_plan, fleet_bidders
    from companion.role_params import params_from_mapping

    role = next(iter(scenario.spec.roles))
    params = params_from_mapping(McoParams, scenario.spec.roles[role].args)
    bidders = fleet_bidders(scenario.fleet_entries(), role, scenario.spec.n_vehicles)
    return cached_plan(str(run_dir / "world.yaml"), params, bidders, seed)


def draw_plots(rows: list[dict], cfg: Any, plots_dir: Path, out_dir: Path) -> list[Path]:
    """Every plot; returns their paths."""
    paths = []
    reps: dict[tuple[str, str], tuple[Any, dict]] = {}
    for case in cfg.cases:
        for planner in cfg.planners:
            reps[case.name, planner] = _representative(cfg, case, planner, out_dir / "runs")
    paths.append(_partition_maps(reps, cfg, plots_dir / "partitions.png"))
    paths.append(_battery_per_agent(reps, cfg, plots_dir / "battery_per_agent.png"))
    paths.append(_links_over_time(reps, cfg, out_dir / "runs", plots_dir / "links_over_time.png"))
    paths.append(_by_n(rows, cfg, plots_dir / "by_fleet_size.png"))
    return paths


def _partition_maps(reps: dict, cfg: Any, path: Path) -> Path:
    cases, planners = cfg.cases, cfg.planners
    fig, axes = plt.subplots(len(cases), len(planners), figsize=(4.2 * len(planners),
                             3.6 * len(cases)), squeeze=False)  # fmt: skip
    for i, case in enumerate(cases):
        for j, planner in enumerate(planners):
            ax = axes[i][j]
            plan, _ = reps[case.name, planner]
            xy = plan.grid.waypoints_xy_m
            cmap = plt.get_cmap("tab20")
            ax.scatter(xy[:, 0], xy[:, 1], s=2, c=[cmap(k % 20) for k in plan.partition.labels])
            for task in plan.tasks:
                tour = task.waypoints_xy_m
                ax.plot(tour[:, 0], tour[:, 1], lw=0.3, color="k", alpha=0.4)
                site = plan.partition.sites_xy_m[task.sub_area]
                ax.annotate(str(task.role)[0].upper(), site, fontsize=7, ha="center",
                            weight="bold")  # fmt: skip
            home = plan.partition.takeoff_xy_m.reshape(-1, 2)
            ax.plot(home[:, 0], home[:, 1], "r^", ms=6)
            ax.set_aspect("equal")
            ax.set_title(f"{case.name}, {LABEL[planner]}, n={len(plan.tasks)}", fontsize=9)
            ax.tick_params(labelsize=6)
    fig.suptitle("Sub-areas (colours), tours (lines), roles (M/C/O at the sites), take-off (red)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _battery_per_agent(reps: dict, cfg: Any, path: Path) -> Path:
    fig, axes = plt.subplots(1, len(cfg.cases), figsize=(5.5 * len(cfg.cases), 3.8),
                             squeeze=False)  # fmt: skip
    width = 0.8 / len(cfg.planners)
    for i, case in enumerate(cfg.cases):
        ax = axes[0][i]
        for j, planner in enumerate(cfg.planners):
            _, report = reps[case.name, planner]
            vehicles = sorted(report["vehicles"].items(), key=lambda kv: int(kv[0][7:]))
            values = [float(v["battery_remaining"]["value"]) for _, v in vehicles]
            x = np.arange(1, len(values) + 1) + (j - (len(cfg.planners) - 1) / 2) * width
            ax.bar(x, values, width, label=LABEL[planner])
        ax.set_xlabel("agent (vehicle)")
        ax.set_ylabel("remaining battery, %")
        ax.set_ylim(0, 100)
        ax.set_title(f"{case.name}, n={max(cfg.n_values[case.name])}, seed {cfg.seeds[0]}")
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _links_over_time(reps: dict, cfg: Any, runs_dir: Path, path: Path) -> Path:
    fig, axes = plt.subplots(2, len(cfg.cases), figsize=(5.5 * len(cfg.cases), 6),
                             squeeze=False, sharex="col")  # fmt: skip
    for i, case in enumerate(cfg.cases):
        for planner in cfg.planners:
            tracks = np.load(runs_dir / f"{case.name}-{planner}" / "tracks.npz")
            t = tracks["time_s"]
            axes[0][i].plot(t, tracks["links_mean"], lw=0.8, label=LABEL[planner])
            axes[1][i].plot(t, tracks["active"], lw=0.8, label=LABEL[planner])
        axes[0][i].set_title(f"{case.name}, n={max(cfg.n_values[case.name])}")
        axes[0][i].set_ylabel("links per active agent")
        axes[1][i].set_ylabel("active agents")
        axes[1][i].set_xlabel("simulated time, s")
        axes[0][i].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _by_n(rows: list[dict], cfg: Any, path: Path) -> Path:
    metrics = (
        ("heterogeneity_std_pct", "heterogeneity std, % of waypoints"),
        ("mean_remaining_battery_pct", "mean remaining battery, %"),
        ("mission_time_s", "mission time, s"),
        ("links_per_agent_mean", "links per agent (total)"),
    )
    size = (5 * len(cfg.cases), 3 * len(metrics))
    fig, axes = plt.subplots(len(metrics), len(cfg.cases), figsize=size, squeeze=False)
    for i, case in enumerate(cfg.cases):
        ns = cfg.n_values[case.name]
        for k, (key, label) in enumerate(metrics):
            ax = axes[k][i]
            for planner in cfg.planners:
                ys = [_mean(r[key] for r in _select(rows, workspace=case.name, planner=planner,
                                                    n=n)) for n in ns]  # fmt: skip
                ax.plot(ns, [y if math.isfinite(y) else np.nan for y in ys], "o-", ms=3,
                        label=LABEL[planner])  # fmt: skip
            ax.set_ylabel(label, fontsize=8)
            if k == 0:
                ax.set_title(case.name)
            if k == len(metrics) - 1:
                ax.set_xlabel("fleet size n")
        axes[0][i].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
