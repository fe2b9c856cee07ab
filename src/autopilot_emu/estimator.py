"""Navigation filter of N vehicles: an error-state extended Kalman filter batched over the fleet.

The structure follows PX4's EKF2 (PX4-Autopilot src/modules/ekf2): strapdown inertial navigation
predicted with every IMU sample, a covariance predicted at a downsampled rate (EKF2_PREDICT_US,
10 ms), delayed measurements (GNSS, external vision) compared with the state buffered at the time
they were taken, innovation gates in standard deviations (EKF2_*_GATE), a fake position held
while no source aids the horizontal position, and the EKF2_* parameters for every noise.

Nominal state per vehicle: attitude ``q`` (body FRD -> NED, [w, x, y, z]), NED velocity and
position, gyro bias (rad/s) and accelerometer bias (m/s²), both in body FRD. The 15-element
error state is ``[dtheta, dv, dp, dbg, dba]`` with ``dtheta`` a rotation error in the NED frame
(``q_true = exp(dtheta) ⊗ q``); its continuous dynamics (Solà 2017, "Quaternion kinematics for the
error-state Kalman filter", §7.2, global angular error) are

    dtheta' = -R dbg,   dv' = -[R (f - ba)]x dtheta - R dba,   dp' = dv,   dbg' = dba' = noise,

discretised to first order over the prediction interval: Phi = I + F dt. Process noise per
prediction step is as EKF2's: (EKF2_GYR_NOISE dt)² on the angle, (EKF2_ACC_NOISE dt)² on the
velocity, (EKF2_GYR_B_NOISE dt)² and (EKF2_ACC_B_NOISE dt)² on the biases. Measurements are fused
one scalar at a time (as EKF2), for all vehicles at once with per-vehicle masks; the covariances
are an (N, 15, 15) array. Controllers only ever see these estimates, never ground truth.

Heights: the barometer is the height reference (EKF2_HGT_REF baro); GNSS gives horizontal position
and 3-D velocity. Heading: magnetic heading fusion (EKF2's heading mode) with EKF2_HEAD_NOISE.

The per-sample work (IMU step with covariance prediction and fake position, magnetometer,
barometer, GNSS fusion) runs in compiled kernels (``estimator_kernels``), one call per stage, on
packed arrays (``estimator_layout``) of which the public attributes are views; the rare paths
(alignment, origin, external vision, resets) are numpy and share the kernels' scalar fusion.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from autopilot_emu import estimator_kernels as kernels
from autopilot_emu import estimator_layout as lay
from autopilot_emu import geodesy
from autopilot_emu import quaternion as quat
from autopilot_emu.estimator_params import (
    EV_HORIZONTAL_POSITION,
    EV_VELOCITY,
    EV_VERTICAL_POSITION,
    EV_YAW,
    EstimatorParams,
)
from autopilot_emu.params import ParamStore
from autopilot_emu.position_validity_kernel import position_validity

GRAVITY_M_S2 = kernels.GRAVITY_M_S2
_TH, _VEL, _POS, _BG, _BA = kernels.TH, kernels.VEL, kernels.POS, kernels.BG, kernels.BA
"""First index of each block of the 15-element error state (the kernels' layout)."""
_K = 15


@dataclass(frozen=True)
class EstimatorConfig:
    """Structure of the fleet filter (its tuning is the EKF2_* parameters)."""

    predict_period_s: float = 0.01
    """Covariance prediction interval (PX4 EKF2_PREDICT_US default 10 000 us), s."""
    buffer_samples: int = 128
    """Length of the delayed-state buffer, IMU samples (0.5 s at 250 Hz)."""
    settle_s: float = 1.0
    """Time after the first position fix before the position is declared good, s."""
    fake_position_period_s: float = 0.2
    """Interval of fake-position fusion without aiding (EKF2 fuses it at 5 Hz), s."""
    preflight_fake_position_std_m: float = 0.5
    """Fake-position noise before any aiding source was ever used (EKF2 at rest), m."""
    reset_timeout_s: float = 7.0
    """A source rejected this long resets the state to it (EKF2 reset_timeout_max), s."""
    heading_reject_limit_s: float = 1.0
    """Magnetometer data rejected by the heading gate this long: heading failure, s."""
    accel_lpf_tau_s: float = 0.3
    """Time constant of the reported NED acceleration, s."""
    gyro_bias_limit_rad_s: float = 0.15
    """Clamp of the gyro-bias estimate (EKF2's gyro bias limit), rad/s."""


def _column(values: np.ndarray | float, n: int) -> np.ndarray:
    """A new (n,) float64 array of ``values`` (broadcast), as the fusion kernel takes."""
    out = np.empty(n)
    out[:] = values
    return out


def _f64(a: np.ndarray | list) -> np.ndarray:
    """``a`` as a float64 array (the kernels' argument type)."""
    return np.asarray(a, dtype=np.float64)


class FleetEstimator:
    """Attitude, velocity, position and IMU-bias estimates of N vehicles in their NED frames."""

    def __init__(
        self, n: int, config: EstimatorConfig | None = None, params: EstimatorParams | None = None
    ) -> None:
        self.n = n
        self.config = config or EstimatorConfig()
        cfg = self.config
        # Packed state the kernels update in place (layout: estimator_layout); the public
        # attributes below are C-contiguous views of it.
        self._v3 = np.zeros((lay.V3_BLOCKS, n, 3))
        self._s1 = np.zeros((lay.S1_ROWS, n))
        self._flags = np.zeros((lay.FLAGS_ROWS, n), dtype=bool)
        self._prm = np.zeros((n, len(lay.PRM_FIELDS)))
        self._scalars = np.zeros(lay.SCALARS_SIZE)
        self._scalars[lay.S_PREDICT_PERIOD] = cfg.predict_period_s
        self._scalars[lay.S_FAKE_PERIOD] = cfg.fake_position_period_s
        self._scalars[lay.S_PREFLIGHT_STD] = cfg.preflight_fake_position_std_m
        self._scalars[lay.S_RESET_TIMEOUT] = cfg.reset_timeout_s
        self._scalars[lay.S_GBIAS_LIM] = cfg.gyro_bias_limit_rad_s
        self._scalars[lay.S_ACC_TAU] = cfg.accel_lpf_tau_s
        self.params = params or EstimatorParams.defaults(n)
        self.q = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
        """Attitude body FRD -> NED, [w, x, y, z] (updated in place)."""
        self._r = quat.to_rotation_matrix(self.q)
        """Rotation matrices of ``q``, kept current by every change of ``q``."""
        self.position_ned_m = self._v3[lay.V_POS]
        """(N, 3) position in each vehicle's NED frame, m."""
        self.velocity_ned_m_s = self._v3[lay.V_VEL]
        """(N, 3) velocity NED, m/s."""
        self.gyro_bias_rad_s = self._v3[lay.V_BG]
        """Gyro bias estimate, body FRD, rad/s."""
        self.accel_bias_m_s2 = self._v3[lay.V_BA]
        """Accelerometer bias estimate, body FRD, m/s²."""
        self.P = np.zeros((n, _K, _K))
        """Error-state covariances, (N, 15, 15) (updated in place)."""
        self.rates_rad_s = np.zeros((n, 3))
        """Bias-corrected body rates, rad/s (a new array at every IMU sample)."""
        self.accel_ned_m_s2 = self._v3[lay.V_ACC_NED]
        """Low-passed, bias-corrected NED acceleration, m/s²."""
        self.attitude_ok = self._flags[lay.F_ATT_OK]
        self.origin_set = self._flags[lay.F_ORIGIN]
        self.origin_lla = self._v3[lay.V_ORIGIN]
        """EKF origin: latitude, longitude (deg), altitude AMSL (m) of each vehicle's NED frame."""
        self.baro_offset_m = self._s1[lay.T_BARO_OFF]
        """pressure_alt - GPS altitude at the origin fix, m."""
        self.first_fix_s = np.full(n, np.inf)
        """When the origin was set (the first GNSS fix passing the checks), s."""
        self.first_aiding_s = self._s1[lay.T_FIRST_AID]
        """When a horizontal position source was first fused, s."""
        self.first_aiding_s[:] = np.inf
        self.gps_fix_type = np.zeros(n, dtype=int)
        self.gps_checks_ok = np.zeros(n, dtype=bool)
        """The last GNSS sample passed EKF2's checks (fix, satellites, eph, epv)."""
        self.gps_time_s = np.full(n, -np.inf)
        self.gps_fused_s = self._s1[lay.T_GPS_FUSED]
        """Last GNSS horizontal position fusion, s."""
        self.ev_fused_s = self._s1[lay.T_EV_FUSED]
        """Last external-vision horizontal position fusion, s."""
        self.gps_fused_s[:] = -np.inf
        self.ev_fused_s[:] = -np.inf
        self.hpos_aided_s = self._s1[lay.T_HPOS_AIDED]
        """Last fusion of any horizontal position source (GNSS or vision), s."""
        self.height_aided_s = self._s1[lay.T_HGT_AIDED]
        """Last fusion of a height source (barometer or vision), s."""
        self.hpos_aided_s[:] = -np.inf
        self.height_aided_s[:] = -np.inf
        self.vel_ratio = self._s1[lay.T_VEL_RATIO]
        """GNSS velocity innovation test ratio, sqrt(innov² / (gate² S)) (>1: rejected)."""
        self.pos_horiz_ratio = self._s1[lay.T_HORIZ_RATIO]
        """Horizontal position (GNSS or vision) innovation test ratio."""
        self.pos_vert_ratio = self._s1[lay.T_VERT_RATIO]
        """Height innovation test ratio."""
        self.mag_ratio = self._s1[lay.T_MAG_RATIO]
        """Magnetic heading innovation test ratio."""
        self.gps_glitch = self._flags[lay.F_GPS_GLITCH]
        """The last GNSS position was rejected by its gate."""
        self.const_pos_mode = self._flags[lay.F_CONST_POS]
        """A fake position is fused (no horizontal aiding)."""
        self.const_pos_mode[:] = True
        self.mag_seen_s = self._s1[lay.T_MAG_SEEN]
        self.mag_accepted_s = self._s1[lay.T_MAG_ACCEPTED]
        self.mag_seen_s[:] = -np.inf
        self.mag_accepted_s[:] = -np.inf
        self._idx = np.arange(n)
        self._baro_ref = self._flags[lay.F_BARO_REF]
        """The barometer has a reference height (set at its first sample or by the origin)."""
        self._corr_p = self._v3[lay.V_CORR_P]
        self._corr_v = self._v3[lay.V_CORR_V]
        """Corrections applied since the start: a buffered state is its row plus these."""
        self._corr_yaw = self._s1[lay.T_CORR_YAW]
        # Delayed-state ring buffer (one row per IMU sample): time, position, velocity, attitude,
        # yaw corrections applied until then (rad).
        length = cfg.buffer_samples
        self._buf_t = np.full(length, -np.inf)
        self._buf = np.zeros((length, n, lay.BUF_WIDTH))
        self._buf_p = self._buf[:, :, lay.B_POS : lay.B_POS + 3]
        self._buf_v = self._buf[:, :, lay.B_VEL : lay.B_VEL + 3]
        self._buf_q = self._buf[:, :, lay.B_Q : lay.B_Q + 4]
        self._buf_q[:] = self.q
        self._buf_corr_yaw = self._buf[:, :, lay.B_CORR_YAW]
        self._scalars[lay.S_HEAD] = length - 1
        self._zero3 = np.zeros((n, 3))
        self._zero1 = np.zeros(n)
        self._no = np.zeros(n, dtype=bool)
        """Placeholders for the inputs of the kernel stages not run."""
        self._axis_rows = np.tile(np.eye(_K)[:, None, :], (1, n, 1))
        """Measurement rows e_j of a direct observation of error state j, (15, N, 15)."""
        self._reset_covariance(np.ones(n, dtype=bool))

    @property
    def params(self) -> EstimatorParams:
        """Each vehicle's EKF2_* parameters (assigning one also updates the kernels' copy)."""
        return self._params

    @params.setter
    def params(self, params: EstimatorParams) -> None:
        self._params = params
        for col, name in enumerate(lay.PRM_FIELDS):
            self._prm[:, col] = getattr(params, name)

    @property
    def time_s(self) -> float:
        """Filter time (sum of the IMU intervals), s."""
        return float(self._scalars[lay.S_TIME])

    @time_s.setter
    def time_s(self, value: float) -> None:
        self._scalars[lay.S_TIME] = value

    # -- read-only views ---------------------------------------------------------------------
    @property
    def r(self) -> np.ndarray:
        """(N, 3, 3) rotation matrices of ``q`` (body FRD -> NED)."""
        return self._r

    def position_validity(self) -> tuple[np.ndarray, np.ndarray]:
        """(local_position_ok, global_position_ok) in one compiled call."""
        return position_validity(
            float(self._scalars[lay.S_TIME]),
            self._prm,
            lay.P_NOAID_TOUT,
            float(self.config.settle_s),
            self.attitude_ok,
            self.hpos_aided_s,
            self.first_aiding_s,
            self.gps_fused_s,
            self.origin_set,
        )

    @property
    def local_position_ok(self) -> np.ndarray:
        """(N,) the local position is aided (or dead-reckoned for < EKF2_NOAID_TOUT) and settled."""
        return self.position_validity()[0]

    @property
    def position_ok(self) -> np.ndarray:
        """(N,) the position estimate can be flown on (PX4's local position validity)."""
        return self.position_validity()[0]

    @property
    def global_position_ok(self) -> np.ndarray:
        """(N,) the position is also global: an origin and GNSS fused within EKF2_NOAID_TOUT."""
        return self.position_validity()[1]

    @property
    def position_variance_m2(self) -> np.ndarray:
        """(N, 3) variance of the NED position estimate, m²."""
        return self.P.diagonal(0, 1, 2)[:, 6:9].copy()

    @property
    def velocity_variance_m2_s2(self) -> np.ndarray:
        """(N, 3) variance of the NED velocity estimate, m²/s²."""
        return self.P.diagonal(0, 1, 2)[:, 3:6].copy()

    @property
    def heading_failure(self) -> np.ndarray:
        """(N,) magnetometer data keep failing the heading gate (PX4's heading preflight fail)."""
        limit = self.config.heading_reject_limit_s
        return self.attitude_ok & (self.mag_seen_s > self.mag_accepted_s + limit)

    def set_params(self, params: EstimatorParams | list[ParamStore]) -> None:
        """Apply each vehicle's EKF2_* parameters (an EstimatorParams or the parameter stores)."""
        if not isinstance(params, EstimatorParams):
            params = EstimatorParams.from_params(params)
        self.params = params

    def set_declination(self, declination_deg: np.ndarray | list[float]) -> None:
        """Use these magnetic declinations, (N,) degrees (EKF2_MAG_DECL or a geo lookup)."""
        decl = np.radians(np.asarray(declination_deg, dtype=float))
        self.params = replace(self.params, mag_decl_rad=decl)

    # -- prediction ----------------------------------------------------------------------------
    def update_imu(self, accel_frd: np.ndarray, gyro_frd: np.ndarray, dt_s: float) -> None:
        """Propagate with one IMU sample per vehicle (specific force m/s², rates rad/s).

        Strapdown step, the covariance prediction when EKF2_PREDICT_US has elapsed
        (P <- Phi P Phi^T + Q), a delayed-state buffer row and, at its period, the fake-position
        fusion: one kernel call (``estimator_kernels.sensor_step``).
        """
        self._sensor_step(kernels.IMU, self._zero3, self._no, accel_frd, gyro_frd, dt_s)

    def update_sensors(
        self,
        accel_frd: np.ndarray,
        gyro_frd: np.ndarray,
        dt_s: float,
        mag_frd: np.ndarray,
        has_mag: np.ndarray,
        pressure_alt_m: np.ndarray,
        has_baro: np.ndarray,
    ) -> None:
        """One sensor sample in one call: update_mag, update_imu, update_baro, in this order.

        ``has_mag``/``has_baro`` (N,) bool select the vehicles whose sample carries a new
        magnetometer / barometer reading (the HIL_SENSOR fields_updated bits).
        """
        stages = kernels.MAG | kernels.IMU | kernels.BARO
        self._sensor_step(
            stages, mag_frd, has_mag, accel_frd, gyro_frd, dt_s, pressure_alt_m, has_baro
        )

    def _sensor_step(
        self,
        stages: int,
        mag: np.ndarray,
        has_mag: np.ndarray,
        accel: np.ndarray,
        gyro: np.ndarray,
        dt_s: float,
        pressure_alt: np.ndarray | None = None,
        has_baro: np.ndarray | None = None,
    ) -> None:
        """Run the stages in the ``stages`` bits (MAG, IMU, BARO) in one kernel call.

        The kernel ignores the inputs of stages not selected; without a barometer sample, zeros
        and an all-false mask stand in for it.
        """
        if pressure_alt is None:
            pressure_alt, has_baro = self._zero1, self._no
        rates = self.rates_rad_s
        if stages & kernels.IMU:
            rates = np.empty((self.n, 3))  # a new array: callers may keep the previous sample's
        state = (self.q, self._r, self._v3, self._s1, self._flags, self.P, self._prm)
        try:
            kernels.sensor_step(
                *state, self._scalars, self._buf, self._buf_t, stages, mag, has_mag,
                accel, gyro, dt_s, rates, pressure_alt, has_baro,
            )  # fmt: skip
        except TypeError:  # not float64 samples or bool masks (lists, integers): convert once
            kernels.sensor_step(
                *state, self._scalars, self._buf, self._buf_t, stages, _f64(mag),
                np.asarray(has_mag, dtype=bool), _f64(accel), _f64(gyro), float(dt_s), rates,
                _f64(pressure_alt), np.asarray(has_baro, dtype=bool),
            )  # fmt: skip
        self.rates_rad_s = rates

    def update_acceleration(self, dt_s: float) -> None:
        """Low-pass the mean NED acceleration of the last ``dt_s`` into ``accel_ned_m_s2``.

        Called at the navigation rate (the hover-thrust estimator and controllers read it).
        """
        kernels.acceleration_step(self._v3, self._scalars, float(dt_s))

    # -- generic fusion ----------------------------------------------------------------------------
    def _fuse_axis(self, j: int, innov: np.ndarray, var: np.ndarray, use: np.ndarray) -> None:
        """Scalar update of error-state element j (H = e_j) for the vehicles in ``use``."""
        self._fuse_row(self._axis_rows[j], innov, var, use)

    def _fuse_row(self, h: np.ndarray, innov: np.ndarray, var: np.ndarray, use: np.ndarray) -> None:
        """Scalar update with an (N, 15) measurement row for the vehicles in ``use``."""
        n = self.n
        kernels.fuse(
            self.q,
            self._r,
            self._v3,
            self._s1,
            self.P,
            self._prm,
            self._scalars,
            np.ascontiguousarray(h, dtype=float),
            _column(innov, n),
            _column(var, n),
            np.asarray(use, dtype=bool),
        )

    def _test_ratio(
        self, j: int, innov: np.ndarray, var: np.ndarray, gate: np.ndarray
    ) -> np.ndarray:
        """innov² / (gate² S) of a scalar measurement of element j (EKF2's innovation test)."""
        return innov * innov / (gate * gate * (self.P[:, j, j] + var))

    def _reset_block(self, j: int, values: np.ndarray, var: np.ndarray, mask: np.ndarray) -> None:
        """Reset three states (block starting at j) to ``values`` with variance ``var``."""
        if not mask.any():
            return
        sl = slice(j, j + 3)
        cur = self.position_ned_m if j == _POS else self.velocity_ned_m_s
        delta = np.where(mask[:, None], values - cur, 0.0)
        cur += delta
        (self._corr_p if j == _POS else self._corr_v)[:] += delta
        self.P[mask, sl, :] = 0.0
        self.P[mask, :, sl] = 0.0
        for k in range(3):
            self.P[mask, j + k, j + k] = var[mask]

    def _reset_covariance(self, mask: np.ndarray) -> None:
        prm = self.params
        diag = np.concatenate(
            (
                np.tile([0.1**2, 0.1**2, 0.5**2], (self.n, 1)),
                np.full((self.n, 3), 0.5**2),
                np.full((self.n, 3), 0.5**2),
                np.repeat(prm.gbias_init_rad_s[:, None] ** 2, 3, axis=1),
                np.repeat(prm.abias_init_m_s2[:, None] ** 2, 3, axis=1),
            ),
            axis=1,
        )
        self.P[mask] = np.einsum("ni,ij->nij", diag[mask], np.eye(_K))

    def _delayed_slot(self, delay_s: np.ndarray) -> np.ndarray:
        """(N,) ring-buffer rows of the state ``delay_s`` ago (the latest at or before it)."""
        length = self._buf_t.shape[0]
        order = (int(self._scalars[lay.S_HEAD]) + 1 + np.arange(length)) % length
        k = np.searchsorted(self._buf_t[order], self.time_s - delay_s + 1e-9, side="right") - 1
        return order[np.clip(k, 0, length - 1)]

    def _delayed_p(self, slot: np.ndarray) -> np.ndarray:
        """(N, 3) corrected position buffered at ``slot``."""
        return self._buf_p[slot, self._idx] + self._corr_p

    def _delayed_v(self, slot: np.ndarray) -> np.ndarray:
        """(N, 3) corrected velocity buffered at ``slot``."""
        return self._buf_v[slot, self._idx] + self._corr_v

    # -- attitude -------------------------------------------------------------------------------
    def align_heading(self, accel_frd: np.ndarray, mag_frd: np.ndarray, mask: np.ndarray) -> None:
        """Initial alignment (roll/pitch from gravity, yaw from the magnetometer)."""
        if not mask.any():
            return
        a = accel_frd[mask] - self.accel_bias_m_s2[mask]
        roll = np.arctan2(-a[:, 1], -a[:, 2])
        pitch = np.arctan2(a[:, 0], np.hypot(a[:, 1], a[:, 2]))
        zeros = np.zeros_like(roll)
        tilt = quat.to_rotation_matrix(quat.from_euler(np.stack((roll, pitch, zeros), axis=1)))
        m_h = np.einsum("nij,nj->ni", tilt, mag_frd[mask])
        yaw = quat.wrap_pi(self.params.mag_decl_rad[mask] - np.arctan2(m_h[:, 1], m_h[:, 0]))
        self.q[mask] = quat.from_euler(np.stack((roll, pitch, yaw), axis=1))
        self._r[mask] = quat.to_rotation_matrix(self.q[mask])
        self._buf_q[:, mask] = self.q[mask]
        self.attitude_ok[mask] = True

    def _yaw_row(self) -> np.ndarray:
        """(N, 15) derivative of the ZYX yaw with respect to the NED rotation error."""
        c0 = self.r[:, :, 0]
        h2 = np.maximum(c0[:, 0] ** 2 + c0[:, 1] ** 2, 1e-6)
        h = np.zeros((self.n, _K))
        h[:, _TH] = -c0[:, 0] * c0[:, 2] / h2
        h[:, _TH + 1] = -c0[:, 1] * c0[:, 2] / h2
        h[:, _TH + 2] = 1.0
        return h

    def update_mag(self, mag_frd: np.ndarray, mask: np.ndarray) -> None:
        """Magnetic heading fusion with EKF2_HEAD_NOISE (or EKF2_MAG_NOISE's heading equivalent).

        Gated by EKF2_HDG_GATE; one kernel call (``estimator_kernels.sensor_step``).
        """
        self._sensor_step(kernels.MAG, mag_frd, mask, self._zero3, self._zero3, 0.0)

    # -- height ---------------------------------------------------------------------------------
    def update_baro(self, pressure_alt_m: np.ndarray, mask: np.ndarray) -> None:
        """Barometric height fusion, gated by EKF2_BARO_GATE.

        Before an origin the barometer is referenced to the height estimate at its first sample
        (a GNSS-denied vehicle still holds height on it); the first GNSS fix re-references it
        to the fix's altitude. A height rejected longer than the reset timeout is reset to the
        barometer (EKF2). One kernel call (``estimator_kernels.sensor_step``).
        """
        self._sensor_step(
            kernels.BARO, self._zero3, self._no, self._zero3, self._zero3, 0.0, pressure_alt_m, mask
        )

    # -- GNSS -----------------------------------------------------------------------------------
    def update_gps(
        self,
        ned_m: np.ndarray,
        vel_ned_m_s: np.ndarray,
        fix_type: np.ndarray,
        lla: np.ndarray,
        pressure_alt_m: np.ndarray,
        eph_m: np.ndarray | None = None,
        epv_m: np.ndarray | None = None,
        satellites: np.ndarray | None = None,
    ) -> np.ndarray:
        """Fuse a GNSS sample taken EKF2_GPS_DELAY ago; return the mask of new origins.

        ``ned_m`` is the fix in each vehicle's NED frame (callers convert with the origin; for
        vehicles without an origin it is ignored); ``lla`` is (N, 3) latitude/longitude (deg)
        and AMSL altitude (m). ``eph_m``/``epv_m`` (HIL_GPS accuracies) and ``satellites``
        enter EKF2's GNSS checks (EKF2_REQ_EPH, EKF2_REQ_EPV, EKF2_REQ_NSATS) and the position
        noise, max(EKF2_GPS_P_NOISE, eph) as EKF2 (capped at EKF2_NOAID_NOISE while GNSS is the
        only aiding source, so it keeps constraining the attitude).
        """
        n, prm = self.n, self.params
        eph = np.zeros(n) if eph_m is None else eph_m
        epv = np.zeros(n) if epv_m is None else epv_m
        sats = np.full(n, 99.0) if satellites is None else satellites
        self.gps_fix_type = fix_type.astype(int)
        checks = (
            (fix_type >= 3)
            & (sats >= prm.req_nsats)
            & (eph <= prm.req_eph_m)
            & (epv <= prm.req_epv_m)
            & np.isfinite(ned_m).all(axis=1)
        )
        self.gps_checks_ok = checks
        self.gps_time_s[checks] = self.time_s
        new_origin = checks & ~self.origin_set & self.attitude_ok
        if new_origin.any():
            self._set_origin(new_origin, lla, vel_ned_m_s, pressure_alt_m, eph)
        use = checks & self.origin_set & ~new_origin
        args = (self.q, self._r, self._v3, self._s1, self._flags, self.P, self._prm, self._scalars)
        try:
            kernels.gps_step(*args, self._buf, self._buf_t, ned_m, vel_ned_m_s, eph, use)
        except TypeError:  # not float64 arrays: convert once
            kernels.gps_step(
                *args, self._buf, self._buf_t, _f64(ned_m), _f64(vel_ned_m_s), _f64(eph), use
            )
        return new_origin

    def _set_origin(
        self,
        mask: np.ndarray,
        lla: np.ndarray,
        vel_ned_m_s: np.ndarray,
        pressure_alt_m: np.ndarray,
        eph_m: np.ndarray,
    ) -> None:
        """The first good fix sets the EKF origin.

        Without earlier aiding the position restarts at zero and the velocity from GNSS. A vehicle
        already navigating on another source (external vision) keeps its local frame: the origin
        is placed so that its current position maps to the fix (EKF2 keeps the local position
        when it sets the origin).
        """
        aided = mask & np.isfinite(self.first_aiding_s)
        fresh = mask & ~aided
        p = self.position_ned_m
        origin = lla.copy()
        m_per_deg = geodesy.metres_per_degree(lla)
        origin[:, 0] -= p[:, 0] / m_per_deg[:, 0]
        origin[:, 1] -= p[:, 1] / m_per_deg[:, 1]
        origin[:, 2] += p[:, 2]
        origin = np.where(fresh[:, None], lla, origin)
        self.origin_lla[mask] = origin[mask]
        down = np.where(fresh, 0.0, p[:, 2])
        self.baro_offset_m[mask] = (pressure_alt_m - origin[:, 2] + down)[mask]
        self._baro_ref |= mask
        self.origin_set |= mask
        self.first_fix_s[mask] = self.time_s
        var = np.maximum(self.params.gps_p_noise_m, eph_m) ** 2
        self._reset_horizontal(fresh, np.zeros((self.n, 3)), var)
        self._reset_block(_VEL, vel_ned_m_s, self.params.gps_v_noise_m_s**2, fresh)
        self.height_aided_s[mask] = self.time_s
        self.gps_fused_s[mask] = self.time_s
        self._mark_aided(mask)

    def _reset_horizontal(self, mask: np.ndarray, target: np.ndarray, var: np.ndarray) -> None:
        """Reset the position to ``target`` (all three axes) with variance ``var``."""
        self._reset_block(_POS, target, np.broadcast_to(var, (self.n,)), mask)

    def _mark_aided(self, mask: np.ndarray) -> None:
        self.hpos_aided_s[mask] = self.time_s
        first = mask & ~np.isfinite(self.first_aiding_s)
        self.first_aiding_s[first] = self.time_s
        self.const_pos_mode[mask] = False

    # -- external vision ------------------------------------------------------------------------
    def update_vision(
        self,
        mask: np.ndarray,
        position_ned_m: np.ndarray,
        position_var_m2: np.ndarray,
        yaw_rad: np.ndarray,
        yaw_var_rad2: np.ndarray,
        velocity_ned_m_s: np.ndarray,
        velocity_var_m2_s2: np.ndarray,
        age_s: np.ndarray | float = 0.0,
    ) -> None:
        """Fuse external-vision samples taken ``age_s`` + EKF2_EV_DELAY ago under EKF2_EV_CTRL.

        All arrays are (N, ...) with ``mask`` selecting the vehicles that have a sample; NaN
        entries (no yaw, no velocity) are not fused. Noise is max(reported, EKF2_EV*_NOISE);
        the gate EKF2_EV_GATE. The vision frame is taken as the vehicle's local NED frame.
        """
        prm = self.params
        ctrl = prm.ev_ctrl
        use = mask & self.attitude_ok
        if not use.any():
            return
        slot = self._delayed_slot(prm.ev_delay_s + age_s)
        gate = prm.ev_gate
        # Reported variances with EKF2_EV*_NOISE as the floor (fmax: NaN, unknown, gives the floor).
        pos_var = np.fmax(position_var_m2, (prm.evp_noise_m**2)[:, None])
        horiz = use & ((ctrl & EV_HORIZONTAL_POSITION) != 0)
        horiz &= np.isfinite(position_ned_m[:, :2]).all(axis=1)
        if horiz.any():
            innov = position_ned_m[:, :2] - self._delayed_p(slot)[:, :2]
            ratio = np.maximum(
                self._test_ratio(_POS, innov[:, 0], pos_var[:, 0], gate),
                self._test_ratio(_POS + 1, innov[:, 1], pos_var[:, 1], gate),
            )
            self.pos_horiz_ratio[:] = np.where(horiz, np.sqrt(ratio), self.pos_horiz_ratio)
            ok = horiz & (ratio <= 1.0)
            stale = horiz & ~ok & (self.time_s - self.ev_fused_s > self.config.reset_timeout_s)
            stale |= horiz & ~np.isfinite(self.first_aiding_s)  # first sample: start there
            if stale.any():
                shift = self.position_ned_m - self._delayed_p(slot)
                target = self.position_ned_m.copy()
                target[:, :2] = position_ned_m[:, :2] + shift[:, :2]
                self._reset_horizontal(stale, target, pos_var[:, 0])
                ok &= ~stale
            for k in range(2):
                innov_k = position_ned_m[:, k] - self._delayed_p(slot)[:, k]
                self._fuse_axis(_POS + k, innov_k, pos_var[:, k], ok)
            self.ev_fused_s[ok | stale] = self.time_s
            self._mark_aided(ok | stale)
        vert = use & ((ctrl & EV_VERTICAL_POSITION) != 0) & np.isfinite(position_ned_m[:, 2])
        if vert.any():
            innov = position_ned_m[:, 2] - self._delayed_p(slot)[:, 2]
            ratio = self._test_ratio(_POS + 2, innov, pos_var[:, 2], gate)
            self.pos_vert_ratio[:] = np.where(vert, np.sqrt(ratio), self.pos_vert_ratio)
            ok = vert & (ratio <= 1.0)
            self._fuse_axis(_POS + 2, innov, pos_var[:, 2], ok)
            self.height_aided_s[ok] = self.time_s
        vel = use & ((ctrl & EV_VELOCITY) != 0) & np.isfinite(velocity_ned_m_s).all(axis=1)
        if vel.any():
            vel_var = np.fmax(velocity_var_m2_s2, (prm.evv_noise_m_s**2)[:, None])
            innov = velocity_ned_m_s - self._delayed_v(slot)
            ratio = np.max(
                [self._test_ratio(_VEL + k, innov[:, k], vel_var[:, k], gate) for k in range(3)],
                axis=0,
            )
            self.vel_ratio[:] = np.where(vel, np.sqrt(ratio), self.vel_ratio)
            ok = vel & (ratio <= 1.0)
            for k in range(3):
                innov_k = velocity_ned_m_s[:, k] - self._delayed_v(slot)[:, k]
                self._fuse_axis(_VEL + k, innov_k, vel_var[:, k], ok)
        yaw = use & ((ctrl & EV_YAW) != 0) & np.isfinite(yaw_rad)
        if yaw.any():
            r_d = quat.to_rotation_matrix(self._buf_q[slot, self._idx])
            yaw_d = quat.yaw_of(r_d) + self._corr_yaw - self._buf_corr_yaw[slot, self._idx]
            innov = quat.wrap_pi(np.nan_to_num(yaw_rad) - yaw_d)
            var = np.fmax(yaw_var_rad2, prm.eva_noise_rad**2)
            h = self._yaw_row()
            s = np.einsum("ni,nij,nj->n", h, self.P, h) + var
            ratio = innov * innov / (gate * gate * s)
            ok = yaw & (ratio <= 1.0)
            self._fuse_row(h, innov, var, ok)
