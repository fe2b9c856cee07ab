"""Seed 001's formation conservation (option 2, Sec. 3.4, Alg. 4; Eq. 8's AvgDistChange_i).

Pure; randomness from the generator passed in. Choices (digest 004_001 §6 item 7):

* **Reference**: the pairwise distances of the *start* positions (Alg. 4 line 1: every UAV
  reads all start points), :func:`reference_distances`.
* **Current**: the pairwise distances of everyone's latest broadcast positions (NaN where a
  position has not been heard), :func:`current_distances`.
* **Check: this UAV's row only**, the *median* over heard j != i of ``|d_ij - d_ij_ref|``
  below the threshold (:func:`in_formation`: the UAV out of place relative to most others
  restores, not its neighbours). The paper's O(X^4) suggests nested loops over all pairs, but
  a UAV can only mend the distances it is part of: checking all pairs would have every UAV
  divert for a pair it cannot affect. (Each UAV building the whole X x X array each tick is
  O(X^2) per UAV, O(X^3) for the swarm, the paper's count of ticks aside.)
* **Restoring point**: samples of the same ball as Alg. 2 (``avoidance.sample_ball``, radius
  R_s) scored by the row's squared error ``sum_j (|p - x_j(t_a)| - d_ij_ref)^2`` with the others
  predicted at the arrival time ``t_a = |p - x| / v`` from their broadcast velocities (so when
  the swarm moves on, the point moves on with it); the lowest-score point that is safe is
  adopted: one divergence. Safe: Alg. 2's tests (a) and (b) against the current path waypoint,
  and nearer that waypoint than the UAV is now (without this progress rule a swarm on different
  ACO paths chases its own formation and never arrives). None qualifies: keep the path.
* **AvgDistChange_i** (Eq. 8): the mean over this UAV's heard partners of ``|d_ij - d_ij_ref|``,
  averaged over the decisions of its flight (:class:`FormationTracker`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from companion.planning.aco.avoidance import (
    AvoidanceParams,
    Obstacle,
    course,
    feasible,
    min_gap,
    sample_ball,
)


def reference_distances(starts_enu_m: np.ndarray) -> np.ndarray:
    """(N, N) pairwise distances of the start positions, m (Alg. 4's reference array)."""
    p = np.asarray(starts_enu_m, float)
    return np.linalg.norm(p[:, None, :] - p[None, :, :], axis=-1)


def current_distances(positions_enu_m: np.ndarray) -> np.ndarray:
    """(N, N) pairwise distances of the latest positions ((N, 3), NaN rows unknown), m."""
    return reference_distances(positions_enu_m)


def row_deviation(i: int, current: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """``|d_ij - d_ij_ref|`` for j != i (NaN where j is unheard), m."""
    dev = np.abs(current[i] - reference[i])
    dev[i] = np.nan
    return dev


def in_formation(i: int, current: np.ndarray, reference: np.ndarray, threshold_m: float) -> bool:
    """Alg. 4's check on this UAV's row: the median heard ``|d_ij - d_ij_ref|`` < threshold.

    The median, not every entry: when one partner is out of place every row holding it breaks,
    and with "every entry" all UAVs would divert for it (tried: the swarm then chases its own
    formation at walking pace and never arrives); the median breaks only the row of the UAV that
    is out of place relative to most others, and that UAV restores. With one partner (two UAVs)
    the median is the entry: both restore.
    """
    dev = row_deviation(i, current, reference)
    heard = dev[np.isfinite(dev)]
    return bool(heard.size == 0 or np.median(heard) < threshold_m)


def restoring_point(
    i: int,
    here: np.ndarray,
    positions_enu_m: np.ndarray,
    velocities_enu_m_s: np.ndarray,
    reference: np.ndarray,
    speed_m_s: float,
    sensed: list[Obstacle],
    rng: np.random.Generator,
    params: AvoidanceParams = AvoidanceParams(),  # noqa: B008 (frozen)
    waypoint: np.ndarray | None = None,
) -> np.ndarray | None:
    """The sampled point that best restores row ``i`` and is safe (None: none qualifies).

    Safe: clears D_min on the way; with ``waypoint`` also Alg. 2's test (b) towards it, and the
    point must be nearer the waypoint than the UAV is (progress: the swarm still flies its paths).
    """
    here = np.asarray(here, float)
    wp = None if waypoint is None else np.asarray(waypoint, float)
    pos = np.asarray(positions_enu_m, float)
    vel = np.nan_to_num(np.asarray(velocities_enu_m_s, float))
    others = [j for j in range(len(pos)) if j != i and np.isfinite(pos[j]).all()]
    if not others:
        return None
    ref = reference[i, others]
    best, best_score = None, np.inf
    for _ in range(params.attempts):
        pts = sample_ball(here, params.sense_m, params.points, rng, params.z_min_m, params.z_max_m)
        t_a = np.linalg.norm(pts - here, axis=1) / speed_m_s
        future = pos[others][None, :, :] + vel[others][None, :, :] * t_a[:, None, None]
        err = ((np.linalg.norm(pts[:, None, :] - future, axis=-1) - ref) ** 2).sum(axis=1)
        for k in np.argsort(err, kind="stable"):
            if err[k] >= best_score:
                break
            if wp is not None:
                ok = np.linalg.norm(wp - pts[k]) < np.linalg.norm(wp - here) and feasible(
                    here, pts[k], wp, speed_m_s, sensed, params
                )
            else:
                ok = _clear_on_the_way(here, pts[k], speed_m_s, sensed, params)
            if ok:
                best, best_score = pts[k], float(err[k])
                break
        if best is not None:
            return best
    return best


def _clear_on_the_way(
    here: np.ndarray, point: np.ndarray, speed_m_s: float, sensed: list[Obstacle],
    params: AvoidanceParams,
) -> bool:  # fmt: skip
    u = course(here, point, speed_m_s)
    t_a = float(np.linalg.norm(point - here)) / speed_m_s
    return all(
        min_gap(here, u, ob, 0.0, t_a) >= min(params.d_min_m, ob.distance_m) for ob in sensed
    )


@dataclass
class FormationTracker:
    """Eq. 8's AvgDistChange_i of one UAV: its row's mean deviation, averaged over decisions."""

    total_m: float = 0.0
    samples: int = 0

    def add(self, i: int, current: np.ndarray, reference: np.ndarray) -> float:
        """Record one decision's mean ``|d_ij - d_ij_ref|`` over heard j (returned, m)."""
        dev = row_deviation(i, current, reference)
        heard = dev[np.isfinite(dev)]
        if heard.size == 0:
            return float("nan")
        mean = float(heard.mean())
        self.total_m += mean
        self.samples += 1
        return mean

    @property
    def avg_dist_change_m(self) -> float:
        """AvgDistChange_i, m (NaN before any decision with a partner heard)."""
        return self.total_m / self.samples if self.samples else float("nan")
