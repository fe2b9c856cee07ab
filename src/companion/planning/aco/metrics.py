"""Seed 001's evaluation metrics (Sec. 3.5, Eqs. 4-10), in the paper's own mixed units.

Table 2's CF values are reproduced only when PQ, MC and FC enter Eqs. 9-10 as *percent numbers*
(PQ = 97.7, not 0.977) and FT and AD as a raw ratio and a raw count (digest 004_001 §4,
verified): that is what these functions return and take, so the paper's numbers can be compared.
CF is then dominated by PQ and MC and the ``(1 - FC)`` term is strongly negative; higher CF is
better. The N = 60 row of Table 2 prints 35.1919 where its own PQ/MC/FC/FT/AD give 35.102 (a typo).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

TIME_FRAME_S = 60.0
"""Eq. 7's TimeFrame, s."""
WEIGHTS_OPTION1 = (0.3, 0.3, 0.2, 0.2)
"""Eq. 9's (alpha, beta, omega, gamma): PQ, (1 - FT), (1 - AD), MC."""
WEIGHTS_OPTION2 = (0.2, 0.2, 0.2, 0.2, 0.2)
"""Eq. 10's (alpha, beta, omega, gamma, mu): PQ, (1 - FT), (1 - AD), MC, (1 - FC)."""


def path_quality(min_dist_m: Sequence[float], total_dist_m: Sequence[float]) -> float:
    """Eq. 4: PQ = (1/N) sum MinDist_i / TotalDist_i * 100, percent."""
    lo, tot = np.asarray(min_dist_m, float), np.asarray(total_dist_m, float)
    if lo.size == 0:
        return float("nan")
    ratio = np.divide(lo, tot, out=np.zeros_like(lo), where=tot > 0)
    return float(ratio.mean() * 100.0)


def mission_completion(reached: Sequence[bool]) -> float:
    """Eq. 5: MC = N_reached / N * 100, percent."""
    r = np.asarray(reached, bool)
    return float(r.mean() * 100.0) if r.size else float("nan")


def average_divergence(divergences: Sequence[float]) -> float:
    """Eq. 6: AD = sum Divergences_i / N, per drone."""
    d = np.asarray(divergences, float)
    return float(d.mean()) if d.size else float("nan")


def flight_time(makespan_s: float, time_frame_s: float = TIME_FRAME_S) -> float:
    """Eq. 7: FT = T / TimeFrame (T: the time for all drones to reach their targets)."""
    return float(makespan_s) / time_frame_s


def formation_change(avg_dist_change_m: Sequence[float], threshold_m: float) -> float:
    """Eq. 8: FC = (1/N) sum AvgDistChange_i / Threshold * 100, percent of the allowable change."""
    a = np.asarray(avg_dist_change_m, float)
    return float(a.mean() / threshold_m * 100.0) if a.size else float("nan")


def cost_function(pq: float, ft: float, ad: float, mc: float, fc: float | None = None) -> float:
    """Eq. 9 (``fc`` None, option 1) or Eq. 10 (option 2): CF, higher is better."""
    if fc is None:
        a, b, w, g = WEIGHTS_OPTION1
        return a * pq + b * (1.0 - ft) + w * (1.0 - ad) + g * mc
    a, b, w, g, mu = WEIGHTS_OPTION2
    return a * pq + b * (1.0 - ft) + w * (1.0 - ad) + g * mc + mu * (1.0 - fc)
