"""Quaternion attitude control (PX4 mc_att_control's P law), batched over the fleet."""

from __future__ import annotations

import numpy as np

from autopilot_emu import quaternion as quat


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
    """
    q_err = quat.multiply(quat.conjugate(q), q_sp)
    q_err *= np.where(q_err[:, :1] < 0.0, -1.0, 1.0)
    rate_sp = 2.0 * q_err[:, 1:] * gains_rpy
    if yaw_rate_ff_rad_s is not None:
        # A yaw rate about NED z expressed in the body frame (third row of R).
        r = quat.to_rotation_matrix(q)
        rate_sp += np.nan_to_num(yaw_rate_ff_rad_s)[:, None] * r[:, 2, :]
    return np.minimum(np.maximum(rate_sp, -rate_max_rad_s), rate_max_rad_s)
