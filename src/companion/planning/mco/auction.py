"""Task allocation of the MCO Plan: an adapted FIPA English auction (Sec. 4.2.5, Fig. 12, seed 004).

The ground station (initiator) auctions the tasks one at a time to the vehicles (participants);
ST-SR-IA (single-task robots, single-robot tasks, instantaneous assignment): every vehicle gets
exactly one task. A bid is three Eq. (2) scores of the vehicle's capabilities over the fleet
(flight time, decision capacity, communication skill); the task's cost is the same three scores,
decision and communication from its role (:data:`~companion.planning.mco.roles.ROLE_SCORES`),
flight time from Eq. (2) of what its tour needs on the fleet's flight-time scale.

The rules the paper leaves open (digest Sec. 6 item 7), as implemented:

* Order: the Master first, then the Coordinators, then the Operators, each group by decreasing
  required flight time, equal ones by sub-area index.
* Acceptance: a bid is accepted when each of its three scores is at least the task's.
* English rounds: while more than one bid is accepted the initiator raises all three thresholds
  by :data:`THRESHOLD_STEP` (score units) and re-announces; a bidder stays in while every score
  still meets its raised threshold. The last bidder in wins, so the winner is the bidder whose
  smallest margin (score minus cost) is largest, to within the step.
* Ties (the last bidders all drop out in the same round): the highest score in the role's key
  skill (:data:`KEY_SKILL`: Master decision, Coordinator communication, Operator flight time),
  then the lowest vehicle index.
* No bid accepted: the mission must still fly, so the remaining vehicle with the smallest total
  shortfall (sum over the three scores of cost minus score, where positive) wins, ties as above;
  the log says so.
* A task that needs less flight time than the fleet's shortest costs 0 in flight time (Eq. (2)'s
  scale starts at 0); one that needs more than the fleet's longest costs more than 3, which no
  bid meets.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from companion.planning.mco.roles import ROLE_SCORES, Role

THRESHOLD_STEP = 0.25
"""How much each English round raises the three thresholds, Eq. (2) score units (0..3)."""

KEY_SKILL: dict[Role, int] = {Role.MASTER: 1, Role.COORDINATOR: 2, Role.OPERATOR: 0}
"""The score (0 flight time, 1 decision, 2 communication) that breaks a role's ties."""

_ORDER = {Role.MASTER: 0, Role.COORDINATOR: 1, Role.OPERATOR: 2}


@dataclass(frozen=True)
class Bidder:
    """A vehicle's raw capabilities X (Table 4's sources; any numeric scale per skill)."""

    vehicle: int
    """The vehicle's index in the fleet."""
    flight_time_s: float
    """Flight time its battery and use history allow, s."""
    decision: float
    """Decision capacity, e.g. a 1..5 class of autopilot and onboard computer."""
    communication: float
    """Communication skill, e.g. a 1..5 class of telemetry module and data flow."""


@dataclass(frozen=True)
class Task:
    """A sub-area's coverage task: its role and the flight time its tour needs."""

    sub_area: int
    """The sub-area's index."""
    role: Role
    """The role its position in the partition gives it (:func:`assign_roles`)."""
    flight_time_s: float
    """Flight time the sub-area's tour needs (transit included if the caller counts it), s."""


@dataclass(frozen=True)
class AuctionResult:
    """The outcome of :func:`english_auction`."""

    assignment: dict[int, int]
    """Sub-area -> vehicle, a bijection between the tasks and the bidders."""
    rounds: int
    """Announcements made over all tasks (the first call for bids plus each raise)."""
    log: tuple[str, ...]
    """One line per task: what was accepted, the rounds, the winner, any fallback."""


def eq2_scores(values: np.ndarray, lo: float | None = None, hi: float | None = None) -> np.ndarray:
    """Eq. (2), seed 004 (denominator typo fixed): ``3 (X - X_min) / (X_max - X_min)``.

    ``lo``, ``hi``: X_min, X_max (default: those of ``values``). Values outside [lo, hi] score
    outside [0, 3] (not clipped). A degenerate scale (X_max = X_min, e.g. a fleet of equal
    vehicles): every value up to X_max scores 3 (all at the top of the scale), a value above it
    +inf (beyond what the scale can give).
    """
    x = np.asarray(values, dtype=float)
    lo_ = float(np.min(x)) if lo is None else float(lo)
    hi_ = float(np.max(x)) if hi is None else float(hi)
    if hi_ < lo_:
        raise ValueError(f"Eq. (2) needs X_max >= X_min, got X_min={lo_}, X_max={hi_}")
    if hi_ == lo_:
        return np.where(x <= hi_, 3.0, np.inf)
    return 3.0 * (x - lo_) / (hi_ - lo_)


def english_auction(tasks: Sequence[Task], bidders: Sequence[Bidder]) -> AuctionResult:
    """Allocate every task to one vehicle, one task per vehicle (Sec. 4.2.5, Fig. 12, seed 004)."""
    if len(tasks) != len(bidders):
        raise ValueError(
            f"ST-SR-IA needs as many tasks as bidders: {len(tasks)} tasks, {len(bidders)} bidders"
        )
    if len({t.sub_area for t in tasks}) != len(tasks):
        raise ValueError("each sub-area must have one task")
    if len({b.vehicle for b in bidders}) != len(bidders):
        raise ValueError("each vehicle must bid once")
    raw = np.array(
        [[b.flight_time_s, b.decision, b.communication] for b in bidders], dtype=float
    ).reshape(-1, 3)
    need = np.array([t.flight_time_s for t in tasks], dtype=float)
    if not (np.isfinite(raw).all() and np.isfinite(need).all()):
        raise ValueError("capabilities and required flight times must be finite")
    if not tasks:
        return AuctionResult({}, 0, ())
    bids = np.column_stack([eq2_scores(raw[:, k]) for k in range(3)])
    flight_cost = np.maximum(eq2_scores(need, raw[:, 0].min(), raw[:, 0].max()), 0.0)
    vehicles = np.array([b.vehicle for b in bidders])
    order = sorted(
        range(len(tasks)),
        key=lambda k: (_ORDER[tasks[k].role], -tasks[k].flight_time_s, tasks[k].sub_area),
    )
    free = np.ones(len(bidders), dtype=bool)
    assignment: dict[int, int] = {}
    log: list[str] = []
    rounds = 0
    for k in order:
        task = tasks[k]
        role = ROLE_SCORES[task.role]
        cost = np.array([flight_cost[k], role.decision, role.communication])
        key = KEY_SKILL[task.role]
        margin = bids - cost  # (bidders, 3)
        accepted = free & (margin >= 0.0).all(axis=1)
        head = f"sub-area {task.sub_area} ({task.role}, cost {np.round(cost, 2).tolist()}):"
        if accepted.any():
            winner, raises = _english_rounds(margin.min(axis=1), bids[:, key], vehicles, accepted)
            rounds += 1 + raises
            log.append(
                f"{head} {int(accepted.sum())} accepted, {raises} raises, "
                f"vehicle {vehicles[winner]} wins"
            )
        else:
            shortfall = np.maximum(-margin, 0.0).sum(axis=1)
            winner = _best(np.flatnonzero(free), shortfall, -bids[:, key], vehicles)
            rounds += 1
            log.append(
                f"{head} no bid meets the cost; fallback: vehicle {vehicles[winner]} "
                f"(smallest shortfall {shortfall[winner]:.2f})"
            )
        free[winner] = False
        assignment[task.sub_area] = int(vehicles[winner])
    return AuctionResult(assignment, rounds, tuple(log))


def _english_rounds(
    worst_margin: np.ndarray, key_score: np.ndarray, vehicles: np.ndarray, accepted: np.ndarray
) -> tuple[int, int]:
    """Raise the thresholds by THRESHOLD_STEP until one bidder is left: (winner row, raises).

    A bidder stays in for ``floor(worst_margin / step)`` raises; the rounds stop at the first raise
    that leaves at most one bidder in. If none is left, the last round's bidders tie.
    """
    rows = np.flatnonzero(accepted)
    stays = np.floor(worst_margin[rows] / THRESHOLD_STEP + 1e-9).astype(np.int64)
    if len(rows) == 1:
        return int(rows[0]), 0
    top = stays.max()
    runner_up = np.sort(stays)[-2]
    if runner_up < top:  # the top bidder alone survives raise runner_up + 1
        return int(rows[np.argmax(stays)]), int(runner_up) + 1
    tied = rows[stays == top]  # all drop out at raise top + 1
    return _best(tied, -key_score, np.zeros_like(key_score), vehicles), int(top) + 1


def _best(rows: np.ndarray, first: np.ndarray, second: np.ndarray, vehicles: np.ndarray) -> int:
    """The row of ``rows`` smallest in ``first``, then ``second``, then vehicle index."""
    return int(min(rows, key=lambda r: (first[r], second[r], vehicles[r])))
