"""State estimation from HIL sensor messages, batched over the fleet.

Two filters, as a small-vehicle autopilot without PX4's full EKF2 would run them:

* attitude: a Mahony-style complementary filter (gyro integration corrected by the gravity
  direction and the magnetometer heading, with gyro-bias integration). The accelerometer reference
  is compensated with the estimated NED acceleration, so a multirotor that accelerates does not
  drift towards "level" the way a plain complementary filter would;
* position and velocity: linear Kalman filters (filterpy's ``KalmanFilter``) driven by the
  rotated accelerometer and corrected by GPS (position, velocity) and the barometer (height, the
  primary height reference as in PX4's default EKF2_HGT_REF).

Every vehicle runs the same linear model on the same sensor schedule, so the Kalman covariance
and gain are identical across the fleet: one covariance is propagated with filterpy and its gain is
applied to the (2, N) state matrices of all vehicles at once. Controllers only ever see these
estimates, never ground truth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from filterpy.kalman import KalmanFilter

from autopilot_emu import quaternion as quat

GRAVITY_M_S2 = 9.80665
_G_NED = np.array([0.0, 0.0, GRAVITY_M_S2])


@dataclass(frozen=True)
class EstimatorConfig:
    """Tuning of the fleet estimator."""

    accel_gain: float = 0.4
    """Gravity-direction correction gain, rad/s per unit direction error."""
    mag_gain: float = 0.4
    """Heading correction gain, rad/s per rad of heading error."""
    bias_gain: float = 0.02
    """Gyro-bias integration gain, 1/s."""
    accel_lpf_tau_s: float = 0.3
    """Time constant of the NED-acceleration estimate used to compensate the accelerometer, s."""
    accel_noise_m_s2: float = 0.5
    """Process noise of the position filters (accelerometer + attitude error), m/s²."""
    gps_pos_std_h_m: float = 0.6
    gps_pos_std_v_m: float = 3.0
    gps_vel_std_h_m_s: float = 0.15
    gps_vel_std_v_m_s: float = 0.25
    baro_std_m: float = 0.4
    settle_s: float = 1.0
    """Time after the first GPS fix before the global position is declared good, s."""
    mag_declination_deg: float = 2.6
    """Magnetic declination (PX4 looks this up from its WMM table; here EKF2_MAG_DECL)."""


class _SharedGain:
    """One filterpy KalmanFilter tracking the covariance shared by all vehicles on one axis group.

    Its state vector is unused (the fleet's states live in a (2, columns) matrix); it exists to
    propagate P and compute the gain K. Prediction is lazy: P is advanced over the whole interval
    since the last measurement just before each update, with that interval's F and Q.
    """

    def __init__(self, dim_z: int, accel_noise_m_s2: float) -> None:
        self.kf = KalmanFilter(dim_x=2, dim_z=dim_z)
        self.kf.P = np.diag([100.0, 4.0])
        self._s2 = accel_noise_m_s2**2
        self.pending_s = 0.0

    def gain(self, h: np.ndarray, r: np.ndarray) -> np.ndarray:
        """Predict P over the pending interval, update it with (H, R); return K."""
        dt = self.pending_s
        if dt > 0.0:
            self.kf.F = np.array([[1.0, dt], [0.0, 1.0]])
            self.kf.Q = self._s2 * np.array([[dt**4 / 4, dt**3 / 2], [dt**3 / 2, dt**2]])
            self.kf.predict()
            self.pending_s = 0.0
        self.kf.update(np.zeros(h.shape[0]), R=r, H=h)
        return self.kf.K


_H_POS = np.array([[1.0, 0.0]])
_H_POS_VEL = np.eye(2)


class FleetEstimator:
    """Attitude, velocity and position estimates of N vehicles in their own NED frames."""

    def __init__(self, n: int, config: EstimatorConfig | None = None) -> None:
        self.n = n
        self.config = config or EstimatorConfig()
        cfg = self.config
        self.q = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
        """Attitude body FRD -> NED, [w, x, y, z]."""
        self.r = quat.to_rotation_matrix(self.q)
        """Rotation matrices of ``q`` (refreshed once per IMU sample)."""
        self.gyro_bias_rad_s = np.zeros((n, 3))
        self.rates_rad_s = np.zeros((n, 3))
        """Bias-corrected body rates, rad/s."""
        self.accel_ned_m_s2 = np.zeros((n, 3))
        """Low-passed NED acceleration estimate, m/s²."""
        self.attitude_ok = np.zeros(n, dtype=bool)
        self.origin_set = np.zeros(n, dtype=bool)
        self.origin_lla = np.zeros((n, 3))
        """EKF origin: latitude, longitude (deg), altitude AMSL (m) of each vehicle's NED frame."""
        self.baro_offset_m = np.zeros(n)
        """pressure_alt - GPS altitude at the origin fix, m."""
        self.time_s = 0.0
        self.first_fix_s = np.full(n, np.inf)
        self.gps_fix_type = np.zeros(n, dtype=int)
        self.gps_time_s = np.full(n, -np.inf)
        # Kalman state: rows (position, velocity); columns north_0..N-1, east_0..N-1, down_0..N-1.
        self._x = np.zeros((2, 3 * n))
        self._h_gain = _SharedGain(2, cfg.accel_noise_m_s2)
        self._v_gain = _SharedGain(2, cfg.accel_noise_m_s2)
        self._r_gps_h = np.diag([cfg.gps_pos_std_h_m**2, cfg.gps_vel_std_h_m_s**2])
        self._r_gps_v = np.diag([cfg.gps_pos_std_v_m**2, cfg.gps_vel_std_v_m_s**2])
        self._r_baro = np.array([[cfg.baro_std_m**2]])
        self._last_vel = np.zeros((n, 3))
        self._decl_rad = np.full(n, np.radians(cfg.mag_declination_deg))
        self._mag_corr: np.ndarray | None = None

    # -- read-only views -------------------------------------------------------------------
    @property
    def position_ned_m(self) -> np.ndarray:
        """(N, 3) position in each vehicle's NED frame, m."""
        return self._x[0].reshape(3, self.n).T

    @property
    def velocity_ned_m_s(self) -> np.ndarray:
        """(N, 3) velocity NED, m/s."""
        return self._x[1].reshape(3, self.n).T

    @property
    def position_ok(self) -> np.ndarray:
        """(N,) true once the local/global position estimate can be trusted."""
        fresh = (self.time_s - self.gps_time_s) < 1.0
        settled = (self.time_s - self.first_fix_s) >= self.config.settle_s
        return self.origin_set & self.attitude_ok & fresh & settled & (self.gps_fix_type >= 3)

    @property
    def variances(self) -> tuple[float, float, float, float]:
        """Position variance (horizontal per axis, vertical), m², then velocity variance, m²/s².

        After the last measurement update; the covariance is shared by the fleet.
        """
        p_h, p_v = self._h_gain.kf.P, self._v_gain.kf.P
        return float(p_h[0, 0]), float(p_v[0, 0]), float(p_h[1, 1]), float(p_v[1, 1])

    def set_declination(self, declination_deg: np.ndarray | list[float]) -> None:
        """Apply each vehicle's EKF2_MAG_DECL, (N,) degrees."""
        self._decl_rad = np.radians(np.asarray(declination_deg, dtype=float))

    # -- sensor updates ----------------------------------------------------------------------
    def update_imu(self, accel_frd: np.ndarray, gyro_frd: np.ndarray, dt_s: float) -> None:
        """Propagate with one IMU sample per vehicle (specific force m/s², rates rad/s)."""
        cfg = self.config
        self.time_s += dt_s
        r = self.r
        # Expected specific force from the estimated acceleration: f = R^T (a - g).
        f_exp = np.einsum("nji,nj->ni", r, self.accel_ned_m_s2 - _G_NED)
        a_unit = accel_frd / np.maximum(quat.row_norm(accel_frd), 1e-6)[:, None]
        v_unit = f_exp / np.maximum(quat.row_norm(f_exp), 1e-6)[:, None]
        err = quat.cross(a_unit, v_unit)
        rates = gyro_frd - self.gyro_bias_rad_s
        self.gyro_bias_rad_s -= (cfg.bias_gain * dt_s) * err
        self.rates_rad_s = rates
        omega = rates + cfg.accel_gain * err
        if self._mag_corr is not None:
            omega += self._mag_corr
            self._mag_corr = None
        self.q = quat.integrate(self.q, omega, dt_s)
        # Position/velocity prediction with the rotated accelerometer (old R: start of interval).
        acc_ned = np.einsum("nij,nj->ni", r, accel_frd) + _G_NED
        a = acc_ned.T.reshape(-1)
        x = self._x
        x[0] += x[1] * dt_s + (0.5 * dt_s * dt_s) * a
        x[1] += a * dt_s
        self._h_gain.pending_s += dt_s
        self._v_gain.pending_s += dt_s
        self.r = quat.to_rotation_matrix(self.q)

    def update_mag(self, mag_frd: np.ndarray, mask: np.ndarray) -> None:
        """Heading correction from the magnetometer, applied by the next ``update_imu``."""
        if not mask.any():
            return
        r = self.r
        m_ned = np.einsum("nij,nj->ni", r, mag_frd)
        heading_err = quat.wrap_pi(np.arctan2(m_ned[:, 1], m_ned[:, 0]) - self._decl_rad)
        heading_err *= mask & self.attitude_ok
        # A NED-z rate of -k*err, expressed in the body frame (third row of R).
        self._mag_corr = (-self.config.mag_gain * heading_err)[:, None] * r[:, 2, :]

    def align_heading(self, accel_frd: np.ndarray, mag_frd: np.ndarray, mask: np.ndarray) -> None:
        """Initial alignment (roll/pitch from gravity, yaw from the magnetometer)."""
        if not mask.any():
            return
        a = accel_frd[mask]
        roll = np.arctan2(-a[:, 1], -a[:, 2])
        pitch = np.arctan2(a[:, 0], np.hypot(a[:, 1], a[:, 2]))
        zeros = np.zeros_like(roll)
        tilt = quat.to_rotation_matrix(quat.from_euler(np.stack((roll, pitch, zeros), axis=1)))
        m_h = np.einsum("nij,nj->ni", tilt, mag_frd[mask])
        yaw = quat.wrap_pi(self._decl_rad[mask] - np.arctan2(m_h[:, 1], m_h[:, 0]))
        self.q[mask] = quat.from_euler(np.stack((roll, pitch, yaw), axis=1))
        self.r = quat.to_rotation_matrix(self.q)
        self.attitude_ok[mask] = True

    def update_baro(self, pressure_alt_m: np.ndarray, mask: np.ndarray) -> None:
        """Height correction from the barometer (vehicles with an origin only)."""
        use = mask & self.origin_set
        if not use.any():
            return
        z = -(pressure_alt_m - self.baro_offset_m - self.origin_lla[:, 2])
        k = self._v_gain.gain(_H_POS, self._r_baro)
        xv = self._x[:, 2 * self.n :]
        innov = np.where(use, z - xv[0], 0.0)
        xv += k @ innov[None, :]

    def update_gps(
        self,
        ned_m: np.ndarray,
        vel_ned_m_s: np.ndarray,
        fix_type: np.ndarray,
        lla: np.ndarray,
        pressure_alt_m: np.ndarray,
    ) -> np.ndarray:
        """Fuse a GPS sample; returns the mask of vehicles whose origin was set just now.

        ``ned_m`` must be the fix expressed in each vehicle's NED frame (callers convert with
        the origin; for vehicles without an origin it is ignored). ``lla`` is (N, 3)
        latitude/longitude (deg) and AMSL altitude (m) of the fix.
        """
        n = self.n
        self.gps_fix_type = fix_type.astype(int)
        good = fix_type >= 3
        self.gps_time_s[good] = self.time_s
        new_origin = good & ~self.origin_set & self.attitude_ok
        x = self._x
        if new_origin.any():
            self.origin_lla[new_origin] = lla[new_origin]
            self.baro_offset_m[new_origin] = pressure_alt_m[new_origin] - lla[new_origin, 2]
            self.origin_set |= new_origin
            self.first_fix_s[new_origin] = self.time_s
            idx = np.nonzero(new_origin)[0]
            for axis in range(3):
                x[0, axis * n + idx] = 0.0
                x[1, axis * n + idx] = vel_ned_m_s[idx, axis]
        use = good & self.origin_set & ~new_origin
        if not use.any():
            return new_origin
        kh = self._h_gain.gain(_H_POS_VEL, self._r_gps_h)
        kv = self._v_gain.gain(_H_POS_VEL, self._r_gps_v)
        z = np.stack((ned_m.T.reshape(-1), vel_ned_m_s.T.reshape(-1)))
        innov = (z - x) * np.tile(use, 3)
        x[:, : 2 * n] += kh @ innov[:, : 2 * n]
        x[:, 2 * n :] += kv @ innov[:, 2 * n :]
        return new_origin

    # -- internals ---------------------------------------------------------------------------
    def update_acceleration(self, dt_s: float) -> None:
        """Refresh the NED-acceleration estimate (navigation rate is enough for its 0.3 s LPF)."""
        vel = self.velocity_ned_m_s
        deriv = (vel - self._last_vel) * (1.0 / dt_s)
        self._last_vel = vel.copy()
        alpha = dt_s / (self.config.accel_lpf_tau_s + dt_s)
        deriv = np.minimum(np.maximum(deriv, -30.0), 30.0)
        self.accel_ned_m_s2 += alpha * (deriv - self.accel_ned_m_s2)
        # Without a position fix there is nothing to compensate with.
        if not self.origin_set.all():
            self.accel_ned_m_s2[~self.origin_set] = 0.0
