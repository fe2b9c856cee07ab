"""Seed 003's tables and plots: ours beside every number the paper prints, and its ANOVA.

The paper's numbers (Barnawi, Nicholls, McAllister, Ortiz 2025: Tables 1-3 mean / sd, Tables 4-6
p-values) are quoted as the digest (``002_003.md`` 003 §5) reads them. Ours are computed here
from ``results.parquet``: mean / sd and the 95 % interval per cell; the full-factorial ANOVA of
each response on S x AT x CL (statsmodels OLS, type II sums of squares: the design is balanced,
where types I-III agree) and Tukey's HSD between the solutions.
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from harness.experiments.stats import format_ci, mean_ci95

LABEL = {"ica": "ICA", "gbaa": "GBAA", "icf": "ICF"}
PAPER_TABLES: dict[str, dict[tuple[str, int], list[tuple[float, float]]]] = {
    "optimality_gap": {
        ("ica", 5): [(0.316, 0.202), (0.158, 0.120), (0.145, 0.120)],
        ("ica", 15): [(0.274, 0.078), (0.096, 0.095), (0.080, 0.045)],
        ("ica", 30): [(0.232, 0.051), (0.079, 0.036), (0.071, 0.029)],
        ("gbaa", 5): [(0.292, 0.147), (0.179, 0.103), (0.171, 0.096)],
        ("gbaa", 15): [(0.246, 0.087), (0.125, 0.127), (0.109, 0.055)],
        ("gbaa", 30): [(0.256, 0.042), (0.104, 0.027), (0.090, 0.027)],
        ("icf", 5): [(0.237, 0.171), (0.174, 0.148), (0.164, 0.146)],
        ("icf", 15): [(0.247, 0.114), (0.133, 0.135), (0.117, 0.081)],
        ("icf", 30): [(0.255, 0.057), (0.122, 0.048), (0.110, 0.043)],
    },
    "convergence_steps": {
        ("ica", 5): [(24.16, 9.72), (41.23, 11.19), (43.23, 12.22)],
        ("ica", 15): [(208.03, 60.13), (812.16, 101.04), (816.29, 110.62)],
        ("ica", 30): [(1069.35, 263.80), (4938.42, 449.05), (4964.52, 504.31)],
        ("gbaa", 5): [(7.42, 0.56), (9.55, 1.03), (9.90, 1.04)],
        ("gbaa", 15): [(18.55, 0.57), (26.29, 2.21), (30.10, 2.87)],
        ("gbaa", 30): [(35.42, 1.18), (50.68, 4.55), (57.74, 5.40)],
        ("icf", 5): [(16.81, 3.65), (24.81, 6.80), (13.26, 2.92)],
        ("icf", 15): [(60.87, 17.23), (128.19, 71.79), (37.23, 3.29)],
        ("icf", 30): [(134.48, 50.84), (393.45, 204.17), (70.10, 1.92)],
    },
    "execution_time": {
        ("ica", 5): [(9.04, 2.56), (12.55, 3.29), (12.17, 3.27)],
        ("ica", 15): [(8.96, 2.17), (15.90, 4.62), (15.12, 4.76)],
        ("ica", 30): [(7.85, 2.22), (14.80, 4.80), (15.23, 5.06)],
        ("gbaa", 5): [(6.95, 2.50), (12.23, 3.91), (13.01, 3.86)],
        ("gbaa", 15): [(5.07, 1.37), (13.03, 3.17), (17.38, 5.26)],
        ("gbaa", 30): [(4.40, 1.26), (12.37, 2.26), (17.71, 4.32)],
        ("icf", 5): [(6.29, 2.19), (9.99, 3.06), (10.94, 3.45)],
        ("icf", 15): [(5.50, 1.60), (11.98, 3.57), (13.54, 3.58)],
        ("icf", 30): [(5.28, 1.41), (12.71, 3.23), (14.08, 3.57)],
    },
}
"""Tables 1-3: (mean, sd) per (solution, N) at CL = 0.1D, 0.5D, 1D."""
PAPER_RANGES = (0.1, 0.5, 1.0)
PAPER_ANOVA_P: dict[str, dict[str, str]] = {
    "optimality_gap": {"S": "0.152", "AT": "<0.001", "CL": "<0.001", "S:AT": "0.162",
                       "S:CL": "0.041", "AT:CL": "0.556", "S:AT:CL": "0.522"},
    "convergence_steps": {"S": "<0.001", "AT": "<0.001", "CL": "<0.001", "S:AT": "<0.001",
                          "S:CL": "<0.001", "AT:CL": "<0.001", "S:AT:CL": "<0.001"},
    "execution_time": {"S": "<0.001", "AT": "<0.001", "CL": "<0.001", "S:AT": "0.258",
                       "S:CL": "<0.001", "AT:CL": "<0.001", "S:AT:CL": "0.346"},
}  # fmt: skip
"""Tables 4-6: the p-value of each term."""
TITLES = {
    "optimality_gap": ("Table 1", "Optimality gap (J* - J) / J*", 3),
    "convergence_steps": ("Table 2", "Convergence steps", 1),
    "execution_time": ("Table 3", "Execution time (Eq. 29), s (paper: units not given)", 2),
}
ANOVA_TABLES = {"optimality_gap": "Table 4", "convergence_steps": "Table 5",
                "execution_time": "Table 6"}  # fmt: skip
TERMS = ("S", "AT", "CL", "S:AT", "S:CL", "AT:CL", "S:AT:CL")


def _values(rows: list[dict], metric: str, **match: Any) -> list[float]:
    out = []
    for r in rows:
        if all(r.get(k) == v for k, v in match.items()):
            v = r.get(metric)
            if v is not None and math.isfinite(v):
                out.append(float(v))
    return out


def _cell(values: list[float], digits: int) -> str:
    """``mean / sd [± 95 % half-width]`` of our runs, or ``-``."""
    mean, half, n = mean_ci95(values)
    if n == 0:
        return "-"
    sd = float(np.std(values, ddof=1)) if n > 1 else math.nan
    sd_text = f"{sd:.{digits}f}" if math.isfinite(sd) else "-"
    ci = f" [±{half:.{digits}f}]" if math.isfinite(half) else ""
    return f"{mean:.{digits}f} / {sd_text}{ci}"


def _p(p: float) -> str:
    if not math.isfinite(p):
        return "-"
    return "<0.001" if p < 0.001 else f"{p:.3f}"


def anova(rows: list[dict], metric: str) -> dict[str, tuple[float, float, float]]:
    """Term -> (degrees of freedom, F, p) of ``metric ~ S * AT * CL``.

    ``Error`` -> (df, nan, nan). Empty when the runs do not span two levels of every factor.
    """
    import pandas as pd
    import statsmodels.formula.api as smf
    from statsmodels.stats.anova import anova_lm

    data = pd.DataFrame(
        [
            {"y": r[metric], "S": r["algorithm"], "AT": r["agents"], "CL": r["range_frac"]}
            for r in rows
            if r.get(metric) is not None and math.isfinite(r[metric])
        ]
    )
    if data.empty or min(data[c].nunique() for c in ("S", "AT", "CL")) < 2:
        return {}
    cells = data.groupby(["S", "AT", "CL"]).ngroups
    if len(data) <= cells or float(data["y"].var()) == 0.0:
        return {}  # no residual degrees of freedom (one run per cell), or nothing varies
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = smf.ols("y ~ C(S) * C(AT) * C(CL)", data=data).fit()
        table = anova_lm(model, typ=2)
    out: dict[str, tuple[float, float, float]] = {}
    for index, row in table.iterrows():
        term = str(index).replace("C(", "").replace(")", "")
        name = "Error" if term == "Residual" else term
        out[name] = (float(row["df"]), float(row.get("F", math.nan)),
                     float(row.get("PR(>F)", math.nan)))  # fmt: skip
    return out


def tukey(rows: list[dict], metric: str) -> list[tuple[str, str, float, float, bool]]:
    """Tukey's HSD between the solutions on ``metric``: (a, b, mean b - a, adjusted p, reject)."""
    from statsmodels.stats.multicomp import pairwise_tukeyhsd

    y = [r[metric] for r in rows if r.get(metric) is not None and math.isfinite(r[metric])]
    groups = [r["algorithm"] for r in rows
              if r.get(metric) is not None and math.isfinite(r[metric])]  # fmt: skip
    if len(set(groups)) < 2:
        return []
    result = pairwise_tukeyhsd(np.asarray(y, dtype=float), np.asarray(groups), alpha=0.05)
    a_b = list(itertools.combinations(result.groupsunique, 2))  # statsmodels' pair order
    return [
        (str(a), str(b), float(d), float(p), bool(rej))
        for (a, b), d, p, rej in zip(
            a_b, result.meandiffs, result.pvalues, result.reject, strict=True
        )
    ]


def _table(rows: list[dict], cfg: Any, metric: str) -> list[str]:
    number, title, digits = TITLES[metric]
    paper_digits = 3 if metric == "optimality_gap" else 2  # as the paper prints them
    paper = PAPER_TABLES[metric]
    fracs = list(cfg.ranges)
    head = ["Alg", "N"]
    for f in fracs:
        head += [f"{f:g}D ours", f"{f:g}D paper"]
    lines = [f"## {number}: {title}", "",
             "ours: mean / sd [± half-width of the 95 % interval]; paper: mean / sd", "",
             "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]  # fmt: skip
    for alg in cfg.algorithms:
        for n in cfg.scales:
            cells = [LABEL[alg], str(n)]
            for f in fracs:
                ours = _values(rows, metric, algorithm=alg, agents=n, range_frac=f)
                cells.append(_cell(ours, digits))
                printed = paper.get((alg, n))
                if printed is None or f not in PAPER_RANGES:
                    cells.append("-")
                else:
                    mean, sd = printed[PAPER_RANGES.index(f)]
                    cells.append(f"{mean:.{paper_digits}f} / {sd:.{paper_digits}f}")
            lines.append("| " + " | ".join(cells) + " |")
    return [*lines, ""]


def _anova_lines(rows: list[dict], metric: str) -> tuple[list[str], dict[str, float]]:
    result = anova(rows, metric)
    title = f"## {ANOVA_TABLES[metric]}: ANOVA of {metric} on S x AT x CL"
    if not result:
        return [title, "", "(not computed: fewer than two levels of a factor in these runs)",
                ""], {}  # fmt: skip
    lines = [title, "", "| Term | DF | F | p (ours) | p (paper) |", "|---|---|---|---|---|"]
    pvalues = {}
    for term in TERMS:
        if term not in result:
            continue
        df, f, p = result[term]
        pvalues[term] = p
        paper = PAPER_ANOVA_P[metric].get(term, "-")
        lines.append(f"| {term} | {df:.0f} | {f:.2f} | {_p(p)} | {paper} |")
    if "Error" in result:
        lines.append(f"| Error | {result['Error'][0]:.0f} | | | 810 |")
    return [*lines, ""], pvalues


def _checks_lines(rows: list[dict]) -> list[str]:
    """The paper's three yes/no questions per run, as the share of runs answering yes."""
    lost = [r for r in rows if (r.get("vehicles_lost") or 0) > 0]
    orphaned = [r for r in lost if r["algorithm"] == "icf"]

    def share(items: list[dict], test: Callable[[dict], bool]) -> str:
        return f"{sum(map(test, items))} / {len(items)}" if items else "-"

    return [
        "## The paper's novelty checks (every run answered yes)",
        "",
        "| Question | runs answering yes |",
        "|---|---|",
        "| Were tasks assigned? | "
        + share(rows, lambda r: (r.get("tasks_assigned") or 0) > 0)
        + " |",
        "| Were tasks released after the report timeout? (ICF runs with a vehicle lost) | "
        + share(orphaned, lambda r: (r.get("tasks_released") or 0) > 0)
        + " |",
        "| Were completed tasks validated? (every task validated) | "
        + share(rows, lambda r: r.get("tasks_validated") == r.get("tasks_total"))
        + " |",
        "",
    ]


def _means(rows: list[dict], metric: str, alg: str) -> float:
    return mean_ci95(_values(rows, metric, algorithm=alg))[0]


def write_report(results: pa.Table, cfg: Any, out_dir: Path, say: Callable[[str], None]) -> str:
    """tables.md and plots/ from the results; returns the RESULT line."""
    rows = results.to_pylist()
    ok = [r for r in rows if r.get("status") == "ok"]
    lines = [
        "# Seed 003: ICF (Caravan auction + Dijkstra) against ICA and GBAA, 10 % vehicle loss",
        "",
        f"{len(rows)} runs ({len(ok)} ran to the end; {sum(r['passed'] for r in rows)} passed "
        f"their checks); {'quick' if cfg.quick else 'full'} design: S {list(cfg.algorithms)} x "
        f"AT {list(cfg.scales)} x CL {list(cfg.ranges)} x {len(cfg.runs)} runs. Every number of "
        "ours is computed from results.parquet; docs/seed003.md says where they disagree with "
        "the paper's and why.",
        "",
    ]
    for metric in TITLES:
        lines += _table(ok, cfg, metric)
    pvalues: dict[str, dict[str, float]] = {}
    for metric in TITLES:
        block, pvalues[metric] = _anova_lines(ok, metric)
        lines += block
    pairs = tukey(ok, "execution_time")
    if pairs:
        lines += ["## Tukey HSD on execution time (family 95 %)", "",
                  "| a | b | mean(b) - mean(a), s | adjusted p | differ |",
                  "|---|---|---|---|---|"]  # fmt: skip
        for a, b, d, p, rej in pairs:
            lines.append(f"| {LABEL.get(a, a)} | {LABEL.get(b, b)} | {d:.3f} | {_p(p)} | "
                         f"{'yes' if rej else 'no'} |")  # fmt: skip
        lines += ["", "Paper: all three solutions differ, ICF fastest overall.", ""]
    lines += _checks_lines(ok)
    means = {alg: {m: _means(ok, m, alg) for m in TITLES} for alg in cfg.algorithms}
    fastest = min(cfg.algorithms, key=lambda a: (means[a]["execution_time"]
                                                 if math.isfinite(means[a]["execution_time"])
                                                 else math.inf))  # fmt: skip
    lines += ["## Overall means", "", "| Alg | gap | steps | execution time, s |",
              "|---|---|---|---|"]  # fmt: skip
    for alg in cfg.algorithms:
        m = means[alg]
        lines.append(
            f"| {LABEL[alg]} | {format_ci(m['optimality_gap'], math.nan, 3)} | "
            f"{format_ci(m['convergence_steps'], math.nan, 1)} | "
            f"{format_ci(m['execution_time'], math.nan, 2)} |"
        )
    lines.append("")
    (out_dir / "tables.md").write_text("\n".join(lines))
    try:
        from harness.experiments.seed003_plots import write_plots

        write_plots(ok, cfg, out_dir / "plots")
    except Exception as exc:  # a failed plot must not cost the tables
        say(f"plots not written: {exc!r}")
    parts = [f"experiment=seed003 runs={len(rows)} ok={len(ok)}"]
    for alg in cfg.algorithms:
        m = means[alg]
        parts.append(
            f"gap_{alg}={m['optimality_gap']:.3f} steps_{alg}={m['convergence_steps']:.1f} "
            f"exec_{alg}={m['execution_time']:.2f}"
        )
    parts.append(f"fastest={fastest}")
    for metric, key in (("execution_time", "exec"), ("optimality_gap", "gap")):
        p = pvalues.get(metric, {}).get("S", math.nan)
        parts.append(f"anova_S_{key}_p={_p(p)}")
    return "RESULT " + " ".join(parts)
