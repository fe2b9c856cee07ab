"""Seed 001's Alg. 2: who keeps its course, where the other goes, divergences."""

from __future__ import annotations

import numpy as np
import pytest

from companion.planning.aco.avoidance import (
    Action,
    AvoidanceParams,
    avoid,
    feasible,
    obstacle,
    potential_collisions,
    sample_ball,
)

SPEED = 6.0
BODY = 0.25  # vehicle radius (0.5 m diameter, Sec. 4.1)


def _vehicle(here: np.ndarray, other: np.ndarray, vel: np.ndarray, priority: int | None) -> object:
    gap = float(np.linalg.norm(other - here)) - 2 * BODY
    return obstacle(here, other, vel, gap, "vehicle", "other", priority)


def _min_gap_flying(here, vel_self, point, other, vel_other, t_end, dt=0.01):
    """Brute-force least centre distance minus radii while flying to ``point`` then on."""
    best = np.inf
    x, q = here.copy(), other.copy()
    for _ in range(int(t_end / dt)):
        d = point - x
        n = np.linalg.norm(d)
        step = d / n * SPEED * dt if n > SPEED * dt else d
        x = x + step
        q = q + vel_other * dt
        best = min(best, np.linalg.norm(q - x) - 2 * BODY)
    return best


@pytest.mark.parametrize("seed", [0, 1, 2, 3, 4])
def test_head_on_pair_lower_priority_diverts_higher_keeps(seed: int) -> None:
    """Two UAVs 4 m apart head-on at 6 m/s each: priority 1 keeps, priority 2 adopts a point
    that, flown against the keeper's straight course, keeps the pair at least D_min apart."""
    a, b = np.array([0.0, 0.0, 20.0]), np.array([4.5, 0.0, 20.0])
    va, vb = np.array([SPEED, 0, 0]), np.array([-SPEED, 0, 0])
    ta, tb = np.array([100.0, 0, 20]), np.array([-100.0, 0, 20])
    rng = np.random.default_rng(seed)
    keep = avoid(a, ta, ta, 1, [_vehicle(a, b, vb, 2)], SPEED, rng)
    assert keep.action is Action.KEEP and keep.conflicts == ("other",)
    d = avoid(b, tb, tb, 2, [_vehicle(b, a, va, 1)], SPEED, rng)
    assert d.action is Action.DIVERT and d.diverge
    assert np.linalg.norm(d.point - b) <= 5.0 + 1e-9
    # independent check: simulate the keeper straight and the diverter to its point
    assert _min_gap_flying(b, vb, d.point, a, va, np.linalg.norm(d.point - b) / SPEED) >= 1.0 - 0.02


def test_unknown_priority_and_solids_make_both_divert() -> None:
    """A vehicle not yet heard from is not outranked; a solid has no priority."""
    a, b = np.array([0.0, 0.0, 20.0]), np.array([4.0, 0.0, 20.0])
    rng = np.random.default_rng(0)
    d = avoid(a, [50, 0, 20], [50, 0, 20], 1, [_vehicle(a, b, np.zeros(3), None)], SPEED, rng)
    assert d.action is Action.DIVERT


def test_no_conflict_when_passing_wide_or_moving_away() -> None:
    """A vehicle 3 m to the side on a parallel course, or one behind moving away, is no conflict."""
    a = np.array([0.0, 0.0, 20.0])
    side = _vehicle(a, np.array([2.0, 3.0, 20.0]), np.array([SPEED, 0, 0]), 5)
    behind = _vehicle(a, np.array([-3.0, 0.0, 20.0]), np.array([-2.0, 0, 0]), 5)
    p = AvoidanceParams()
    assert potential_collisions(a, np.array([50.0, 0, 20]), SPEED, [side, behind], p) == []
    d = avoid(a, [50, 0, 20], [50, 0, 20], 9, [side, behind], SPEED, np.random.default_rng(0))
    assert d.action is Action.KEEP and d.conflicts == ()


@pytest.mark.parametrize("seed", range(5))
def test_static_obstacle_on_the_path_is_avoided_with_a_point_clearing_d_min(seed: int) -> None:
    """A static solid 3 m ahead on the course (nearest surface point reported): the chosen point
    clears D_min at arrival and the course from it to the target passes the point > D_min."""
    here = np.array([0.0, 0.0, 20.0])
    surface = np.array([3.0, 0.0, 20.0])
    ob = obstacle(here, surface, np.zeros(3), 3.0 - BODY, "solid", "obstacle_0")
    target = np.array([40.0, 0.0, 20.0])
    params = AvoidanceParams(d_min_m=1.0)
    d = avoid(here, target, target, 1, [ob], SPEED, np.random.default_rng(seed), params)
    assert d.action is Action.DIVERT
    p = d.point
    assert np.linalg.norm(p - surface) - BODY >= 1.0
    # the line from p to the target passes the surface point beyond D_min
    seg = target - p
    t = np.clip((surface - p) @ seg / (seg @ seg), 0, 1)
    assert np.linalg.norm(p + t * seg - surface) - BODY >= 1.0
    # and the point is a short detour: chosen by |p - x| + |target - p|, not far off
    assert np.linalg.norm(p - here) + np.linalg.norm(target - p) < np.linalg.norm(target - here) + 2


def test_divergences_count_one_per_adopted_point_and_hold_when_boxed_in() -> None:
    """Repeated ticks with a conflict give one divergence each; surrounded: hold, no divergence."""
    here = np.array([0.0, 0.0, 20.0])
    target = np.array([40.0, 0.0, 20.0])
    ahead = obstacle(here, np.array([2.5, 0, 20]), np.zeros(3), 2.25, "solid", "s")
    rng = np.random.default_rng(1)
    decisions = [avoid(here, target, target, 1, [ahead], SPEED, rng) for _ in range(4)]
    assert sum(d.diverge for d in decisions) == 4
    # a shell of solids 1.2 m around it: every point within R_s is either too close or blocked
    dirs = sample_ball(np.zeros(3), 1.0, 400, np.random.default_rng(2), -9, 9)
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    shell = [obstacle(here, here + 1.2 * u, np.zeros(3), 1.2 - BODY, "solid", "w") for u in dirs]
    d = avoid(here, target, target, 1, shell, SPEED, rng)
    assert d.action is Action.HOLD and not d.diverge and d.point is None


def test_samples_are_in_the_ball_and_above_the_floor() -> None:
    """Sampling: within R_s of the UAV, never below z_min."""
    pts = sample_ball(np.array([0, 0, 3.0]), 5.0, 2000, np.random.default_rng(0), 2.0, 99.0)
    assert (np.linalg.norm(pts - [0, 0, 3.0], axis=1) <= 5.0 + 1e-9).all()
    assert pts[:, 2].min() >= 2.0
    # uniform in volume (no floor in reach): about half lie beyond 5 * 0.5^(1/3) = 3.97 m
    pts = sample_ball(np.array([0, 0, 30.0]), 5.0, 2000, np.random.default_rng(0), 2.0, 99.0)
    far = (np.linalg.norm(pts - [0, 0, 30.0], axis=1) > 3.97).mean()
    assert 0.4 < far < 0.6


def test_feasible_rejects_a_point_behind_a_moving_vehicle() -> None:
    """A point the other vehicle will occupy at arrival is rejected."""
    here = np.array([0.0, 0.0, 20.0])
    other = np.array([0.0, 4.0, 20.0])
    ob = _vehicle(here, other, np.array([0.0, -3.0, 0.0]), 3)
    p = np.array([0.0, 1.5, 20.0])  # it arrives in 0.25 s, the other is at y = 3.25
    assert not feasible(here, p, np.array([0, 40.0, 20]), SPEED, [ob], AvoidanceParams())
