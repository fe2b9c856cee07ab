"""Seed 001's Alg. 4: reference array, the row check, a restoring point, AvgDistChange."""

from __future__ import annotations

import numpy as np
import pytest

from companion.planning.aco.avoidance import AvoidanceParams, obstacle
from companion.planning.aco.formation import (
    FormationTracker,
    current_distances,
    in_formation,
    reference_distances,
    restoring_point,
    row_deviation,
)

# a 3-4-5 right triangle plus a fourth UAV: independent distances by hand
STARTS = np.array([[0.0, 0, 20], [3.0, 0, 20], [0.0, 4, 20], [3.0, 4, 20]])


def test_reference_array_is_the_start_distances() -> None:
    """Symmetric, zero diagonal, the triangle's 3, 4, 5 m."""
    ref = reference_distances(STARTS)
    assert ref.shape == (4, 4) and np.allclose(ref, ref.T) and np.allclose(np.diag(ref), 0)
    assert ref[0, 1] == pytest.approx(3) and ref[0, 2] == pytest.approx(4)
    assert ref[1, 2] == pytest.approx(5) and ref[0, 3] == pytest.approx(5)


def test_threshold_check_on_own_row_and_unheard_partners() -> None:
    """A rigid translation keeps everyone in formation; moving UAV 3 0.15 m away from UAV 0 breaks
    its own row (median over partners) but not UAV 0's, where it is one entry of three;
    an unheard UAV (NaN) is left out of the check."""
    ref = reference_distances(STARTS)
    moved = STARTS + np.array([10.0, -3.0, 1.0])
    cur = current_distances(moved)
    assert all(in_formation(i, cur, ref, 0.1) for i in range(4))
    moved[3] += [0.09, 0.12, 0.0]  # d_03 +0.15, d_13 +0.12, d_23 +0.09
    cur = current_distances(moved)
    assert not in_formation(3, cur, ref, 0.1)  # its row: 0.15, 0.12, 0.09, median 0.12
    assert in_formation(0, cur, ref, 0.1)  # row 0: 0, 0, 0.15: the median is in, 3 restores
    assert in_formation(3, cur, ref, 0.2)
    moved[3] = np.nan  # not heard yet
    cur = current_distances(moved)
    assert in_formation(0, cur, ref, 0.1)
    assert np.isnan(row_deviation(0, cur, ref)[[0, 3]]).all()


@pytest.mark.parametrize("seed", range(5))
def test_displaced_uav_picks_a_restoring_point(seed: int) -> None:
    """UAV 3, pushed 2 m east, picks a point that reduces its row's error by most of it and is
    not nearer than D_min to an obstacle sensed beside it."""
    ref = reference_distances(STARTS)
    pos = STARTS.copy()
    pos[3, 0] += 2.0
    before = np.nansum(row_deviation(3, current_distances(pos), ref) ** 2)
    wall = obstacle(pos[3], pos[3] + [0, 2.0, 0], np.zeros(3), 1.75, "solid", "wall")
    p = restoring_point(
        3, pos[3], pos, np.zeros((4, 3)), ref, 6.0, [wall], np.random.default_rng(seed),
        AvoidanceParams(points=25),
    )  # fmt: skip
    assert p is not None
    after_pos = pos.copy()
    after_pos[3] = p
    after = np.nansum(row_deviation(3, current_distances(after_pos), ref) ** 2)
    assert after < 0.35 * before
    assert np.linalg.norm(p - wall.position_enu_m) - 0.25 >= 1.0 - 1e-9


def test_restoring_point_follows_the_moving_swarm() -> None:
    """The others fly east at 6 m/s: the chosen point lies east of the displaced UAV."""
    ref = reference_distances(STARTS)
    pos = STARTS.copy()
    pos[3, 1] += 1.0
    vel = np.tile([6.0, 0, 0], (4, 1))
    p = restoring_point(3, pos[3], pos, vel, ref, 6.0, [], np.random.default_rng(0))
    assert p is not None and p[0] > pos[3, 0] + 1.0


def test_tracker_averages_row_means_over_decisions() -> None:
    """AvgDistChange_i: the mean over partners, then over decisions (Eq. 8's input)."""
    ref = reference_distances(STARTS)
    t = FormationTracker()
    assert np.isnan(t.avg_dist_change_m)
    t.add(0, current_distances(STARTS), ref)  # 0
    pos = STARTS.copy()
    pos[1, 0] += 0.3  # d_01: 3.3 (0.3), d_02 4, d_03 5
    assert t.add(0, current_distances(pos), ref) == pytest.approx(0.1)
    assert t.avg_dist_change_m == pytest.approx(0.05)
