"""Compiled per-tick work of the fleet filter (``FleetEstimator``): one kernel call per stage.

Each kernel loops over the vehicles of the arrays laid out in ``estimator_layout`` (attitude
``q`` and rotations ``rot``, 3-vectors ``v3``, scalars ``s1``, ``flags``, covariances ``cov``,
parameters ``prm``, fleet-wide ``scalars``) and updates them in place. The mathematics is the
filter's (see the ``estimator`` module docstring); the kernels fuse what the numpy code did in
many small array operations into one pass per call.

A scalar fusion "applied to the fleet" with a per-vehicle mask corrects the vehicles in the mask
and, when any vehicle is corrected, applies a zero correction to the others (their quaternion is
renormalised and their bias estimates clamped to the current limits), as the vectorised update
does.

Samples and masks from callers are accepted in any layout; the filter's own arrays are
C-contiguous. Each kernel has one explicit signature, so it compiles once (cached beside the
package). Scratch space is always ``np.zeros((rows, cols))`` and loops over the 15 error states
have run-time trip counts: both keep the cold compile short.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from autopilot_emu.estimator_layout import (
    B_CORR_YAW,
    B_POS,
    B_Q,
    B_VEL,
    F_ATT_OK,
    F_BARO_REF,
    F_CONST_POS,
    F_GPS_GLITCH,
    F_ORIGIN,
    P_ABIAS_LIM,
    P_ACC_B_NOISE,
    P_ACC_NOISE,
    P_BARO_GATE,
    P_BARO_NOISE,
    P_GPS_DELAY,
    P_GPS_P_GATE,
    P_GPS_P_NOISE,
    P_GPS_V_GATE,
    P_GPS_V_NOISE,
    P_GYR_B_NOISE,
    P_GYR_NOISE,
    P_HDG_GATE,
    P_HEAD_NOISE,
    P_MAG_DECL,
    P_MAG_NOISE,
    P_NOAID_NOISE,
    P_NOAID_TOUT,
    S_ACC_TAU,
    S_FAKE_NEXT,
    S_FAKE_PERIOD,
    S_GBIAS_LIM,
    S_HEAD,
    S_PRED_DT,
    S_PREDICT_PERIOD,
    S_PREFLIGHT_STD,
    S_RESET_TIMEOUT,
    S_TIME,
    T_BARO_OFF,
    T_CORR_YAW,
    T_EV_FUSED,
    T_FIRST_AID,
    T_GPS_FUSED,
    T_HGT_AIDED,
    T_HORIZ_RATIO,
    T_HPOS_AIDED,
    T_MAG_ACCEPTED,
    T_MAG_RATIO,
    T_MAG_SEEN,
    T_VEL_RATIO,
    T_VERT_RATIO,
    V_ACC_DV,
    V_ACC_NED,
    V_BA,
    V_BG,
    V_CORR_P,
    V_CORR_V,
    V_FAKE,
    V_ORIGIN,
    V_POS,
    V_PRED_DV,
    V_VEL,
)

GRAVITY_M_S2 = 9.80665
TH, VEL, POS, BG, BA = 0, 3, 6, 9, 12
"""First index of each block of the 15-element error state [dtheta, dv, dp, dbg, dba]."""

_Q = "f8[:, ::1]"
_ROT = "f8[:, :, ::1]"
_V3 = "f8[:, :, ::1]"
_S1 = "f8[:, ::1]"
_FLAGS = "b1[:, ::1]"
_COV = "f8[:, :, ::1]"
_PRM = "f8[:, ::1]"
_VEC = "f8[::1]"
_BUF = "f8[:, :, ::1]"
_IN2 = "f8[:, :]"
_IN1 = "f8[:]"
_MASK = "b1[:]"
"""Argument types: the filter's arrays are C-contiguous, callers' samples any layout."""

_helper = numba.njit(
    cache=True, nogil=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True
)
"""Helpers are only called from kernels: no Python or C wrapper is generated (compile time)."""


def _kernel(*args: str) -> numba.core.registry.CPUDispatcher:
    """Compile a kernel for exactly one signature (void return), cached beside the package."""
    return numba.njit("void(" + ", ".join(args) + ")", cache=True, nogil=True, error_model="numpy")


# -- per-vehicle helpers ------------------------------------------------------------------------
@_helper
def _maxn(a: float, b: float) -> float:
    """numpy.maximum of two floats (NaN if either is NaN)."""
    if a != a or a >= b:
        return a
    return b


@_helper
def _set_q(q: np.ndarray, rot: np.ndarray, i: int, w: float, a: float, b: float, c: float) -> None:
    """Store the normalised quaternion (w, a, b, c) of vehicle i and its rotation matrix."""
    norm = math.sqrt(w * w + a * a + b * b + c * c)
    w, a, b, c = w / norm, a / norm, b / norm, c / norm
    q[i, 0], q[i, 1], q[i, 2], q[i, 3] = w, a, b, c
    r = rot[i]
    r[0, 0] = w * w + a * a - b * b - c * c
    r[0, 1] = 2.0 * (a * b - w * c)
    r[0, 2] = 2.0 * (a * c + w * b)
    r[1, 0] = 2.0 * (a * b + w * c)
    r[1, 1] = w * w - a * a + b * b - c * c
    r[1, 2] = 2.0 * (b * c - w * a)
    r[2, 0] = 2.0 * (a * c - w * b)
    r[2, 1] = 2.0 * (b * c + w * a)
    r[2, 2] = w * w - a * a - b * b + c * c


@_helper
def _inject(
    q: np.ndarray,
    rot: np.ndarray,
    v3: np.ndarray,
    s1: np.ndarray,
    i: int,
    dx: np.ndarray,
    lim_g: float,
    lim_a: float,
) -> None:
    """Add the error-state correction dx (15,) to vehicle i's nominal state.

    The rotation error is global: q <- normalise([1, dtheta/2] ⊗ q). The bias estimates are
    clamped to +-lim_g and +-lim_a (NaN passes through, as with numpy.minimum/maximum).
    """
    p0, p1, p2 = 0.5 * dx[TH], 0.5 * dx[TH + 1], 0.5 * dx[TH + 2]
    w, a, b, c = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
    _set_q(
        q,
        rot,
        i,
        w - p0 * a - p1 * b - p2 * c,
        a + p0 * w + p1 * c - p2 * b,
        b - p0 * c + p1 * w + p2 * a,
        c + p0 * b - p1 * a + p2 * w,
    )
    s1[T_CORR_YAW, i] += dx[TH + 2]
    for k in range(3):
        v3[V_VEL, i, k] += dx[VEL + k]
        v3[V_POS, i, k] += dx[POS + k]
        v3[V_CORR_V, i, k] += dx[VEL + k]
        v3[V_CORR_P, i, k] += dx[POS + k]
        for block, lim in ((V_BG, lim_g), (V_BA, lim_a)):
            value = v3[block, i, k] + dx[(BG if block == V_BG else BA) + k]
            if value < -lim:
                value = -lim
            elif value > lim:
                value = lim
            v3[block, i, k] = value


@_helper
def _fuse(
    q: np.ndarray,
    rot: np.ndarray,
    v3: np.ndarray,
    s1: np.ndarray,
    cov: np.ndarray,
    prm: np.ndarray,
    scalars: np.ndarray,
    i: int,
    h: np.ndarray,
    innov: float,
    var: float,
    scratch: np.ndarray,
) -> None:
    """Scalar Kalman update of vehicle i with measurement row h (15,); scratch is (2, 15).

    K = P h / (h P h + var), P <- P - K (P h)^T, x <- x + K innov.
    """
    p = cov[i]
    nk = p.shape[0]  # a run-time trip count: LLVM does not unroll the 15x15 loops (compile time)
    pht, dx = scratch[0], scratch[1]
    for a in range(nk):
        acc = 0.0
        for b in range(nk):
            acc += p[a, b] * h[b]
        pht[a] = acc
    s = 0.0
    for a in range(nk):
        s += h[a] * pht[a]
    gain = 1.0 / (s + var)
    for a in range(nk):
        ka = pht[a] * gain
        for b in range(nk):
            p[a, b] -= ka * pht[b]
        dx[a] = ka * innov
    _inject(q, rot, v3, s1, i, dx, scalars[S_GBIAS_LIM], prm[i, P_ABIAS_LIM])


@_helper
def _fuse_masked(
    q: np.ndarray,
    rot: np.ndarray,
    v3: np.ndarray,
    s1: np.ndarray,
    cov: np.ndarray,
    prm: np.ndarray,
    scalars: np.ndarray,
    h: np.ndarray,
    innov: np.ndarray,
    var: np.ndarray,
    use: np.ndarray,
) -> None:
    """Scalar update with rows h (N, 15) of the vehicles where use (N,) is non-zero.

    One masked fleet update: when any vehicle is updated, the others get a zero correction.
    """
    n, nk = q.shape[0], cov.shape[1]
    any_use = False
    for i in range(n):
        any_use |= use[i] != 0
    if not any_use:
        return
    scratch = np.zeros((3, nk))
    for i in range(n):
        if use[i] != 0:
            _fuse(q, rot, v3, s1, cov, prm, scalars, i, h[i], innov[i], var[i], scratch)
        else:
            _inject(q, rot, v3, s1, i, scratch[2], scalars[S_GBIAS_LIM], prm[i, P_ABIAS_LIM])


@_helper
def _predict(
    rot: np.ndarray, v3: np.ndarray, cov: np.ndarray, prm: np.ndarray, i: int, dt: float
) -> None:
    """P <- Phi P Phi^T + Q of vehicle i over dt, Phi = I + F dt (4 sparse 3x3 blocks).

    The rotation is the current one; the specific-force block is [sum f_ned dt]x, from the
    velocity change accumulated since the last prediction.
    """
    p = cov[i]
    nk = p.shape[0]
    a = np.zeros((nk + 6, nk))
    rdt, sdt = a[nk : nk + 3, :3], a[nk + 3 :, :3]
    for r in range(3):
        for c in range(3):
            rdt[r, c] = rot[i, r, c] * dt
    f0, f1, f2 = v3[V_PRED_DV, i, 0], v3[V_PRED_DV, i, 1], v3[V_PRED_DV, i, 2]
    sdt[0, 1], sdt[0, 2], sdt[1, 2] = -f2, f1, -f0
    sdt[1, 0], sdt[2, 0], sdt[2, 1] = f2, -f1, f0
    # a = Phi P (row blocks).
    for c in range(nk):
        for r in range(nk):
            a[r, c] = p[r, c]
        for r in range(3):
            acc_g, acc_s, acc_a = 0.0, 0.0, 0.0
            for b in range(3):
                acc_g += rdt[r, b] * p[BG + b, c]
                acc_s += sdt[r, b] * p[TH + b, c]
                acc_a += rdt[r, b] * p[BA + b, c]
            a[TH + r, c] -= acc_g
            a[VEL + r, c] -= acc_s + acc_a
            a[POS + r, c] += dt * p[VEL + r, c]
    # P = a Phi^T (column blocks).
    for r in range(nk):
        for c in range(nk):
            p[r, c] = a[r, c]
        for c in range(3):
            acc_g, acc_s, acc_a = 0.0, 0.0, 0.0
            for b in range(3):
                acc_g += rdt[c, b] * a[r, BG + b]
                acc_s += sdt[c, b] * a[r, TH + b]
                acc_a += rdt[c, b] * a[r, BA + b]
            p[r, TH + c] -= acc_g
            p[r, VEL + c] -= acc_s + acc_a
            p[r, POS + c] += dt * a[r, VEL + c]
    # Process noise per step (EKF2_GYR_NOISE, _ACC_NOISE, _GYR_B_NOISE, _ACC_B_NOISE), symmetrised.
    for k in range(3):
        p[TH + k, TH + k] += (prm[i, P_GYR_NOISE] * dt) ** 2
        p[VEL + k, VEL + k] += (prm[i, P_ACC_NOISE] * dt) ** 2
        p[BG + k, BG + k] += (prm[i, P_GYR_B_NOISE] * dt) ** 2
        p[BA + k, BA + k] += (prm[i, P_ACC_B_NOISE] * dt) ** 2
    for r in range(nk):
        for c in range(r, nk):
            s = 0.5 * (p[r, c] + p[c, r])
            p[r, c] = s
            p[c, r] = s


@_helper
def _fuse_fake_position(
    q: np.ndarray,
    rot: np.ndarray,
    v3: np.ndarray,
    s1: np.ndarray,
    flags: np.ndarray,
    cov: np.ndarray,
    prm: np.ndarray,
    scalars: np.ndarray,
) -> None:
    """Hold a fake position (and height) while nothing aids them (EKF2's fake position).

    Its noise is the preflight value before any aiding, EKF2_NOAID_NOISE after a loss of aiding.
    The three axes are three masked fleet updates in turn (north, east, down).
    """
    n, nk = q.shape[0], cov.shape[1]
    t = scalars[S_TIME]
    # Rows: 0 no aiding, 1 no height aiding, 2 noise variance, 3 innovation (per vehicle).
    work = np.zeros((4, n))  # per vehicle (n columns); the rows h have nk
    no_aid, no_height, var, innov = work[0], work[1], work[2], work[3]
    h = np.zeros((n, nk))
    for i in range(n):
        tout = prm[i, P_NOAID_TOUT]
        lost = flags[F_ATT_OK, i] and (t - s1[T_HPOS_AIDED, i]) > tout
        no_aid[i] = lost
        no_height[i] = lost and (t - s1[T_HGT_AIDED, i]) > tout
        if lost and not flags[F_CONST_POS, i]:
            for k in range(3):
                v3[V_FAKE, i, k] = v3[V_POS, i, k]
        flags[F_CONST_POS, i] = lost or (flags[F_CONST_POS, i] and not flags[F_ATT_OK, i])
        std = prm[i, P_NOAID_NOISE]
        if not math.isfinite(s1[T_FIRST_AID, i]):
            std = scalars[S_PREFLIGHT_STD]
        var[i] = std * std
    for k in range(3):
        for i in range(n):
            innov[i] = v3[V_FAKE, i, k] - v3[V_POS, i, k]
            h[i, POS + k] = 1.0
            h[i, POS + k - 1] = 0.0
        mask = no_height if k == 2 else no_aid
        _fuse_masked(q, rot, v3, s1, cov, prm, scalars, h, innov, var, mask)


@_helper
def _delayed_slot(buf_t: np.ndarray, head: int, target_s: float) -> int:
    """Ring-buffer row of the latest sample at or before target_s (the oldest if none is)."""
    length = buf_t.shape[0]
    for back in range(length):
        row = (head - back) % length
        if buf_t[row] <= target_s:
            return row
    return (head + 1) % length


@_helper
def _reset_block(cov: np.ndarray, i: int, j: int, var: float) -> None:
    """Zero the rows and columns of the 3-state block at j of vehicle i; var on its diagonal."""
    nk = cov.shape[1]
    for k in range(3):
        for m in range(nk):
            cov[i, j + k, m] = 0.0
            cov[i, m, j + k] = 0.0
    for k in range(3):
        cov[i, j + k, j + k] = var


# -- kernels ------------------------------------------------------------------------------------
@_helper
def _imu_step(
    q: np.ndarray,
    rot: np.ndarray,
    v3: np.ndarray,
    s1: np.ndarray,
    flags: np.ndarray,
    cov: np.ndarray,
    prm: np.ndarray,
    scalars: np.ndarray,
    buf: np.ndarray,
    buf_t: np.ndarray,
    accel: np.ndarray,
    gyro: np.ndarray,
    dt: float,
    rates_out: np.ndarray,
) -> None:
    """One IMU sample of every vehicle: strapdown step, covariance prediction, buffer, fake pos.

    The covariance is predicted when EKF2_PREDICT_US has elapsed, the fake position fused at
    its period; the delayed-state buffer gets one row. Bias-corrected rates go to rates_out.
    """
    n = q.shape[0]
    t = scalars[S_TIME] + dt
    scalars[S_TIME] = t
    half_dt2 = 0.5 * dt * dt
    for i in range(n):
        fb0 = accel[i, 0] - v3[V_BA, i, 0]
        fb1 = accel[i, 1] - v3[V_BA, i, 1]
        fb2 = accel[i, 2] - v3[V_BA, i, 2]
        for r in range(3):
            f = rot[i, r, 0] * fb0 + rot[i, r, 1] * fb1 + rot[i, r, 2] * fb2
            acc = f + GRAVITY_M_S2 if r == 2 else f + 0.0
            v3[V_POS, i, r] += v3[V_VEL, i, r] * dt + half_dt2 * acc
            v3[V_VEL, i, r] += acc * dt
            v3[V_ACC_DV, i, r] += acc * dt
            v3[V_PRED_DV, i, r] += f * dt
            rates_out[i, r] = gyro[i, r] - v3[V_BG, i, r]
        # q <- normalise(q + q ⊗ (0, w dt / 2)).
        h0 = 0.5 * dt * rates_out[i, 0]
        h1 = 0.5 * dt * rates_out[i, 1]
        h2 = 0.5 * dt * rates_out[i, 2]
        w, a, b, c = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
        _set_q(
            q,
            rot,
            i,
            w + (-a * h0 - b * h1 - c * h2),
            a + (w * h0 + b * h2 - c * h1),
            b + (w * h1 - a * h2 + c * h0),
            c + (w * h2 + a * h1 - b * h0),
        )
    pred_dt = scalars[S_PRED_DT] + dt
    scalars[S_PRED_DT] = pred_dt
    if pred_dt >= scalars[S_PREDICT_PERIOD] - 1e-9:
        for i in range(n):
            _predict(rot, v3, cov, prm, i, pred_dt)
            for k in range(3):
                v3[V_PRED_DV, i, k] = 0.0
        scalars[S_PRED_DT] = 0.0
    head = (int(scalars[S_HEAD]) + 1) % buf_t.shape[0]
    scalars[S_HEAD] = head
    buf_t[head] = t
    for i in range(n):
        for k in range(3):
            buf[head, i, B_POS + k] = v3[V_POS, i, k] - v3[V_CORR_P, i, k]
            buf[head, i, B_VEL + k] = v3[V_VEL, i, k] - v3[V_CORR_V, i, k]
        for k in range(4):
            buf[head, i, B_Q + k] = q[i, k]
        buf[head, i, B_CORR_YAW] = s1[T_CORR_YAW, i]
    if t >= scalars[S_FAKE_NEXT]:
        scalars[S_FAKE_NEXT] = t + scalars[S_FAKE_PERIOD]
        _fuse_fake_position(q, rot, v3, s1, flags, cov, prm, scalars)


@_kernel(_V3, _VEC, "f8")
def acceleration_step(v3: np.ndarray, scalars: np.ndarray, dt: float) -> None:
    """Low-pass the mean NED acceleration of the last dt into V_ACC_NED; restart the sum."""
    alpha = dt / (scalars[S_ACC_TAU] + dt)
    for i in range(v3.shape[1]):
        for k in range(3):
            cur = v3[V_ACC_NED, i, k]
            v3[V_ACC_NED, i, k] = cur + alpha * (v3[V_ACC_DV, i, k] / dt - cur)
            v3[V_ACC_DV, i, k] = 0.0


@_helper
def _mag_step(
    q: np.ndarray,
    rot: np.ndarray,
    v3: np.ndarray,
    s1: np.ndarray,
    flags: np.ndarray,
    cov: np.ndarray,
    prm: np.ndarray,
    scalars: np.ndarray,
    mag: np.ndarray,
    mask: np.ndarray,
) -> None:
    """Magnetic heading fusion of the vehicles in mask that have an attitude (EKF2_HDG_GATE)."""
    n, nk = q.shape[0], cov.shape[1]
    t = scalars[S_TIME]
    any_use = False
    for i in range(n):
        any_use |= mask[i] and flags[F_ATT_OK, i]
    if not any_use:
        return
    # Rows: 0 accepted, 1 innovation, 2 variance (per vehicle); h: measurement rows.
    work = np.zeros((3, n))  # per vehicle (n columns); the rows h have nk
    ok, innovs, variances = work[0], work[1], work[2]
    h = np.zeros((n, nk))
    for i in range(n):
        if not (mask[i] and flags[F_ATT_OK, i]):
            continue
        r = rot[i]
        m0 = r[0, 0] * mag[i, 0] + r[0, 1] * mag[i, 1] + r[0, 2] * mag[i, 2]
        m1 = r[1, 0] * mag[i, 0] + r[1, 1] * mag[i, 1] + r[1, 2] * mag[i, 2]
        m_h = _maxn(math.hypot(m0, m1), 1e-6)
        # Innovation wrapped to [-pi, pi) (floor modulo, as numpy's).
        innov = (prm[i, P_MAG_DECL] - math.atan2(m1, m0) + math.pi) % (2.0 * math.pi) - math.pi
        std = _maxn(prm[i, P_HEAD_NOISE], prm[i, P_MAG_NOISE] / m_h)
        var = std * std
        # Derivative of the ZYX yaw with respect to the NED rotation error.
        horiz2 = _maxn(r[0, 0] * r[0, 0] + r[1, 0] * r[1, 0], 1e-6)
        h[i, TH] = -r[0, 0] * r[2, 0] / horiz2
        h[i, TH + 1] = -r[1, 0] * r[2, 0] / horiz2
        h[i, TH + 2] = 1.0
        p = cov[i]
        s = 0.0
        for a in range(nk):
            acc = 0.0
            for b in range(nk):
                acc += p[a, b] * h[i, b]
            s += h[i, a] * acc
        gate = prm[i, P_HDG_GATE]
        ratio = innov * innov / (gate * gate * (s + var))
        s1[T_MAG_RATIO, i] = math.sqrt(ratio)
        s1[T_MAG_SEEN, i] = t
        if ratio <= 1.0:
            ok[i] = 1.0
            s1[T_MAG_ACCEPTED, i] = t
        innovs[i] = innov
        variances[i] = var
    _fuse_masked(q, rot, v3, s1, cov, prm, scalars, h, innovs, variances, ok)


@_helper
def _baro_step(
    q: np.ndarray,
    rot: np.ndarray,
    v3: np.ndarray,
    s1: np.ndarray,
    flags: np.ndarray,
    cov: np.ndarray,
    prm: np.ndarray,
    scalars: np.ndarray,
    pressure_alt: np.ndarray,
    mask: np.ndarray,
) -> None:
    """Barometric height fusion of the vehicles in mask, gated by EKF2_BARO_GATE.

    Without an origin the first sample sets the barometer's reference; a height rejected for
    longer than the reset timeout is reset to the barometer (EKF2).
    """
    n, nk = q.shape[0], cov.shape[1]
    t = scalars[S_TIME]
    any_use = False
    for i in range(n):
        if not mask[i]:
            continue
        if not flags[F_ORIGIN, i] and not flags[F_BARO_REF, i] and flags[F_ATT_OK, i]:
            s1[T_BARO_OFF, i] = pressure_alt[i] + v3[V_POS, i, 2]
            flags[F_BARO_REF, i] = True
            s1[T_HGT_AIDED, i] = t
        any_use |= flags[F_ORIGIN, i] or flags[F_BARO_REF, i]
    if not any_use:
        return
    # Rows: 0 accepted, 1 innovation, 2 variance (per vehicle); h: measurement rows.
    work = np.zeros((3, n))  # per vehicle (n columns); the rows h have nk
    ok, innovs, variances = work[0], work[1], work[2]
    h = np.zeros((n, nk))
    for i in range(n):
        if not (mask[i] and (flags[F_ORIGIN, i] or flags[F_BARO_REF, i])):
            continue
        z = -(pressure_alt[i] - s1[T_BARO_OFF, i] - v3[V_ORIGIN, i, 2])
        innov = z - v3[V_POS, i, 2]
        var = prm[i, P_BARO_NOISE] ** 2
        gate = prm[i, P_BARO_GATE]
        ratio = innov * innov / (gate * gate * (cov[i, POS + 2, POS + 2] + var))
        s1[T_VERT_RATIO, i] = math.sqrt(ratio)
        h[i, POS + 2] = 1.0
        innovs[i] = innov
        variances[i] = var
        if ratio <= 1.0:
            ok[i] = 1.0
        elif t - s1[T_HGT_AIDED, i] > scalars[S_RESET_TIMEOUT]:
            # Rejected too long: reset the height to the barometer.
            v3[V_CORR_P, i, 2] += z - v3[V_POS, i, 2]
            v3[V_POS, i, 2] = z
            for k in range(nk):
                cov[i, POS + 2, k] = 0.0
                cov[i, k, POS + 2] = 0.0
            cov[i, POS + 2, POS + 2] = var
            s1[T_HGT_AIDED, i] = t
    _fuse_masked(q, rot, v3, s1, cov, prm, scalars, h, innovs, variances, ok)
    for i in range(n):
        if ok[i] != 0:
            s1[T_HGT_AIDED, i] = t


@_kernel(_Q, _ROT, _V3, _S1, _COV, _PRM, _VEC, _PRM, _VEC, _VEC, _MASK)
def fuse(
    q: np.ndarray,
    rot: np.ndarray,
    v3: np.ndarray,
    s1: np.ndarray,
    cov: np.ndarray,
    prm: np.ndarray,
    scalars: np.ndarray,
    h: np.ndarray,
    innov: np.ndarray,
    var: np.ndarray,
    use: np.ndarray,
) -> None:
    """Scalar update with the (N, 15) measurement rows h of the vehicles in use."""
    work = np.zeros((1, use.shape[0]))
    for i in range(use.shape[0]):
        work[0, i] = 1.0 if use[i] else 0.0
    _fuse_masked(q, rot, v3, s1, cov, prm, scalars, h, innov, var, work[0])


@_kernel(_Q, _ROT, _V3, _S1, _FLAGS, _COV, _PRM, _VEC, _BUF, _VEC, _IN2, _IN2, _IN1, _MASK)
def gps_step(
    q: np.ndarray,
    rot: np.ndarray,
    v3: np.ndarray,
    s1: np.ndarray,
    flags: np.ndarray,
    cov: np.ndarray,
    prm: np.ndarray,
    scalars: np.ndarray,
    buf: np.ndarray,
    buf_t: np.ndarray,
    ned: np.ndarray,
    vel: np.ndarray,
    eph: np.ndarray,
    use: np.ndarray,
) -> None:
    """GNSS velocity and horizontal position fusion of the vehicles in use (EKF2_GPS_*_GATE).

    Innovations are against the state buffered EKF2_GPS_DELAY ago (plus the corrections since);
    position noise is max(EKF2_GPS_P_NOISE, eph), capped at EKF2_NOAID_NOISE while GNSS is the
    only aiding source. A position rejected longer than the reset timeout resets position and
    velocity to GNSS (delay-compensated). Fusion order: velocity N, E, D, position N, E.
    """
    n, nk = q.shape[0], cov.shape[1]
    t = scalars[S_TIME]
    head = int(scalars[S_HEAD])
    # Rows (one column per vehicle): 0 slot, 1 position variance, 2 velocity variance,
    # 3 velocity ok, 4 position ok, 5 innovation; the measurement rows h have nk columns.
    work = np.zeros((6, n))
    slot, pos_var, vel_var, ok_v, ok_p, innov = work[0], work[1], work[2], work[3], work[4], work[5]
    h = np.zeros((n, nk))
    for i in range(n):
        flags[F_GPS_GLITCH, i] = False
        if not use[i]:
            continue
        row = _delayed_slot(buf_t, head, t - prm[i, P_GPS_DELAY] + 1e-9)
        slot[i] = row
        p_noise = prm[i, P_GPS_P_NOISE]
        std = _maxn(p_noise, eph[i])
        if not (t - s1[T_EV_FUSED, i]) <= prm[i, P_NOAID_TOUT]:  # GNSS is the only aiding
            std = -_maxn(-std, -_maxn(prm[i, P_NOAID_NOISE], p_noise))
        pos_var[i] = std * std
        vel_var[i] = prm[i, P_GPS_V_NOISE] ** 2
        ratio_v = -np.inf
        gate = prm[i, P_GPS_V_GATE]
        for k in range(3):
            d = vel[i, k] - (buf[row, i, B_VEL + k] + v3[V_CORR_V, i, k])
            ratio_v = _maxn(
                ratio_v, d * d / (gate * gate * (cov[i, VEL + k, VEL + k] + vel_var[i]))
            )
        ratio_p = -np.inf
        gate = prm[i, P_GPS_P_GATE]
        for k in range(2):
            d = ned[i, k] - (buf[row, i, B_POS + k] + v3[V_CORR_P, i, k])
            ratio_p = _maxn(
                ratio_p, d * d / (gate * gate * (cov[i, POS + k, POS + k] + pos_var[i]))
            )
        s1[T_VEL_RATIO, i] = math.sqrt(ratio_v)
        s1[T_HORIZ_RATIO, i] = math.sqrt(ratio_p)
        ok_v[i] = 1.0 if ratio_v <= 1.0 else 0.0
        ok_p[i] = 1.0 if ratio_p <= 1.0 else 0.0
        flags[F_GPS_GLITCH, i] = not ratio_p <= 1.0
        if ratio_p <= 1.0 or not t - s1[T_GPS_FUSED, i] > scalars[S_RESET_TIMEOUT]:
            continue
        # Rejected longer than the reset timeout: reset to GNSS, shifted by the state's change
        # since the sample was taken.
        _reset_block(cov, i, POS, pos_var[i])
        for k in range(2):
            shift = v3[V_POS, i, k] - (buf[row, i, B_POS + k] + v3[V_CORR_P, i, k])
            delta = ned[i, k] + shift - v3[V_POS, i, k]
            v3[V_POS, i, k] += delta
            v3[V_CORR_P, i, k] += delta
        _reset_block(cov, i, VEL, vel_var[i])
        for k in range(3):
            shift = v3[V_VEL, i, k] - (buf[row, i, B_VEL + k] + v3[V_CORR_V, i, k])
            delta = vel[i, k] + shift - v3[V_VEL, i, k]
            v3[V_VEL, i, k] += delta
            v3[V_CORR_V, i, k] += delta
        ok_p[i] = -1.0  # reset: marked aided below, with the fused ones
    for j in range(VEL, VEL + 3):
        for i in range(n):
            row = int(slot[i])
            innov[i] = vel[i, j - VEL] - (buf[row, i, B_VEL + j - VEL] + v3[V_CORR_V, i, j - VEL])
            h[i, j - 1] = 0.0
            h[i, j] = 1.0
        _fuse_masked(q, rot, v3, s1, cov, prm, scalars, h, innov, vel_var, ok_v)
    for i in range(n):
        h[i, VEL + 2] = 0.0
        ok_v[i] = 1.0 if ok_p[i] > 0.0 else 0.0  # the position-accepted mask
    for j in range(POS, POS + 2):
        for i in range(n):
            row = int(slot[i])
            innov[i] = ned[i, j - POS] - (buf[row, i, B_POS + j - POS] + v3[V_CORR_P, i, j - POS])
            h[i, j - 1] = 0.0
            h[i, j] = 1.0
        _fuse_masked(q, rot, v3, s1, cov, prm, scalars, h, innov, pos_var, ok_v)
    for i in range(n):
        if ok_p[i] != 0.0:  # fused or reset
            s1[T_GPS_FUSED, i] = t
            s1[T_HPOS_AIDED, i] = t
            if not math.isfinite(s1[T_FIRST_AID, i]):
                s1[T_FIRST_AID, i] = t
            flags[F_CONST_POS, i] = False


MAG, IMU, BARO = 1, 2, 4
"""Stages of ``sensor_step`` (bits), run in this order: magnetometer, IMU, barometer."""


@_kernel(
    _Q, _ROT, _V3, _S1, _FLAGS, _COV, _PRM, _VEC, _BUF, _VEC,
    "i8", _IN2, _MASK, _IN2, _IN2, "f8", _Q, _IN1, _MASK,
)  # fmt: skip
def sensor_step(
    q: np.ndarray,
    rot: np.ndarray,
    v3: np.ndarray,
    s1: np.ndarray,
    flags: np.ndarray,
    cov: np.ndarray,
    prm: np.ndarray,
    scalars: np.ndarray,
    buf: np.ndarray,
    buf_t: np.ndarray,
    stages: int,
    mag: np.ndarray,
    has_mag: np.ndarray,
    accel: np.ndarray,
    gyro: np.ndarray,
    dt: float,
    rates_out: np.ndarray,
    pressure_alt: np.ndarray,
    has_baro: np.ndarray,
) -> None:
    """The stages of one sensor sample (MAG | IMU | BARO bits), in the fleet's order.

    One kernel for the three, so that the fleet's per-sample work is one call (the arguments
    of a stage not run are not read).
    """
    if stages & MAG:
        _mag_step(q, rot, v3, s1, flags, cov, prm, scalars, mag, has_mag)
    if stages & IMU:
        _imu_step(q, rot, v3, s1, flags, cov, prm, scalars, buf, buf_t, accel, gyro, dt, rates_out)
    if stages & BARO:
        _baro_step(q, rot, v3, s1, flags, cov, prm, scalars, pressure_alt, has_baro)
