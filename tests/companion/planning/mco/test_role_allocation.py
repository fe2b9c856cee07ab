"""Role allocation of seed 004 (Sec. 4.2.3): one Master nearest p0, Coordinators around it."""

from __future__ import annotations

import numpy as np
import pytest

from companion.planning.mco.roles import ROLE_SCORES, Role, assign_roles


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("n", [1, 3, 5, 9, 16])
def test_counts_and_master_nearest_takeoff(seed, n):
    """One Master, min(4, n - 1) Coordinators; the Master's site is nearest p0; the Coordinators'
    sites are nearer the Master's than any Operator's (independent brute-force check)."""
    rng = np.random.default_rng(seed)
    sites = rng.uniform(0, 500, (n, 2))
    p0 = rng.uniform(0, 500, 2)
    roles = assign_roles(sites, p0)
    assert roles.count(Role.MASTER) == 1
    assert roles.count(Role.COORDINATOR) == min(4, n - 1)
    master = roles.index(Role.MASTER)
    assert np.linalg.norm(sites[master] - p0) == pytest.approx(
        np.linalg.norm(sites - p0, axis=1).min()
    )
    d = np.linalg.norm(sites - sites[master], axis=1)
    coord = [k for k, r in enumerate(roles) if r is Role.COORDINATOR]
    oper = [k for k, r in enumerate(roles) if r is Role.OPERATOR]
    if coord and oper:
        assert d[coord].max() <= d[oper].min()


def test_levels_each_get_a_master_and_coordinators():
    """Phase IV: two levels (two p0), one Master and 4 Coordinators in each."""
    rng = np.random.default_rng(3)
    a = rng.uniform(0, 100, (8, 2))
    b = rng.uniform(1000, 1100, (7, 2))
    sites = np.vstack([a, b])
    p0 = np.array([[50.0, 50.0], [1050.0, 1050.0]])
    for level in (None, np.array([0] * 8 + [1] * 7)):
        roles = assign_roles(sites, p0, level=level)
        assert roles[:8].count(Role.MASTER) == 1 and roles[8:].count(Role.MASTER) == 1
        assert roles[:8].count(Role.COORDINATOR) == 4 and roles[8:].count(Role.COORDINATOR) == 4


def test_bad_input_raises():
    with pytest.raises(ValueError, match="coordinators"):
        assign_roles(np.zeros((3, 2)), np.zeros(2), coordinators=-1)
    with pytest.raises(ValueError, match="level"):
        assign_roles(np.zeros((3, 2)), np.zeros(2), level=np.array([0, 1, 0]))


def test_master_asks_most_operator_least():
    """Sec. 4.2.3's order of demands: Master >= Coordinator >= Operator in each skill."""
    m, c, o = (ROLE_SCORES[r] for r in (Role.MASTER, Role.COORDINATOR, Role.OPERATOR))
    assert m.decision > c.decision > o.decision
    assert m.communication >= c.communication > o.communication
