"""Layout of the fleet filter's packed state arrays, shared by the filter and its kernels.

The compiled kernels (``estimator_kernels``) take a few packed arrays instead of one argument
per quantity, because each array argument costs a call ~0.1-0.2 us. The packing is along the
first axis, so the filter's public attributes (``position_ned_m``, ``hpos_aided_s``,
``attitude_ok``, ...) are C-contiguous views of one block each and stay current without copies.

* ``V3`` (11, N, 3): per-vehicle 3-vectors.
* ``S1`` (13, N): per-vehicle scalars.
* ``FLAGS`` (5, N) bool: per-vehicle status flags.
* ``PRM`` (N, 18): the EKF2_* parameters the kernels read (SI units, from ``EstimatorParams``).
* ``SCALARS`` (10,): fleet-wide clock, counters and configuration.
* ``BUF`` (L, N, 11): the delayed-state ring buffer, one row per IMU sample.

The attitude ``q`` (N, 4), its rotation matrices (N, 3, 3) and the covariances (N, 15, 15) are
arrays of their own.
"""

from __future__ import annotations

# V3: per-vehicle 3-vectors, (11, N, 3).
V_POS = 0
"""NED position, m."""
V_VEL = 1
"""NED velocity, m/s."""
V_BG = 2
"""Gyro bias, body FRD, rad/s."""
V_BA = 3
"""Accelerometer bias, body FRD, m/s²."""
V_ACC_DV = 4
"""Velocity change from the bias-corrected accelerometer since update_acceleration, m/s."""
V_PRED_DV = 5
"""Specific-force velocity change (NED) since the last covariance prediction, m/s."""
V_CORR_P = 6
"""Position corrections applied since the start (a buffered row plus these is current), m."""
V_CORR_V = 7
"""Velocity corrections applied since the start, m/s."""
V_FAKE = 8
"""Fake position held without horizontal aiding, m."""
V_ACC_NED = 9
"""Low-passed NED acceleration, m/s²."""
V_ORIGIN = 10
"""EKF origin: latitude, longitude (deg), altitude AMSL (m)."""
V3_BLOCKS = 11

# S1: per-vehicle scalars, (13, N).
T_HPOS_AIDED = 0
"""Last fusion of a horizontal position source, s."""
T_HGT_AIDED = 1
"""Last fusion of a height source, s."""
T_FIRST_AID = 2
"""First fusion of a horizontal position source, s (inf before)."""
T_MAG_SEEN = 3
"""Last magnetometer sample offered to the heading fusion, s."""
T_MAG_ACCEPTED = 4
"""Last magnetometer sample passing the heading gate, s."""
T_MAG_RATIO = 5
"""Magnetic heading innovation test ratio."""
T_VERT_RATIO = 6
"""Height innovation test ratio."""
T_BARO_OFF = 7
"""Barometer offset: pressure altitude minus the height reference, m."""
T_CORR_YAW = 8
"""Yaw corrections applied since the start, rad."""
T_GPS_FUSED = 9
"""Last GNSS horizontal position fusion, s."""
T_EV_FUSED = 10
"""Last external-vision horizontal position fusion, s."""
T_VEL_RATIO = 11
"""Velocity (GNSS or vision) innovation test ratio."""
T_HORIZ_RATIO = 12
"""Horizontal position (GNSS or vision) innovation test ratio."""
S1_ROWS = 13

# FLAGS: per-vehicle booleans, (5, N).
F_ATT_OK = 0
F_ORIGIN = 1
F_BARO_REF = 2
F_CONST_POS = 3
F_GPS_GLITCH = 4
FLAGS_ROWS = 5

# PRM: EKF2_* parameters read by the kernels, (N, 18), SI units.
PRM_FIELDS = (
    "gyr_noise_rad_s",
    "acc_noise_m_s2",
    "gyr_b_noise_rad_s2",
    "acc_b_noise_m_s3",
    "abias_lim_m_s2",
    "noaid_tout_s",
    "noaid_noise_m",
    "mag_decl_rad",
    "head_noise_rad",
    "mag_noise_gauss",
    "hdg_gate",
    "baro_noise_m",
    "baro_gate",
    "gps_p_noise_m",
    "gps_v_noise_m_s",
    "gps_p_gate",
    "gps_v_gate",
    "gps_delay_s",
)
"""EstimatorParams fields in PRM column order."""
(
    P_GYR_NOISE,
    P_ACC_NOISE,
    P_GYR_B_NOISE,
    P_ACC_B_NOISE,
    P_ABIAS_LIM,
    P_NOAID_TOUT,
    P_NOAID_NOISE,
    P_MAG_DECL,
    P_HEAD_NOISE,
    P_MAG_NOISE,
    P_HDG_GATE,
    P_BARO_NOISE,
    P_BARO_GATE,
    P_GPS_P_NOISE,
    P_GPS_V_NOISE,
    P_GPS_P_GATE,
    P_GPS_V_GATE,
    P_GPS_DELAY,
) = range(len(PRM_FIELDS))

# SCALARS: fleet-wide clock, counters and configuration, (10,).
S_TIME = 0
"""Filter time, s."""
S_PRED_DT = 1
"""Time since the last covariance prediction, s."""
S_FAKE_NEXT = 2
"""Time of the next fake-position fusion, s."""
S_HEAD = 3
"""Ring-buffer row written last (an integer stored as float)."""
S_PREDICT_PERIOD = 4
S_FAKE_PERIOD = 5
S_PREFLIGHT_STD = 6
S_RESET_TIMEOUT = 7
S_GBIAS_LIM = 8
S_ACC_TAU = 9
"""EstimatorConfig values (see its fields)."""
SCALARS_SIZE = 10

# BUF: delayed-state ring buffer, (L, N, 11).
B_POS = 0
"""Position minus the corrections applied until then, m (3)."""
B_VEL = 3
"""Velocity minus the corrections applied until then, m/s (3)."""
B_Q = 6
"""Attitude quaternion (4)."""
B_CORR_YAW = 10
"""Yaw corrections applied until then, rad."""
BUF_WIDTH = 11
