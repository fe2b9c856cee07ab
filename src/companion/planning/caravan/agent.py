"""The per-agent interface of seed 003's three allocators: messages in, one step, a task out.

An allocator learns about other agents only through ``inbox`` (a neighbour's dict message, heard
over a range-limited, lossy radio) and tells them only through ``outbox``; ``step`` is one
synchronous consensus step. Geometry stays outside: the adapter hands ``step`` this agent's bid
vector (Eq. 26 from where it is) and calls ``arrived`` when the vehicle is at its task (Eq. 19).

Convergence steps (Sec. 4.3; digest gap 9), the same definition for the three: the consensus
steps (one per ``step`` call, synchronous across the fleet) until no agent's believed assignment
changes any more, re-auctions after a loss or a completion included. An agent's believed
assignment is the map open task -> holder it believes (for ICA, the assignment it solved); a task
leaving it because it was completed is not a change. ``AllocatorStats.last_change_step`` is the
step at which it last changed; the run's convergence steps are its maximum over the fleet.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from companion.planning.caravan.scores import CaravanParams


@dataclass
class AllocatorStats:
    """What one agent's allocator counted."""

    steps: int = 0
    """Consensus steps run."""
    last_change_step: int = 0
    """The step at which the believed assignment last changed (0: never)."""
    assigned: int = 0
    """Auctions won / tasks taken."""
    released: set[int] = field(default_factory=set)
    """Tasks this agent released (Eqs. 22-25; ICF only)."""
    completed: list[tuple[int, float]] = field(default_factory=list)
    """(task, time s) of the tasks this agent completed itself."""
    validated: set[int] = field(default_factory=set)
    """Tasks it knows completed."""
    duplicates: int = 0
    """Arrivals at a task already completed (known to it, or seen so on arrival)."""


class Allocator(Protocol):
    """One agent's task allocator (see the module docstring)."""

    agent: int
    """0-based agent index."""
    stats: AllocatorStats

    @property
    def task(self) -> int | None:
        """The task it heads to (None: none)."""

    @property
    def finished(self) -> bool:
        """Every task is known completed."""

    def outbox(self, now_s: float) -> dict[str, Any]:
        """The JSON-able message broadcast to the neighbours this step."""

    def inbox(self, sender: int, message: dict[str, Any], now_s: float) -> None:
        """A neighbour's message (only neighbours within range are heard)."""

    def step(self, now_s: float, scores: np.ndarray) -> int | None:
        """One consensus step: merge, validate, auction; return the task it heads to."""

    def arrived(self, task: int, now_s: float, seen_done: bool = False) -> None:
        """The vehicle reached ``task`` (Eq. 19); ``seen_done``: it saw the task already done."""


class AssignmentTracker:
    """Counts steps and records when the believed assignment (open task -> holder) changed."""

    def __init__(self, stats: AllocatorStats) -> None:
        self.stats = stats
        self._last: dict[int, int] = {}

    def note(self, believed: dict[int, int], done: np.ndarray) -> None:
        """Count one step; ``believed``: open task -> holder after it; ``done``: completed."""
        self.stats.steps += 1
        tasks = set(self._last) | set(believed)
        if any(self._last.get(j) != believed.get(j) for j in tasks if not done[j]):
            self.stats.last_change_step = self.stats.steps
        self._last = dict(believed)


def beats(
    y_new: np.ndarray, x_new: np.ndarray | int, y_old: np.ndarray, x_old: np.ndarray, eps: float
) -> np.ndarray:
    """Eq. (18) with ties: does the bid (y_new from x_new) take the task from (y_old, x_old)?

    It does if it exceeds the winning bid by more than eps, or ties it (within eps) from a lower
    agent id ("lexicographical order", lowest id wins; digest gap 8). ``x_old`` < 0 (no holder)
    is beaten by any positive bid.
    """
    x_old = np.asarray(x_old)
    holder = np.where(x_old >= 0, x_old, np.iinfo(np.int64).max)
    free = x_old < 0
    tie = np.abs(y_new - y_old) <= eps
    return np.where(free, y_new > 0, (y_new - y_old > eps) | (tie & (x_new < holder)))


def make_allocator(params: CaravanParams, agent: int, n_agents: int, n_tasks: int) -> Allocator:
    """The allocator ``params.algorithm`` names, for ``agent`` of ``n_agents`` over ``n_tasks``."""
    if not 0 <= agent < n_agents:
        raise ValueError(f"agent: {agent} is not in 0..{n_agents - 1}")
    if n_tasks < 0:
        raise ValueError(f"n_tasks: must be >= 0, got {n_tasks}")
    if params.algorithm == "icf":
        from companion.planning.caravan.icf import CarA

        return CarA(params, agent, n_agents, n_tasks)
    if params.algorithm == "gbaa":
        from companion.planning.caravan.gbaa import Gbaa

        return Gbaa(params, agent, n_agents, n_tasks)
    from companion.planning.caravan.ica import Ica

    return Ica(params, agent, n_agents, n_tasks)
