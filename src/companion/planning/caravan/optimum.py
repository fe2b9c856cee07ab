"""Seed 003's optimality gap: J* by the Hungarian method and the gap (J* - J) / J*.

Sec. 4.3 defines the gap only as a "relative comparison of closeness to the best possible
answer" (digest gap 3). Here:

- J* = max sum_ij a exp(-lambda t_ij) x_ij (Eq. 1 with Eq. 26), solved centrally by
  ``scipy.optimize.linear_sum_assignment`` with full information and no loss: every agent from
  its start (t_ij its lattice travel time to task j), every task.
- J = sum over the COMPLETED tasks of a exp(-lambda T_j), T_j the time from the start of the
  mission at which task j was FIRST completed (a task never completed adds 0; a second
  completion adds nothing).

So the gap counts slow assignments, detours after re-assignment and tasks left undone alike.
It is usually in [0, 1), but not bounded below by 0: J* assigns one task per agent, while an agent
that completes a task is free again and may complete another, and a vehicle that cuts the
lattice's corners is faster than the lattice time J* assumes; either can make J > J* in rare maps.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from companion.planning.caravan.graph import TaskGraph
from companion.planning.caravan.scores import CaravanParams


def score_matrix(
    graph: TaskGraph | None, starts_xy: np.ndarray, tasks_xy: np.ndarray, params: CaravanParams
) -> np.ndarray:
    """(N_u, N_m) Eq. (26) scores of every agent from its start (lattice; None: straight)."""
    starts = np.asarray(starts_xy, dtype=float).reshape(-1, 2)
    tasks = np.asarray(tasks_xy, dtype=float).reshape(-1, 2)
    if graph is None:
        t = np.linalg.norm(starts[:, None, :] - tasks[None, :, :], axis=2) / params.speed_m_s
    else:
        t = np.array([graph.travel_times_s(p, tasks, params.speed_m_s) for p in starts])
    return params.scores(t.reshape(len(starts), len(tasks)))


def optimal_assignment(scores: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(agents, tasks) of the single assignment maximising Eq. (1) on this score matrix."""
    return linear_sum_assignment(np.asarray(scores, dtype=float), maximize=True)


def optimal_score(scores: np.ndarray) -> float:
    """J*: the maximum of Eq. (1) over single assignments of this score matrix."""
    s = np.asarray(scores, dtype=float)
    if s.size == 0:
        return 0.0
    rows, cols = optimal_assignment(s)
    return float(s[rows, cols].sum())


def achieved_score(first_completion_s: np.ndarray, params: CaravanParams) -> float:
    """J: Eq. (26) at each task's first completion time (NaN: never completed, adds 0)."""
    t = np.asarray(first_completion_s, dtype=float)
    done = np.isfinite(t)
    return float(params.scores(t[done]).sum())


def optimality_gap(j_star: float, j: float) -> float:
    """(J* - J) / J* (see the module docstring)."""
    if not j_star > 0:
        raise ValueError(f"j_star: must be > 0, got {j_star}")
    return (j_star - j) / j_star
