"""Quaternion attitude control (PX4 mc_att_control's P law), batched over the fleet."""

from __future__ import annotations

import numpy as np

from autopilot_emu.control.attitude_kernel import attitude_rate_kernel


def attitude_rate_setpoint(
    q: np.ndarray,
    q_sp: np.ndarray,
    gains_rpy: np.ndarray,
    rate_max_rad_s: np.ndarray,
    yaw_rate_ff_rad_s: np.ndarray | None = None,
) -> np.ndarray:
    """Body-rate setpoint (N, 3) that turns attitude q towards q_sp.

    The error quaternion q^-1 ⊗ q_sp is taken on the short way round (w >= 0); its vector part
    times two is the rotation-vector error for small angles, scaled per axis by MC_*_P. Yaw has a
    lower gain than roll and pitch, so tilt (which produces thrust direction) is served first.
    A yaw-rate feed-forward (about NED z, NaN: none) is added in the body frame.
    """
    out = np.empty((q.shape[0], 3))
    use_ff = yaw_rate_ff_rad_s is not None
    ff = np.asarray(yaw_rate_ff_rad_s, dtype=float) if use_ff else out[:, 0]
    attitude_rate_kernel(
        _f64(q), _f64(q_sp), _f64(gains_rpy), _f64(rate_max_rad_s), _f64(ff), use_ff, out
    )
    return out


def _f64(a: np.ndarray) -> np.ndarray:
    """C-contiguous float64 (one compiled signature for the kernels)."""
    return np.ascontiguousarray(a, dtype=np.float64)
