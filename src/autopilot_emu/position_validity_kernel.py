"""Compiled validity flags of the position estimate (local and global), one call for all vehicles.

The estimator's ``local_position_ok`` / ``global_position_ok`` are read every navigation tick and
by telemetry; as numpy expressions they cost ten small array operations, here one call.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def position_validity(
    time_s: float,
    params: np.ndarray,
    noaid_tout_col: int,
    settle_s: float,
    attitude_ok: np.ndarray,
    hpos_aided_s: np.ndarray,
    first_aiding_s: np.ndarray,
    gps_fused_s: np.ndarray,
    origin_set: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """(local_ok, global_ok), each (N,) bool; EKF2_NOAID_TOUT is ``params[:, noaid_tout_col]``.

    (The whole (N, K) parameter table is passed, not a column view, so that the kernel has one
    signature for any N.)

    local: attitude aligned, a horizontal position source fused within EKF2_NOAID_TOUT, and the
    first aiding at least ``settle_s`` ago. global: local, an origin, and GNSS fused within
    EKF2_NOAID_TOUT. Comparisons with NaN are false, as in numpy.
    """
    n = attitude_ok.shape[0]
    local_ok = np.empty(n, dtype=np.bool_)
    global_ok = np.empty(n, dtype=np.bool_)
    for i in range(n):
        tout = params[i, noaid_tout_col]
        ok = (
            attitude_ok[i]
            and (time_s - hpos_aided_s[i]) <= tout
            and (time_s - first_aiding_s[i]) >= settle_s
        )
        local_ok[i] = ok
        global_ok[i] = ok and origin_set[i] and (time_s - gps_fused_s[i]) <= tout
    return local_ok, global_ok
