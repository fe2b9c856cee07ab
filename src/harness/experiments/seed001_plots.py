"""Seed 001's plots, laid out as the paper's figures: each response against the swept level.

* ``safe_distance.png`` (Figs. 3-5): PQ, AD, FT against the swarm size, a line per D_min (ACO
  solid, A* dashed);
* ``obstacles.png`` (Figs. 6, 8, 9): PQ, FT, CF against the drum count, a line per swarm size;
* ``threshold.png`` (Figs. 10-12): PQ, FT, FC against the threshold, a line per swarm size;
* ``fig13.png`` (Fig. 13): FT, AD, PQ, CF, FC against the drum count, 20 UAVs;
* ``table2.png`` (Table 2): each column against the swarm size, ours with its 95 % interval
  and the paper's printed values as hollow markers.

Every point is a mean over the runs with its 95 % Student-t interval.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from harness.experiments.seed001_report import PAPER_TABLE2, TABLE2_COLUMNS, values
from harness.experiments.stats import mean_ci95

NAMES = {"pq_pct": "PQ, %", "ad": "AD, divergences per UAV", "ft": "FT (makespan / 60 s)",
         "cf": "CF (Eqs. 9-10)", "fc_pct": "FC, % of the threshold", "mc_pct": "MC, %"}  # fmt: skip


def _line(ax: Any, rows: list[dict], metric: str, xs: list[Any], xkey: str, label: str,
          style: str = "-", **match: Any) -> None:  # fmt: skip
    px, py, ph = [], [], []
    for x in xs:
        mean, half, n = mean_ci95(values(rows, metric, **{xkey: x}, **match))
        if n:
            px.append(x)
            py.append(mean)
            ph.append(half if half == half else 0.0)
    if px:
        ax.errorbar(px, py, yerr=ph, marker="o", capsize=3, linestyle=style, label=label)


def _figure(rows: list[dict], case: str, metrics: tuple[str, ...], xkey: str, xlabel: str,
            lines: list[tuple[str, str, dict]], title: str, path: Path) -> Path | None:  # fmt: skip
    mine = [r for r in rows if r["case"] == case]
    if not mine:
        return None
    xs = sorted({r[xkey] for r in mine})
    fig, axes = plt.subplots(1, len(metrics), figsize=(4.2 * len(metrics), 3.6), squeeze=False)
    for ax, metric in zip(axes[0], metrics, strict=True):
        for label, style, match in lines:
            _line(ax, mine, metric, xs, xkey, label, style, **match)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(NAMES[metric])
        ax.grid(alpha=0.3)
    axes[0][-1].legend(fontsize=7)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def write_plots(rows: list[dict], cfg: Any, out_dir: Path) -> list[Path]:
    """The figures above under ``out_dir``; returns the files written."""
    out_dir.mkdir(parents=True, exist_ok=True)
    files: list[Path | None] = []
    sizes = sorted({r["drones"] for r in rows if r["case"] in ("obstacles", "threshold")})
    files.append(_figure(
        rows, "safe_distance", ("pq_pct", "ad", "ft"), "drones", "UAVs",
        [(f"D_min {d:g} m{' A*' if p == 'astar' else ''}", "--" if p == "astar" else "-",
          {"d_min_m": d, "planner": p})
         for d in cfg.safe_distances_m for p in ("aco", "astar")],
        "Seed 001, Figs. 3-5: safe distance (option 1, no obstacles)",
        out_dir / "safe_distance.png",
    ))  # fmt: skip
    files.append(_figure(
        rows, "obstacles", ("pq_pct", "ft", "cf"), "obstacles", "drums",
        [(f"{n} UAVs", "-", {"drones": n, "planner": "aco"}) for n in sizes],
        "Seed 001, Figs. 6, 8, 9: obstacles (option 1, D_min 1 m, ACO)",
        out_dir / "obstacles.png",
    ))  # fmt: skip
    files.append(_figure(
        rows, "threshold", ("pq_pct", "ft", "fc_pct"), "threshold_m", "threshold, m",
        [(f"{n} UAVs", "-", {"drones": n}) for n in sizes],
        "Seed 001, Figs. 10-12: formation threshold (option 2, D_min 1 m)",
        out_dir / "threshold.png",
    ))  # fmt: skip
    files.append(_figure(
        rows, "fig13", ("ft", "ad", "pq_pct", "cf", "fc_pct"), "obstacles", "drums",
        [("20 UAVs", "-", {})], "Seed 001, Fig. 13: 20 UAVs, threshold 0.1 m",
        out_dir / "fig13.png",
    ))  # fmt: skip
    table = [r for r in rows if r["case"] == "table2"]
    if table:
        cols = [c for c, _, _ in TABLE2_COLUMNS]
        fig, axes = plt.subplots(1, len(cols), figsize=(3.6 * len(cols), 3.4), squeeze=False)
        drones = sorted({r["drones"] for r in table})
        for ax, col in zip(axes[0], cols, strict=True):
            _line(ax, table, col, drones, "drones", "ours")
            printed = sorted((n, v[col]) for (_, n), v in PAPER_TABLE2.items())
            ax.plot([n for n, _ in printed], [v for _, v in printed], linestyle=":",
                    marker="o", mfc="none", color="black", label="paper")  # fmt: skip
            ax.set_xlabel("UAVs (obstacles as Table 2)")
            ax.set_ylabel(NAMES[col])
            ax.grid(alpha=0.3)
        axes[0][-1].legend(fontsize=7)
        fig.suptitle("Seed 001, Table 2: option 2, threshold 0.1 m, D_min 1 m")
        fig.tight_layout()
        path = out_dir / "table2.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        files.append(path)
    return [f for f in files if f is not None]
