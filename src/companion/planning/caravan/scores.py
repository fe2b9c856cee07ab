"""Seed 003's bid (Eq. 26) and the parameters of the three allocators and of the role.

Eq. (26), seed 003: ``s_k = a_k exp(-lambda t_v)``, t_v the shortest travel time to the task.
Sec. 4.1 prints the score as Eq. (28), ``s = a lambda^(-t)``, which with lambda = 0.1 *grows* with
t (0.1^-t = 10^t), against the text ("the longer it takes ..., the lower the score") and Eq. (26);
we use Eq. (26) (digest gap 1).

t_v is the visit time of the task's vertex (Sec. 3.5), counted from the start of the mission: the
time now plus the shortest travel time (``CaravanParams.bids``). A bid is then what the task adds
to the fleet's score J (``optimum``) if the agent flies there now; it stays the same while the
agent flies to the task and never rises as time passes, so that an agent's fresh score is never
above the bid it sent earlier (the auction's consensus then cannot cycle).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

ALGORITHMS = ("icf", "ica", "gbaa")
"""The allocators: ICF (CarA), ICA (Alighanbari & How 2005), GBAA (Brunet 2008)."""


def bid(a: float, lam: float, t: np.ndarray | float) -> np.ndarray:
    """Eq. (26), seed 003: the score ``a exp(-lam t)`` of a task reached after ``t`` s."""
    return a * np.exp(-lam * np.asarray(t, dtype=float))


@dataclass(frozen=True)
class CaravanParams:
    """Parameters of the allocators (seed 003, Sec. 4.1) and of the caravan role's flight."""

    algorithm: str = "icf"
    """Which allocator: ``icf`` (CarA), ``ica`` or ``gbaa``."""
    reward: float = 1000.0
    """a, the reward of every task (Sec. 4.1), score units."""
    discount_per_s: float = 0.1
    """lambda, the discount of Eq. (26), 1/s (Sec. 4.1: 0.1; 0 <= lambda <= 1, Sec. 3.5)."""
    epsilon: float = 1e-6
    """epsilon of Eq. (18): a challenger must beat the winning bid by more, score units."""
    speed_m_s: float = 1.0
    """Constant flight speed, m/s (NOT GIVEN in seed 003; unit speed on a ~10 m map matches the
    execution times of Table 3, digest gap 2)."""
    release_timeout_s: float = 3.0
    """delta of Eq. (22): an owner not heard of for this long loses its task, s. NOT GIVEN in
    seed 003 (digest gap 5). 3 s is 15 consensus steps at 5 Hz: far longer than a relay across
    a connected fleet (one step per hop) and a short dropout, and short beside a mission of
    10-20 s on a 10 m map at 1 m/s, so that an orphaned task is still worth re-assigning."""
    arrive_tolerance_m: float = 0.25
    """Eq. (19)'s ``l_i = l_J`` for continuous motion: horizontally this close, m (half the
    0.5 m grid spacing, so the vehicle is at the task's vertex; digest gap 11)."""
    altitude_m: float = 3.0
    """Flight height of the role's first vehicle, m (swarm adapter)."""
    altitude_step_m: float = 0.5
    """Height added per role index, m: the paper's staggered altitudes (Sec. 4.1)."""
    decision_period_s: float = 0.2
    """Time between two consensus steps of the MAVSDK adapter (``python -m
    companion.scripts.caravan``), vehicle (simulated) s. At swarm fidelity the engine's
    ``decision_hz`` sets it instead and this field is not read; 0.2 s is the 5 Hz of seed 003's
    experiment (``harness.experiments.seed003``), so both fidelities step alike by default."""

    def __post_init__(self) -> None:
        if self.algorithm not in ALGORITHMS:
            raise ValueError(f"algorithm: {self.algorithm!r}, expected one of {ALGORITHMS}")
        checks = (
            ("reward", lambda v: v > 0, "> 0"),
            ("discount_per_s", lambda v: 0.0 <= v <= 1.0, "in [0, 1]"),
            ("epsilon", lambda v: v >= 0, ">= 0"),
            ("speed_m_s", lambda v: v > 0, "> 0"),
            ("release_timeout_s", lambda v: v > 0, "> 0"),
            ("arrive_tolerance_m", lambda v: v > 0, "> 0"),
            ("altitude_m", lambda v: v > 0, "> 0"),
            ("altitude_step_m", lambda v: v >= 0, ">= 0"),
            ("decision_period_s", lambda v: v > 0, "> 0"),
        )
        for name, ok, want in checks:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ValueError(f"{name}: must be a number, got {value!r}")
            if not (math.isfinite(value) and ok(value)):
                raise ValueError(f"{name}: must be {want} and finite, got {value!r}")

    def scores(self, times_s: np.ndarray) -> np.ndarray:
        """Eq. (26) at these times, with this ``reward`` and ``discount_per_s``."""
        return bid(self.reward, self.discount_per_s, times_s)

    def bids(self, now_s: float, travel_times_s: np.ndarray) -> np.ndarray:
        """An agent's bid vector: Eq. (26) at the visit times ``now_s + travel_times_s``."""
        return self.scores(now_s + np.asarray(travel_times_s, dtype=float))
