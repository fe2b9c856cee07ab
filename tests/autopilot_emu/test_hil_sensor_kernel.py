"""HIL_SENSOR rows -> estimator inputs: corrupt values, failure injection, pressure altitude."""

from __future__ import annotations

import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.hil_sensor_kernel import hil_sensor_kernel

ALL_FIELDS = 0x1FFF
NO_BARO_NO_MAG = ALL_FIELDS & ~0x800 & ~0x1C0


def run(rows, failures):
    raw = np.array(rows, dtype=float)
    n = len(rows)
    pressure_alt = np.full(n, 123.0)
    imu, baro, flags = np.empty((3, n, 3)), np.empty(n), np.empty((2, n), dtype=bool)
    hil_sensor_kernel(raw, np.array(failures, dtype=np.int64), pressure_alt, imu, baro, flags)
    return imu, baro, flags, pressure_alt


def test_rows_are_split_and_failures_applied():
    row = [0.1, 0.2, -9.8, 0.01, 0.02, 0.03, 0.2, -0.1, 0.4, 488.0, ALL_FIELDS]
    imu, baro, flags, alt = run(
        [row, row, row],
        [mavlink2.FAILURE_TYPE_OK, mavlink2.FAILURE_TYPE_OFF, mavlink2.FAILURE_TYPE_WRONG],
    )
    np.testing.assert_array_equal(imu[0], [[0.1, 0.2, -9.8]] * 3)
    np.testing.assert_array_equal(imu[1], [[0.01, 0.02, 0.03]] * 3)
    np.testing.assert_array_equal(imu[2, :2], [[0.2, -0.1, 0.4]] * 2)
    np.testing.assert_array_equal(imu[2, 2], [-0.2, 0.1, 0.4])  # mounted 180 deg off in yaw
    np.testing.assert_array_equal(flags[0], [True, False, True])  # OFF: no magnetometer
    np.testing.assert_array_equal(flags[1], True)
    np.testing.assert_array_equal(baro, 488.0)
    np.testing.assert_array_equal(alt, 488.0)


def test_corrupt_values_become_finite_and_missing_fields_are_flagged():
    row = [np.nan, np.inf, -np.inf, 0, 0, 0, 0, 0, 0, 500.0, NO_BARO_NO_MAG]
    imu, _, flags, alt = run([row], [mavlink2.FAILURE_TYPE_OK])
    big = np.finfo(float).max
    np.testing.assert_array_equal(imu[0, 0], [0.0, big, -big])
    assert not flags[0, 0] and not flags[1, 0]
    assert alt[0] == 123.0  # the last pressure altitude is kept
