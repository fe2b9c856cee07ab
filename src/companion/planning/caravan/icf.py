"""CarA, the upper tier of seed 003's Integrated Consensus Framework (Secs. 3.2-3.4).

One agent's state is the five vectors of Sec. 3.2 over the N_m tasks: ``x`` (winner, -1: none;
agents are 0-based here), ``t`` (assignment time), ``y`` (winning bid), ``z`` (completed), ``f``
(released), plus the last time each agent was heard of (the release times T of Eq. 22 are those
plus delta). Each step:

1. Consensus (Eqs. 16-18): merge every neighbour's (x, y, t) into its own, task by task: a bid
   replaces the winning one if it exceeds it by more than epsilon (Eq. 18), or ties it from a
   lower agent id ("lexicographical order", lowest id wins). Relays multi-hop, since neighbours'
   merged vectors are merged again at the next step. An agent outbid on its task drops it and
   takes the winner's time (Eq. 17). Claims naming this agent come only from itself.
2. Validation (Eqs. 19-25): completions OR-propagate (Eq. 20, an OR over the neighbours) and
   clear the task's x, y, t (Eq. 21). Liveness (Eq. 22, as intended: ``T_ki = now + delta`` on
   contact, digest gap 6): the last time each agent was heard of is max-merged from the
   neighbours too, so an agent reachable through relays is not released; an owner not heard of
   for delta loses its task (Eqs. 23-24): x, y, t of the task are reset and f = 1. A release
   propagates (Eq. 25) as the claim time it voids, max-merged: every claim on that task made no
   later than the void one is dropped wherever the release arrives (a max-merge of y alone would
   bring the dead bid back). An owner that reappears after the release finds its claim void and
   competes again; one heard of again before delta keeps its task.
3. Auction (Eqs. 14-15), for a free agent: among the tasks not completed whose winning bid its
   score beats (Eq. 14 with Eq. 18's epsilon and the tie rule; released tasks have no winner, so
   they are available), it takes J = argmax_j s_j (Eq. 15, argmax over j), with y = s_J, t = now.

The bids are Eq. (26) at the visit time counted from the start of the mission
(``CaravanParams.bids``): an agent flying to a task keeps its bid, and nobody's score for a task
rises as time passes. With bids from the remaining travel time instead, an outbid agent flying
near the task soon beats the winner's older bid with its fresh one, the winner does the same
back, and both fly on to the task together and complete it twice.

Single assignment; an agent is free again after completing its task and re-bids (digest gap 10).
With a short radio range an isolated but healthy agent's task is released after delta and may be
done twice: that is seed 003's behaviour, counted by the adapters (``duplicates``, and the run's
``tasks_completed_twice``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from companion.planning.caravan.agent import AllocatorStats, AssignmentTracker, beats
from companion.planning.caravan.scores import CaravanParams

NEVER = -1.0
"""Time stamp of 'never' (times are >= 0 s)."""


class CarA:
    """One agent of the Caravan Auction (see the module docstring)."""

    def __init__(self, params: CaravanParams, agent: int, n_agents: int, n_tasks: int) -> None:
        self.params = params
        self.agent = agent
        self.n_agents = n_agents
        self.n_tasks = n_tasks
        self.x = np.full(n_tasks, -1, dtype=np.int64)
        """Winner per task (Sec. 3.2), -1: none."""
        self.t = np.zeros(n_tasks)
        """Assignment time per task, s."""
        self.y = np.zeros(n_tasks)
        """Winning bid per task."""
        self.z = np.zeros(n_tasks, dtype=bool)
        """Completed tasks."""
        self.void = np.full(n_tasks, NEVER)
        """Per task, the time of the latest released claim: claims made no later are void."""
        self.heard = np.full(n_agents, NEVER)
        """When each agent was last heard of (directly or through relays), s."""
        self.stats = AllocatorStats()
        self._tracker = AssignmentTracker(self.stats)
        self._task: int | None = None
        self._inbox: list[tuple[int, dict[str, Any], float]] = []

    @property
    def f(self) -> np.ndarray:
        """Released tasks (Sec. 3.2's f): released and not claimed or completed since."""
        return (self.void > NEVER) & (self.x < 0) & ~self.z

    @property
    def task(self) -> int | None:
        """The task it heads to."""
        return self._task

    @property
    def finished(self) -> bool:
        """Every task known completed."""
        return bool(self.z.all())

    def outbox(self, now_s: float) -> dict[str, Any]:
        """x, y, t (Eq. 16), z (Eq. 20), the release stamps (Eq. 25) and the liveness times."""
        self.heard[self.agent] = max(self.heard[self.agent], now_s)
        return {
            "x": self.x.tolist(),
            "y": self.y.tolist(),
            "t": self.t.tolist(),
            "z": self.z.astype(int).tolist(),
            "void": self.void.tolist(),
            "heard": self.heard.tolist(),
        }

    def inbox(self, sender: int, message: dict[str, Any], now_s: float) -> None:
        """Keep a neighbour's vectors for the next step (g_ik(t) = 1)."""
        self._inbox.append((sender, message, now_s))

    def step(self, now_s: float, scores: np.ndarray) -> int | None:
        """One step: consensus, validation, auction (see the module docstring)."""
        me, eps = self.agent, self.params.epsilon
        s = np.asarray(scores, dtype=float)
        self.heard[me] = now_s
        msgs, self._inbox = self._inbox, []
        # Eqs. (20), (22), (25): completions, liveness and releases first, then the bids
        for sender, m, heard_s in msgs:
            self.z |= np.asarray(m["z"], dtype=bool)
            np.maximum(self.heard, np.asarray(m["heard"], dtype=float), out=self.heard)
            self.heard[sender] = max(self.heard[sender], heard_s)
            np.maximum(self.void, np.asarray(m["void"], dtype=float), out=self.void)
        self._drop_void()
        # Eq. (16) with Eq. (18): max-merge the winning bids
        for _, m, _ in msgs:
            cx = np.asarray(m["x"], dtype=np.int64)
            cy = np.asarray(m["y"], dtype=float)
            ct = np.asarray(m["t"], dtype=float)
            live = (cx >= 0) & (cx != me) & (ct > self.void) & ~self.z
            same = live & (cx == self.x)
            take = live & ~same & beats(cy, cx, self.y, self.x, eps)
            take |= same & ((ct > self.t) | ((ct == self.t) & (cy > self.y)))  # its latest
            self.x[take], self.y[take], self.t[take] = cx[take], cy[take], ct[take]
        # Eq. (17): outbid (or released) -> free
        j = self._task
        if j is not None and (self.x[j] != me or self.z[j]):
            self._task = None
        # Eq. (21): completed tasks leave the vectors
        self.x[self.z], self.y[self.z], self.t[self.z] = -1, 0.0, 0.0
        # Eqs. (22)-(24): release the tasks of owners not heard of for delta
        owner = self.x
        held = (owner >= 0) & (owner != me) & ~self.z
        lost = held & (now_s > self.heard[np.maximum(owner, 0)] + self.params.release_timeout_s)
        if lost.any():
            self.void[lost] = np.maximum(self.void[lost], self.t[lost])
            self.stats.released.update(int(k) for k in np.flatnonzero(lost))
            self.x[lost], self.y[lost], self.t[lost] = -1, 0.0, 0.0
        # Eqs. (14)-(15): a free agent bids on its best available task
        if self._task is None and not self.finished:
            avail = ~self.z & beats(s, me, self.y, self.x, eps)
            if avail.any():
                j = int(np.argmax(np.where(avail, s, -np.inf)))
                self.x[j], self.y[j], self.t[j] = me, s[j], now_s
                self._task = j
                self.stats.assigned += 1
        self.stats.validated = set(np.flatnonzero(self.z).tolist())
        open_ = (self.x >= 0) & ~self.z
        self._tracker.note({int(k): int(self.x[k]) for k in np.flatnonzero(open_)}, self.z)
        return self._task

    def _drop_void(self) -> None:
        """Claims (its own too) made no later than a released claim are void (Eq. 25)."""
        dead = (self.x >= 0) & (self.t <= self.void)
        if dead.any():
            self.x[dead], self.y[dead], self.t[dead] = -1, 0.0, 0.0
            if self._task is not None and dead[self._task]:
                self._task = None  # reappeared after its release: competes again

    def arrived(self, task: int, now_s: float, seen_done: bool = False) -> None:
        """Eq. (19): the task is completed; the agent is free again."""
        if self.z[task] or seen_done:
            self.stats.duplicates += 1
        else:
            self.stats.completed.append((int(task), float(now_s)))
        self.z[task] = True
        self.x[task], self.y[task], self.t[task] = -1, 0.0, 0.0
        self.stats.validated.add(int(task))
        if self._task == task:
            self._task = None
