"""The navigation filter's tuning, read from each vehicle's EKF2_* parameters into (N,) arrays.

Names and meanings are PX4's EKF2 parameters (PX4-Autopilot src/modules/ekf2/module.yaml);
units are converted to SI here (ms -> s, us -> s, deg -> rad) so the filter never sees PX4 units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from autopilot_emu.params import ParamStore, param_column

EV_HORIZONTAL_POSITION, EV_VERTICAL_POSITION, EV_VELOCITY, EV_YAW = 1, 2, 4, 8
"""EKF2_EV_CTRL bits (PX4 meaning)."""


@dataclass(frozen=True)
class EstimatorParams:
    """EKF2 parameters of N vehicles, (N,) arrays in SI units."""

    acc_noise_m_s2: np.ndarray
    """EKF2_ACC_NOISE: accelerometer noise of the covariance prediction, m/s²."""
    gyr_noise_rad_s: np.ndarray
    """EKF2_GYR_NOISE: gyro noise of the covariance prediction, rad/s."""
    acc_b_noise_m_s3: np.ndarray
    """EKF2_ACC_B_NOISE: accelerometer-bias process noise, m/s³."""
    gyr_b_noise_rad_s2: np.ndarray
    """EKF2_GYR_B_NOISE: gyro-bias process noise, rad/s²."""
    abias_init_m_s2: np.ndarray
    """EKF2_ABIAS_INIT: 1-sigma accelerometer switch-on bias, m/s²."""
    gbias_init_rad_s: np.ndarray
    """EKF2_GBIAS_INIT: 1-sigma gyro switch-on bias, rad/s."""
    abias_lim_m_s2: np.ndarray
    """EKF2_ABL_LIM: limit of the accelerometer-bias estimate, m/s²."""
    gps_p_noise_m: np.ndarray
    """EKF2_GPS_P_NOISE: GNSS position noise floor, m."""
    gps_v_noise_m_s: np.ndarray
    """EKF2_GPS_V_NOISE: GNSS velocity noise, m/s."""
    baro_noise_m: np.ndarray
    """EKF2_BARO_NOISE: barometric height noise, m."""
    head_noise_rad: np.ndarray
    """EKF2_HEAD_NOISE: magnetic heading noise, rad."""
    mag_noise_gauss: np.ndarray
    """EKF2_MAG_NOISE: magnetometer noise, gauss (enters as its heading equivalent)."""
    gps_p_gate: np.ndarray
    """EKF2_GPS_P_GATE: GNSS position innovation gate, standard deviations."""
    gps_v_gate: np.ndarray
    """EKF2_GPS_V_GATE: GNSS velocity innovation gate, standard deviations."""
    baro_gate: np.ndarray
    """EKF2_BARO_GATE: barometric height innovation gate, standard deviations."""
    hdg_gate: np.ndarray
    """EKF2_HDG_GATE: magnetic heading innovation gate, standard deviations."""
    gps_delay_s: np.ndarray
    """EKF2_GPS_DELAY: GNSS measurement delay, s."""
    req_nsats: np.ndarray
    """EKF2_REQ_NSATS: satellites needed to use GNSS."""
    req_eph_m: np.ndarray
    """EKF2_REQ_EPH: largest horizontal accuracy to use GNSS, m."""
    req_epv_m: np.ndarray
    """EKF2_REQ_EPV: largest vertical accuracy to use GNSS, m."""
    noaid_tout_s: np.ndarray
    """EKF2_NOAID_TOUT: dead-reckoning time before the position is declared invalid, s."""
    noaid_noise_m: np.ndarray
    """EKF2_NOAID_NOISE: noise of the fake position fused without aiding, m."""
    ev_ctrl: np.ndarray
    """EKF2_EV_CTRL bits (1 horizontal position, 2 vertical position, 4 velocity, 8 yaw)."""
    ev_delay_s: np.ndarray
    """EKF2_EV_DELAY: vision measurement delay, s."""
    evp_noise_m: np.ndarray
    """EKF2_EVP_NOISE: vision position noise floor, m."""
    evv_noise_m_s: np.ndarray
    """EKF2_EVV_NOISE: vision velocity noise floor, m/s."""
    eva_noise_rad: np.ndarray
    """EKF2_EVA_NOISE: vision yaw noise floor, rad."""
    ev_gate: np.ndarray
    """EKF2_EV_GATE: vision innovation gate, standard deviations."""
    mag_decl_rad: np.ndarray
    """EKF2_MAG_DECL: magnetic declination (east positive), rad."""

    @classmethod
    def from_params(cls, params: list[ParamStore]) -> EstimatorParams:
        """Read the EKF2_* parameters of every vehicle."""

        def col(name: str, scale: float = 1.0) -> np.ndarray:
            return param_column(params, name, scale)

        return cls(
            acc_noise_m_s2=col("EKF2_ACC_NOISE"),
            gyr_noise_rad_s=col("EKF2_GYR_NOISE"),
            acc_b_noise_m_s3=col("EKF2_ACC_B_NOISE"),
            gyr_b_noise_rad_s2=col("EKF2_GYR_B_NOISE"),
            abias_init_m_s2=col("EKF2_ABIAS_INIT"),
            gbias_init_rad_s=col("EKF2_GBIAS_INIT"),
            abias_lim_m_s2=col("EKF2_ABL_LIM"),
            gps_p_noise_m=col("EKF2_GPS_P_NOISE"),
            gps_v_noise_m_s=col("EKF2_GPS_V_NOISE"),
            baro_noise_m=col("EKF2_BARO_NOISE"),
            head_noise_rad=col("EKF2_HEAD_NOISE"),
            mag_noise_gauss=col("EKF2_MAG_NOISE"),
            gps_p_gate=col("EKF2_GPS_P_GATE"),
            gps_v_gate=col("EKF2_GPS_V_GATE"),
            baro_gate=col("EKF2_BARO_GATE"),
            hdg_gate=col("EKF2_HDG_GATE"),
            gps_delay_s=col("EKF2_GPS_DELAY", 1e-3),
            req_nsats=col("EKF2_REQ_NSATS"),
            req_eph_m=col("EKF2_REQ_EPH"),
            req_epv_m=col("EKF2_REQ_EPV"),
            noaid_tout_s=col("EKF2_NOAID_TOUT", 1e-6),
            noaid_noise_m=col("EKF2_NOAID_NOISE"),
            ev_ctrl=col("EKF2_EV_CTRL").astype(int),
            ev_delay_s=col("EKF2_EV_DELAY", 1e-3),
            evp_noise_m=col("EKF2_EVP_NOISE"),
            evv_noise_m_s=col("EKF2_EVV_NOISE"),
            eva_noise_rad=col("EKF2_EVA_NOISE"),
            ev_gate=col("EKF2_EV_GATE"),
            mag_decl_rad=col("EKF2_MAG_DECL", np.pi / 180.0),
        )

    @classmethod
    def defaults(cls, n: int) -> EstimatorParams:
        """PX4 defaults (px4_params.yaml) for n vehicles."""
        store = ParamStore()
        return cls.from_params([store] * n)
