"""ICA, the Implicit Coordination Algorithm: seed 003's second baseline (Sec. 4.2).

After M. Alighanbari and J. P. How, "Decentralized task assignment for unmanned aerial vehicles",
44th IEEE CDC, 2005 (seed 003's [58]; the implicit coordination of that line of work): the
agents reach consensus on their situational awareness and each solves the whole assignment
problem on its own copy of it ("examines all possibilities to provide an optimal solution"),
then flies its own row's task. Conflicts arise while the copies differ and disappear as they
converge.

The situational awareness here: for each agent, its latest bid vector (Eq. 26 from where it is,
which stands for its position: the geometry stays in the adapter) with the time it was taken,
and the task it heads to, relayed multi-hop (each agent keeps the newest entry of every agent it
has heard of, directly or through relays), and the completed tasks (OR-relayed). An agent solves
max sum s_kj x_kj (Eq. 1) with ``scipy.optimize.linear_sum_assignment`` over the agents whose entry
is not older than delta (``release_timeout_s``; so a lost agent drops out and its task is picked
up) and the tasks it believes open, each vector taken back to the same clock (its bids are
from the mission's start, so a vector's age alone would rank it), and heads to the task of its
own row. It solves again when
that set of agents or of open tasks changes (a completion, an agent heard of or dropped), or
when an agent reports (newer than the plan) heading elsewhere than the plan sends it (agents
whose information differed at the last event made different plans), and keeps its plan in
between: re-solving every step on vectors one step old (what the others sent)
makes two agents swap their tasks at every step (each flies toward its task, which makes the
other assignment better one step later), and never arrive. It solves with its own
entry as it last sent it, not with the fresh one it sends next: agents whose awareness agrees
then solve the same problem and agree on the assignment (with bids from the mission's start,
``CaravanParams.bids``, a fresh vector is never above an older one, so solving with its own
fresh row against the others' older ones would make every agent defer to the others).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

from companion.planning.caravan.agent import AllocatorStats, AssignmentTracker
from companion.planning.caravan.scores import CaravanParams


class Ica:
    """One agent of the implicit coordination (see the module docstring)."""

    def __init__(self, params: CaravanParams, agent: int, n_agents: int, n_tasks: int) -> None:
        self.params = params
        self.agent = agent
        self.n_agents = n_agents
        self.n_tasks = n_tasks
        self.done = np.zeros(n_tasks, dtype=bool)
        """Tasks known completed."""
        self.stamp = np.full(n_agents, -1.0)
        """When each agent's bid vector was taken, s (-1: never heard of)."""
        self.scores = np.zeros((n_agents, n_tasks))
        """Each agent's latest bid vector."""
        self.heading = np.full(n_agents, -1, dtype=np.int64)
        """The task each agent reported heading to with that vector (-1: none)."""
        self.stats = AllocatorStats()
        self._tracker = AssignmentTracker(self.stats)
        self._task: int | None = None
        self._key: tuple[tuple[int, ...], tuple[int, ...]] | None = None
        self._plan: dict[int, int] = {}
        self._plan_s = -1.0

    @property
    def task(self) -> int | None:
        """The task it heads to."""
        return self._task

    @property
    def finished(self) -> bool:
        """Every task known completed."""
        return bool(self.done.all())

    def outbox(self, now_s: float) -> dict[str, Any]:
        """Its situational awareness: the agents' stamped bid vectors it knows, and z."""
        known = np.flatnonzero(self.stamp >= 0)
        return {
            "agents": known.tolist(),
            "stamp": self.stamp[known].tolist(),
            "scores": self.scores[known].tolist(),
            "heading": self.heading[known].tolist(),
            "done": self.done.astype(int).tolist(),
        }

    def inbox(self, sender: int, message: dict[str, Any], now_s: float) -> None:
        """Merge a neighbour's awareness: the newer entry of each agent, completions OR-ed."""
        self.done |= np.asarray(message["done"], dtype=bool)
        agents = np.asarray(message["agents"], dtype=np.int64)
        if agents.size == 0:
            return
        stamp = np.asarray(message["stamp"], dtype=float)
        newer = (stamp > self.stamp[agents]) & (agents != self.agent)
        if newer.any():
            self.stamp[agents[newer]] = stamp[newer]
            self.scores[agents[newer]] = np.asarray(message["scores"], dtype=float)[newer]
            self.heading[agents[newer]] = np.asarray(message["heading"], dtype=np.int64)[newer]

    def step(self, now_s: float, scores: np.ndarray) -> int | None:
        """Solve the assignment on its own information; take its own row's task."""
        me = self.agent
        if self.stamp[me] < 0:  # the first step: nothing sent yet
            self.stamp[me], self.scores[me] = now_s, np.asarray(scores, dtype=float)
        agents = np.flatnonzero(
            (self.stamp >= 0) & (now_s - self.stamp <= self.params.release_timeout_s)
        )
        tasks = np.flatnonzero(~self.done)
        key = (tuple(agents.tolist()), tuple(tasks.tolist()))
        held = {k: j for j, k in self._plan.items()}
        later = agents[(agents != me) & (self.stamp[agents] > self._plan_s)]
        contradicted = any(self.heading[k] != held.get(int(k), -1) for k in later)
        if key != self._key or contradicted:
            self._key, self._plan_s = key, now_s
            self._plan = {}
            if tasks.size:
                # every vector back to the same clock: a bid taken at stamp s is
                # a e^(-lambda (s + travel)), so e^(lambda s) x bid = a e^(-lambda travel)
                # whenever it was taken: copies of the awareness that hold vectors of different
                # ages still rank the agents alike (else each defers to the agent whose vector it
                # holds oldest, and nobody goes)
                age = np.exp(self.params.discount_per_s * self.stamp[agents])[:, None]
                sub = self.scores[np.ix_(agents, tasks)] * age
                rows, cols = linear_sum_assignment(sub, maximize=True)
                self._plan = {
                    int(tasks[c]): int(agents[r]) for r, c in zip(rows, cols, strict=True)
                }
        mine = [j for j, k in self._plan.items() if k == me]
        task = mine[0] if mine else None
        self.stamp[me], self.scores[me] = now_s, np.asarray(scores, dtype=float)  # sent next
        self.heading[me] = -1 if task is None else task
        if task is not None and task != self._task:
            self.stats.assigned += 1
        self._task = task
        self.stats.validated = set(np.flatnonzero(self.done).tolist())
        self._tracker.note(self._plan, self.done)
        return self._task

    def arrived(self, task: int, now_s: float, seen_done: bool = False) -> None:
        """The task is done (a duplicate if it already was); the agent is free again."""
        if self.done[task] or seen_done:
            self.stats.duplicates += 1
        else:
            self.stats.completed.append((int(task), float(now_s)))
        self.done[task] = True
        self.stats.validated.add(int(task))
        if self._task == task:
            self._task = None
