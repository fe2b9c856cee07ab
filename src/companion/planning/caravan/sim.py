"""A pure discrete-time driver of seed 003's allocators (Sec. 4.1's 2-D world), for tests.

Every ``dt_s`` all live agents step synchronously: each first receives the messages its disk-range
neighbours (Eq. 13, distance <= ``range_m``) sent at the previous step, steps with its Eq. (26)
bids from where it is, checks whether it is at the task it now heads to (Eq. 19, then ``arrived``
with the truth of whether it was done already: a free agent re-bids at the next step) and sends
its message; then every agent moves at constant speed
straight toward its task (zero turning radius, no dynamics). A lost agent (``lost_at_s``) stops
at that time: it sends, hears and moves no more. Messages can be dropped with ``loss`` (a
Bernoulli probability, drawn from ``rng``). The swarm-scale adapter is
``companion.swarm.caravan``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from companion.planning.caravan.agent import Allocator, make_allocator
from companion.planning.caravan.graph import TaskGraph
from companion.planning.caravan.optimum import achieved_score
from companion.planning.caravan.scores import CaravanParams


@dataclass
class SimResult:
    """What a driven run produced."""

    allocators: list[Allocator]
    first_completion_s: np.ndarray
    """(N_m,) time of each task's first completion, s (NaN: never)."""
    completions: np.ndarray
    """(N_m,) how many times each task was completed (arrivals at it while it was open or not)."""
    time_s: float
    """When the run stopped, s."""
    score: float
    """J: Eq. (26) summed at the first completion times (``optimum.achieved_score``)."""
    max_holders: np.ndarray
    """(N_m,) the most agents that headed to the task at one time."""

    @property
    def convergence_steps(self) -> int:
        """The fleet's maximum of ``last_change_step`` (``agent`` module docstring)."""
        return max(a.stats.last_change_step for a in self.allocators)


def simulate(
    agents_xy: np.ndarray,
    tasks_xy: np.ndarray,
    params: CaravanParams,
    range_m: float = math.inf,
    dt_s: float = 0.2,
    lost_at_s: dict[int, float] | None = None,
    graph: TaskGraph | None = None,
    max_time_s: float = 120.0,
    loss: float = 0.0,
    rng: np.random.Generator | None = None,
) -> SimResult:
    """Drive ``params.algorithm`` until every task is done or ``max_time_s`` (module docstring).

    ``graph``: bids from lattice travel times (None: straight-line times, as the agents fly).
    """
    pos = np.array(agents_xy, dtype=float).reshape(-1, 2)
    tasks = np.asarray(tasks_xy, dtype=float).reshape(-1, 2)
    n, m = len(pos), len(tasks)
    lost_at = dict(lost_at_s or {})
    if loss > 0 and rng is None:
        raise ValueError("rng: a generator is needed to draw message loss")
    allocs = [make_allocator(params, i, n, m) for i in range(n)]
    first = np.full(m, np.nan)
    count = np.zeros(m, dtype=int)
    holders = np.zeros(m, dtype=int)
    sent: list[dict | None] = [None] * n
    now = 0.0
    steps = 0
    while now <= max_time_s:
        alive = np.array([now < lost_at.get(i, math.inf) for i in range(n)])
        d = np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=2)
        for i in np.flatnonzero(alive):
            a = allocs[i]
            for k in np.flatnonzero(alive & (d[i] <= range_m)):
                if k != i and sent[k] is not None and not (loss > 0 and rng.random() < loss):
                    a.inbox(int(k), sent[k], now)  # type: ignore[union-attr,arg-type]
            if graph is None:
                t = np.linalg.norm(tasks - pos[i], axis=1) / params.speed_m_s
            else:
                t = graph.travel_times_s(pos[i], tasks, params.speed_m_s)
            j = a.step(now, params.bids(now, t))
            if j is not None and np.linalg.norm(pos[i] - tasks[j]) <= params.arrive_tolerance_m:
                a.arrived(j, now, seen_done=bool(count[j]))
                count[j] += 1
                if math.isnan(first[j]):
                    first[j] = now
        sent = [allocs[i].outbox(now) if alive[i] else None for i in range(n)]
        heading = np.zeros(m, dtype=int)
        for i in np.flatnonzero(alive):
            j = allocs[i].task
            if j is None:
                continue
            heading[j] += 1
            gap = tasks[j] - pos[i]
            dist = float(np.linalg.norm(gap))
            pos[i] = (
                tasks[j]
                if dist <= params.speed_m_s * dt_s
                else pos[i] + gap / dist * (params.speed_m_s * dt_s)
            )
        np.maximum(holders, heading, out=holders)
        if np.isfinite(first).all() or all(allocs[i].finished for i in np.flatnonzero(alive)):
            break
        steps += 1
        now = steps * dt_s
    return SimResult(allocs, first, count, now, achieved_score(first, params), holders)
