"""Seed 003's plots: each response against the communication range, per scale and solution.

One figure per response (optimality gap, convergence steps, execution time): a panel per scale
AT, the range CL on x, a line per solution with its mean and 95 % interval over the runs, and
the paper's means (Tables 1-3) as hollow markers of the same colour.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from harness.experiments.seed003_report import (
    LABEL,
    PAPER_RANGES,
    PAPER_TABLES,
    TITLES,
    _values,
)
from harness.experiments.stats import mean_ci95

COLOURS = {"ica": "tab:blue", "gbaa": "tab:orange", "icf": "tab:green"}


def write_plots(rows: list[dict], cfg: Any, out_dir: Path) -> list[Path]:
    """``<response>.png`` for each response under ``out_dir``; returns the files."""
    out_dir.mkdir(parents=True, exist_ok=True)
    files = []
    for metric, (number, title, _) in TITLES.items():
        fig, axes = plt.subplots(1, len(cfg.scales), figsize=(4.2 * len(cfg.scales), 3.6),
                                 squeeze=False, sharey=False)  # fmt: skip
        for ax, n in zip(axes[0], cfg.scales, strict=True):
            for alg in cfg.algorithms:
                xs, ys, hs = [], [], []
                for f in cfg.ranges:
                    mean, half, count = mean_ci95(
                        _values(rows, metric, algorithm=alg, agents=n, range_frac=f)
                    )
                    if count:
                        xs.append(f)
                        ys.append(mean)
                        hs.append(half if half == half else 0.0)
                colour = COLOURS.get(alg, "grey")
                ax.errorbar(xs, ys, yerr=hs, marker="o", capsize=3, color=colour,
                            label=f"{LABEL.get(alg, alg)} (ours)")  # fmt: skip
                printed = PAPER_TABLES[metric].get((alg, n))
                if printed:
                    ax.plot(
                        PAPER_RANGES, [m for m, _ in printed], linestyle=":", marker="o",
                        mfc="none", color=colour, label=f"{LABEL.get(alg, alg)} (paper)",
                    )  # fmt: skip
            ax.set_title(f"{n} agents, {n} tasks")
            ax.set_xlabel("communication range / D")
            ax.set_xticks(list(cfg.ranges))
            ax.grid(alpha=0.3)
        axes[0][0].set_ylabel(title)
        axes[0][-1].legend(fontsize=7)
        fig.suptitle(f"Seed 003, {number}: {title}")
        fig.tight_layout()
        path = out_dir / f"{metric}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        files.append(path)
    return files
