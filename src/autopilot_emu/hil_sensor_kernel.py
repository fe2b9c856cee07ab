"""Compiled unpacking of the fleet's HIL_SENSOR rows into the estimator's inputs.

Rows are (xacc, yacc, zacc, xgyro, ygyro, zgyro, xmag, ymag, zmag, pressure_alt, fields_updated)
per vehicle, as :meth:`autopilot_emu.fleet.AutopilotFleet.handle_sensors` reads them from the
messages. One call per IMU sample replaces a dozen small numpy operations.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

MAG_BITS = 0x1C0
"""HIL_SENSOR fields_updated bits of the magnetometer."""
PRESSURE_ALT_BIT = 0x800
"""HIL_SENSOR fields_updated bit of pressure_alt."""
FAILURE_OFF = mavlink2.FAILURE_TYPE_OFF
FAILURE_WRONG = mavlink2.FAILURE_TYPE_WRONG


@numba.njit(cache=True, error_model="numpy")
def hil_sensor_kernel(
    raw: np.ndarray,
    mag_failure: np.ndarray,
    pressure_alt_m: np.ndarray,
    imu: np.ndarray,
    baro_m: np.ndarray,
    flags: np.ndarray,
) -> None:
    """Split ``raw`` (N, 11) into ``imu`` (3, N, 3: accel, gyro, mag) and ``baro_m`` (N,).

    A non-finite value anywhere in a sample becomes 0 (±inf the largest float, as
    ``np.nan_to_num``): a corrupt sample must not poison the filters. ``flags`` (2, N) get "has
    magnetometer" (its bits set and not switched off by failure injection) and "has pressure
    altitude"; a WRONG magnetometer reads x and y reversed (mounted 180 deg off in yaw).
    ``pressure_alt_m`` keeps the last pressure altitude of each vehicle.
    """
    big = np.finfo(np.float64).max
    for i in range(raw.shape[0]):
        for k in range(raw.shape[1]):
            v = raw[i, k]
            if not math.isfinite(v):
                raw[i, k] = 0.0 if math.isnan(v) else (big if v > 0 else -big)
        bits = np.int64(raw[i, 10])
        for a in range(3):
            imu[0, i, a] = raw[i, a]
            imu[1, i, a] = raw[i, 3 + a]
            imu[2, i, a] = raw[i, 6 + a]
        failure = mag_failure[i]
        flags[0, i] = (bits & MAG_BITS) != 0 and failure != FAILURE_OFF
        if failure == FAILURE_WRONG:
            imu[2, i, 0] = -imu[2, i, 0]
            imu[2, i, 1] = -imu[2, i, 1]
        has_baro = (bits & PRESSURE_ALT_BIT) != 0
        flags[1, i] = has_baro
        baro_m[i] = raw[i, 9]
        if has_baro:
            pressure_alt_m[i] = raw[i, 9]
