"""Seed 004's tables and plots: our means and 95 % intervals beside every number the paper prints.

The paper's numbers (Campo, Ledezma, Corrales, Drones 2022, 6, 181) are quoted from its text as
the digest (``004_001.md`` §5) reads them; tables that did not survive the text conversion are
not invented. Every number of ours is computed here from ``results.parquet``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import pyarrow as pa

from harness.experiments.stats import format_ci, mean_ci95

PAPER_BATTERY_MEAN_PCT = {
    "rejoya": {"boustrophedon": 90.77, "kmeans": 87.76, "mco_zigzag": 89.93},
    "urban": {"boustrophedon": 75.55, "kmeans": 79.65, "mco_zigzag": 83.96},
    "naranjos": {"boustrophedon": 75.33, "kmeans": 86.83, "mco_zigzag": 86.96},
}
"""Mean % remaining battery at mission end, zigzag paths (Sec. 5.2 text)."""
PAPER_WORST_DRAIN_PCT = {"mco_zigzag": 40.0, "boustrophedon": 60.0, "kmeans": 22.63}
"""Largest single-agent battery use, % (Sec. 5.2: MCO "without exceeding 40 %", Boustrophedon
"an upper reduction of 60 %", K-means 22.63 %)."""
PAPER_LINKS_AVERAGE = {
    "rejoya": {"boustrophedon": 70.7, "mco_zigzag": 130.2},
    "urban": {"boustrophedon": 47.9, "mco_zigzag": 70.1},
    "naranjos": {"boustrophedon": 20.3, "mco_zigzag": 30.7},
}
"""Links average (Fig. 20): the mean over agents of their total links (Table 12's rows average
to 70.75 and 130.25)."""
PAPER_TABLE_12 = {
    "boustrophedon": [49, 102, 91, 137, 66, 22, 105, 62, 56, 39, 56, 64],
    "kmeans": [337, 70, 57, 107, 123, 55, 224, 73, 58, 58, 123, 95],
    "mco_zigzag": [146, 105, 141, 243, 124, 55, 140, 125, 57, 75, 73, 279],
}
"""Total links per agent, Rejoya, n = 12 (Table 12)."""
PAPER_TABLE_13 = {
    "boustrophedon": [72, 98, 46, 20, 30, 58, 73, 58],
    "kmeans": [49, 52, 50, 54, 80, 102, 41, 34, 57],
    "mco_zigzag": [125, 85, 97, 45, 130, 60, 35, 51, 47, 25],
}
"""Total links per agent, Urban, n = 10 (Table 13; unreadable cells left out)."""
PAPER_HETEROGENEITY_MAX_PCT = {"rejoya": 7.5, "urban": 9.2, "naranjos": 7.9}
"""Largest std of the sub-areas' waypoint counts with MCO, % (Fig. 15 text)."""
PAPER_FA_ENERGY_GAIN_PCT = {"rejoya": 10.0, "urban": 2.5, "naranjos": 1.9}
"""Energy gained by Firefly over zigzag tours, "up to", % (Sec. 5.3, Fig. 22)."""
PAPER_FA_RELEASED_PCT = {"rejoya": 25.0, "urban": 9.0, "naranjos": 2.0}
"""Active MAVs released earlier with Firefly tours, % (Sec. 5.3, Tables 15-17)."""
PAPER_LINKS_PER_STEP = "4-5"
"""MCO's links per time unit (Sec. 5.2)."""
LABEL = {
    "mco_firefly": "MCO + Firefly",
    "mco_zigzag": "MCO + zigzag",
    "boustrophedon": "Boustrophedon",
    "kmeans": "K-means",
}


def _select(rows: list[dict], **match: Any) -> list[dict]:
    return [r for r in rows if all(r.get(k) == v for k, v in match.items())]


def _ci(values: Iterable[float], digits: int = 1) -> str:
    mean, half, _ = mean_ci95(values)
    return format_ci(mean, half, digits)


def _mean(values: Iterable[float]) -> float:
    return mean_ci95(values)[0]


def _paper(value: float | None, digits: int = 1) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def write_report(results: pa.Table, cfg: Any, out_dir: Path, say: Callable[[str], None]) -> str:
    """tables.md and plots/ in ``out_dir``; returns the RESULT line."""
    rows = [r for r in results.to_pylist() if r["status"] == "ok"]
    lines = _tables(rows, cfg)
    (out_dir / "tables.md").write_text("\n".join(lines) + "\n")
    plots_dir = out_dir / "plots"
    plots_dir.mkdir(exist_ok=True)
    try:
        from harness.experiments.seed004_plots import draw_plots

        for path in draw_plots(rows, cfg, plots_dir, out_dir):
            say(f"plot: {path}")
    except Exception as exc:  # a failed plot must not cost the tables
        say(f"plots not drawn: {exc!r}")
    return _result_line(rows, cfg, len(results))


def _tables(rows: list[dict], cfg: Any) -> list[str]:
    seeds = len(cfg.seeds)
    out = [
        "# Seed 004 (MCO Plan) reproduced: our results beside the paper's",
        "",
        f"{'Quick run' if cfg.quick else 'Full run'}: {seeds} seed(s) per point; means ± 95 % "
        "Student-t intervals over seeds. `-`: the paper prints no number. Every choice behind "
        "these numbers: docs/seed004.md.",
        "",
    ]
    maxn = {c.name: max(cfg.n_values[c.name]) for c in cfg.cases}
    # --- battery
    out += [
        "## Remaining battery at mission end, % (Sec. 5.2, zigzag paths; ours at the largest n)",
        "",
        "| workspace | n | planner | ours: mean | paper: mean | ours: worst agent "
        "| paper: worst agent |",
        "|---|---|---|---|---|---|---|",
    ]
    for c in cfg.cases:
        for p in cfg.planners:
            sel = _select(rows, workspace=c.name, planner=p, n=maxn[c.name])
            worst = PAPER_WORST_DRAIN_PCT.get(p)
            out.append(
                f"| {c.name} | {maxn[c.name]} | {LABEL[p]} | "
                f"{_ci(r['mean_remaining_battery_pct'] for r in sel)} | "
                f"{_paper(PAPER_BATTERY_MEAN_PCT[c.name].get(p), 2)} | "
                f"{_ci(r['min_remaining_battery_pct'] for r in sel)} | "
                f"{'-' if worst is None else f'≥ {100 - worst:.2f}'} |"
            )
    out.append("")
    # --- links average
    out += [
        "## Links average: mean over agents of their total links (Fig. 20; ours at the largest n, "
        "one count per agent per simulated second)",
        "",
        "| workspace | n | planner | ours | paper | ours: links per active agent per s | paper |",
        "|---|---|---|---|---|---|---|",
    ]
    for c in cfg.cases:
        for p in cfg.planners:
            sel = _select(rows, workspace=c.name, planner=p, n=maxn[c.name])
            paper_step = PAPER_LINKS_PER_STEP if p.startswith("mco") else "-"
            out.append(
                f"| {c.name} | {maxn[c.name]} | {LABEL[p]} | "
                f"{_ci(r['links_per_agent_mean'] for r in sel)} | "
                f"{_paper(PAPER_LINKS_AVERAGE[c.name].get(p))} | "
                f"{_ci((r['links_per_step_mean'] for r in sel), 2)} | {paper_step} |"
            )
    out.append("")
    # --- per-agent links (Tables 12, 13)
    for case_name, n, paper, title in (
        ("rejoya", 12, PAPER_TABLE_12, "Table 12: total links per agent, Rejoya, n = 12"),
        ("urban", 10, PAPER_TABLE_13, "Table 13: total links per agent, Urban, n = 10"),
    ):
        if n not in cfg.n_values.get(case_name, ()):
            continue
        out += [
            f"## {title} (agents ranked by their links, highest first; ours: mean over seeds of "
            "the agent of each rank)",
            "",
            "| planner | | " + " | ".join(str(k) for k in range(1, n + 1)) + " |",
            "|---|---|" + "---|" * n,
        ]
        for p in cfg.planners:
            sel = _select(rows, workspace=case_name, planner=p, n=n)
            ranked = [
                sorted((r[f"links_agent_{k}"] for k in range(1, n + 1)), reverse=True) for r in sel
            ]
            ours = [_mean(run[k] for run in ranked) for k in range(n)] if ranked else []
            out.append(
                f"| {LABEL[p]} | ours | "
                + " | ".join(f"{v:.0f}" if math.isfinite(v) else "-" for v in ours)
                + " |"
            )
            if p in paper:
                theirs = sorted(paper[p], reverse=True)
                cells = [str(v) for v in theirs] + ["-"] * (n - len(theirs))
                out.append(f"| {LABEL[p]} | paper | " + " | ".join(cells) + " |")
        out.append("")
    # --- heterogeneity
    out += [
        "## Heterogeneity: std of the sub-areas' waypoint counts (Fig. 15)",
        "",
        "In % of the workspace's waypoints, the largest over n of the mean over seeds; and in "
        "waypoints, the range over n of the mean.",
        "",
        "| workspace | planner | ours: max std, % | paper: max std, % | ours: std, waypoints "
        "(min-max over n) | paper |",
        "|---|---|---|---|---|---|",
    ]
    paper_abs = {"boustrophedon": "> 100", "kmeans": "2-50"}
    for c in cfg.cases:
        for p in cfg.planners:
            by_n = [
                (_mean(r["heterogeneity_std_pct"] for r in _select(rows, workspace=c.name,
                                                                   planner=p, n=n)),
                 _mean(r["heterogeneity_std_waypoints"] for r in _select(rows, workspace=c.name,
                                                                         planner=p, n=n)))
                for n in cfg.n_values[c.name]
            ]  # fmt: skip
            pct = [a for a, _ in by_n if math.isfinite(a)]
            wp = [b for _, b in by_n if math.isfinite(b)]
            paper_pct = PAPER_HETEROGENEITY_MAX_PCT[c.name] if p.startswith("mco") else None
            out.append(
                f"| {c.name} | {LABEL[p]} | {max(pct):.1f} | {_paper(paper_pct)} | "
                f"{min(wp):.0f}-{max(wp):.0f} | {paper_abs.get(p, '-')} |"
                if pct and wp
                else f"| {c.name} | {LABEL[p]} | - | {_paper(paper_pct)} | - | - |"
            )
    out.append("")
    # --- firefly vs zigzag
    if {"mco_firefly", "mco_zigzag"} <= set(cfg.planners):
        out += [
            "## Firefly against zigzag tours, both on MCO's partition (Sec. 5.3)",
            "",
            "Energy gained: the largest over n of the difference in mean remaining battery "
            "(Firefly - zigzag), percentage points. Mission time saved: at the largest n, "
            "(zigzag - Firefly) / zigzag of the time the last agent landed, %.",
            "",
            "| workspace | ours: energy gained, max over n | paper: up to | ours: mission time "
            "saved at largest n, % | paper: released earlier, % |",
            "|---|---|---|---|---|",
        ]
        for c in cfg.cases:
            gains = []
            for n in cfg.n_values[c.name]:
                fa = _mean(
                    r["mean_remaining_battery_pct"]
                    for r in _select(rows, workspace=c.name, planner="mco_firefly", n=n)
                )
                zz = _mean(
                    r["mean_remaining_battery_pct"]
                    for r in _select(rows, workspace=c.name, planner="mco_zigzag", n=n)
                )
                if math.isfinite(fa) and math.isfinite(zz):
                    gains.append(fa - zz)
            saved = _paired_saving(rows, c.name, maxn[c.name])
            out.append(
                f"| {c.name} | {max(gains):.2f} | {PAPER_FA_ENERGY_GAIN_PCT[c.name]:.1f} | "
                f"{saved} | {PAPER_FA_RELEASED_PCT[c.name]:.0f} |"
                if gains
                else f"| {c.name} | - | {PAPER_FA_ENERGY_GAIN_PCT[c.name]:.1f} | {saved} | "
                f"{PAPER_FA_RELEASED_PCT[c.name]:.0f} |"
            )
        out.append("")
    # --- mission time and battery by n (ours only)
    out += [
        "## Mission time (s) and mean remaining battery (%) by fleet size (ours; the paper shows "
        "these only in Figs. 17-18)",
        "",
        "| workspace | planner | " + " | ".join(
            f"n={n}" for n in sorted({n for ns in cfg.n_values.values() for n in ns})) + " |",
        "|---|---|" + "---|" * len({n for ns in cfg.n_values.values() for n in ns}),
    ]  # fmt: skip
    all_n = sorted({n for ns in cfg.n_values.values() for n in ns})
    for c in cfg.cases:
        for p in cfg.planners:
            cells = []
            for n in all_n:
                sel = _select(rows, workspace=c.name, planner=p, n=n)
                if not sel:
                    cells.append("")
                    continue
                t = _mean(r["mission_time_s"] for r in sel)
                b = _mean(r["mean_remaining_battery_pct"] for r in sel)
                cells.append(f"{t:.0f} s, {b:.0f} %")
            out.append(f"| {c.name} | {LABEL[p]} | " + " | ".join(cells) + " |")
    out.append("")
    return out


def _paired_saving(rows: list[dict], workspace: str, n: int) -> str:
    """Mission time saved by Firefly tours at ``n``, % (mean ± CI over seeds, paired by seed)."""
    fa = {r["seed"]: r["mission_time_s"] for r in
          _select(rows, workspace=workspace, planner="mco_firefly", n=n)}  # fmt: skip
    zz = {r["seed"]: r["mission_time_s"] for r in
          _select(rows, workspace=workspace, planner="mco_zigzag", n=n)}  # fmt: skip
    pairs = [100.0 * (zz[s] - fa[s]) / zz[s] for s in sorted(set(fa) & set(zz)) if zz[s] > 0]
    return _ci(pairs) if pairs else "-"


def _result_line(rows: list[dict], cfg: Any, total: int) -> str:
    """``RESULT key=value ...``: the headline means over the workspaces at their largest n."""
    parts = [f"trials={total}", f"ok={len(rows)}"]
    maxn = {c.name: max(cfg.n_values[c.name]) for c in cfg.cases}
    for p in cfg.planners:
        vals = [
            r["mean_remaining_battery_pct"]
            for c in cfg.cases
            for r in _select(rows, workspace=c.name, planner=p, n=maxn[c.name])
        ]
        links = [
            r["links_per_agent_mean"]
            for c in cfg.cases
            for r in _select(rows, workspace=c.name, planner=p, n=maxn[c.name])
        ]
        het = [r["heterogeneity_std_pct"] for r in _select(rows, planner=p)]
        parts.append(f"battery_pct_{p}={_mean(vals):.2f}")
        parts.append(f"links_per_agent_{p}={_mean(links):.1f}")
        parts.append(f"heterogeneity_std_max_pct_{p}={max(het, default=math.nan):.2f}")
    return "RESULT " + " ".join(parts)
