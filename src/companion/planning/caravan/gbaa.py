"""GBAA, the Greedy-Based Auction Algorithm: seed 003's first baseline (Sec. 4.2).

After L. Brunet, "Consensus-Based Auctions for Decentralized Task Assignment", MS thesis, MIT,
2008 (http://hdl.handle.net/1721.1/44926), as seed 003 cites it [35]: "a decentralized
task-assignment solution approach that uses auction algorithms and adjudicates conflicts with
direct neighbors only", so that agents without a direct link cannot resolve a conflict.

Each agent broadcasts only its own state: its claim (task, bid) and the tasks it completed
itself. Nothing is relayed: what it knows of who holds what, and of what is done, comes from the
agents it hears directly. A claim heard is kept until the claimant has not been heard for delta
(``release_timeout_s``): a lost or departed neighbour's claim is then dropped. Each step a held
task is given up to a heard claim that beats it (Eq. 18's epsilon, ties to the lowest id, as in
CarA); a free agent greedily takes its best task among those not known done whose known claim
(if any) its score beats. An agent arriving at a task is free again and re-bids (digest gap 10);
arriving at a task already done (it sees so on arrival) is counted as a duplicate.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from companion.planning.caravan.agent import AllocatorStats, AssignmentTracker, beats
from companion.planning.caravan.scores import CaravanParams


class Gbaa:
    """One agent of the greedy auction (see the module docstring)."""

    def __init__(self, params: CaravanParams, agent: int, n_agents: int, n_tasks: int) -> None:
        self.params = params
        self.agent = agent
        self.n_agents = n_agents
        self.n_tasks = n_tasks
        self.done = np.zeros(n_tasks, dtype=bool)
        """Tasks known completed (its own and its direct neighbours' completions)."""
        self.claims: dict[int, tuple[int, float, float]] = {}
        """Neighbour -> (task, bid, when last heard, s)."""
        self.bid = 0.0
        self.stats = AllocatorStats()
        self._tracker = AssignmentTracker(self.stats)
        self._task: int | None = None
        self._mine: list[int] = []

    @property
    def task(self) -> int | None:
        """The task it heads to."""
        return self._task

    @property
    def finished(self) -> bool:
        """Every task known completed."""
        return bool(self.done.all())

    def outbox(self, now_s: float) -> dict[str, Any]:
        """Its own claim and its own completions (nothing relayed)."""
        task = -1 if self._task is None else self._task
        return {"task": task, "bid": self.bid, "done": list(self._mine)}

    def inbox(self, sender: int, message: dict[str, Any], now_s: float) -> None:
        """A direct neighbour's claim and completions."""
        self.claims[sender] = (int(message["task"]), float(message["bid"]), now_s)
        self.done[[int(j) for j in message["done"]]] = True

    def step(self, now_s: float, scores: np.ndarray) -> int | None:
        """Drop stale claims, give up an outbid task, greedily bid when free."""
        me, eps = self.agent, self.params.epsilon
        s = np.asarray(scores, dtype=float)
        timeout = self.params.release_timeout_s
        self.claims = {
            k: c
            for k, c in self.claims.items()
            if k != me and now_s - c[2] <= timeout and c[0] >= 0 and not self.done[c[0]]
        }
        # the winning known claim per task
        wx = np.full(self.n_tasks, -1, dtype=np.int64)
        wy = np.zeros(self.n_tasks)
        for k in sorted(self.claims):
            j, b, _ = self.claims[k]
            if beats(np.array(b), k, wy[j], wx[j], eps):
                wx[j], wy[j] = k, b
        j = self._task
        if j is not None and (self.done[j] or beats(np.array(wy[j]), wx[j], self.bid, me, eps)):
            self._task, self.bid = None, 0.0
        if self._task is None and not self.finished:
            avail = ~self.done & beats(s, me, wy, wx, eps)
            if avail.any():
                j = int(np.argmax(np.where(avail, s, -np.inf)))
                self._task, self.bid = j, float(s[j])
                self.stats.assigned += 1
        if self._task is not None:
            wx[self._task] = me
        self.stats.validated = set(np.flatnonzero(self.done).tolist())
        open_ = (wx >= 0) & ~self.done
        self._tracker.note({int(k): int(wx[k]) for k in np.flatnonzero(open_)}, self.done)
        return self._task

    def arrived(self, task: int, now_s: float, seen_done: bool = False) -> None:
        """The task is done (a duplicate if it already was); the agent is free again."""
        if self.done[task] or seen_done:
            self.stats.duplicates += 1
        else:
            self.stats.completed.append((int(task), float(now_s)))
            self._mine.append(int(task))
        self.done[task] = True
        self.stats.validated.add(int(task))
        if self._task == task:
            self._task, self.bid = None, 0.0
