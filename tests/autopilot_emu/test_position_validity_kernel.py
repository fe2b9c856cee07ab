"""The compiled position-validity flags against hand-checked cases."""

from __future__ import annotations

import math

import numpy as np

from autopilot_emu.estimator import EstimatorConfig, FleetEstimator
from autopilot_emu.position_validity_kernel import position_validity


def test_each_condition_alone_clears_the_flags() -> None:
    # Vehicle 0 valid everywhere; 1 no attitude; 2 aiding too old; 3 not settled; 4 no origin;
    # 5 GNSS too old (local still valid); 6 NaN aiding time (comparisons false, as numpy).
    n = 7
    t = 10.0
    tout = np.full(n, 1.0)
    attitude = np.ones(n, dtype=bool)
    attitude[1] = False
    hpos = np.full(n, 9.5)
    hpos[2] = 8.5
    hpos[6] = math.nan
    first = np.full(n, 2.0)
    first[3] = 9.5
    gps = np.full(n, 9.5)
    gps[5] = -np.inf
    origin = np.ones(n, dtype=bool)
    origin[4] = False
    local_ok, global_ok = position_validity(
        t, tout[:, None], 0, 1.0, attitude, hpos, first, gps, origin
    )
    assert local_ok.tolist() == [True, False, False, False, True, True, False]
    assert global_ok.tolist() == [True, False, False, False, False, False, False]


def test_boundaries_are_inclusive() -> None:
    one = np.ones(1, dtype=bool)
    local_ok, global_ok = position_validity(
        5.0, np.array([[1.0]]), 0, 1.0, one, np.array([4.0]), np.array([4.0]), np.array([4.0]), one
    )
    assert local_ok.tolist() == [True] and global_ok.tolist() == [True]


def test_estimator_properties_agree_with_the_numpy_definition() -> None:
    est = FleetEstimator(3, EstimatorConfig())
    est.attitude_ok[:] = [True, True, False]
    est.time_s = 20.0
    est.hpos_aided_s[:] = [19.9, 10.0, 19.9]
    est.first_aiding_s[:] = [5.0, 5.0, 5.0]
    est.gps_fused_s[:] = [19.9, 19.9, 19.9]
    est.origin_set[:] = True
    tout = est.params.noaid_tout_s
    aided = (est.time_s - est.hpos_aided_s) <= tout
    settled = (est.time_s - est.first_aiding_s) >= est.config.settle_s
    local = est.attitude_ok & aided & settled
    gps = (est.time_s - est.gps_fused_s) <= tout
    assert est.local_position_ok.tolist() == local.tolist() == [True, False, False]
    assert est.position_ok.tolist() == local.tolist()
    assert est.global_position_ok.tolist() == (local & est.origin_set & gps).tolist()
