"""The flight stacks of N vehicles, advanced together from HIL sensor messages.

Inputs and outputs are the PX4 simulator messages (pymavlink objects): HIL_SENSOR at the IMU
rate, HIL_GPS at the GPS rate and BATTERY_STATUS (the power module's voltage and current) in,
HIL_ACTUATOR_CONTROLS out, one per vehicle. Whether they come
from PyBullet in memory or from a socket makes no difference here. Each IMU sample runs estimator
prediction, attitude and rate control and the mixer for the whole fleet in numpy; navigation
(commander + position control) runs at ``nav_hz``.
"""

from __future__ import annotations

import functools
import math
import operator
from dataclasses import dataclass, field

import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu import geodesy, magnetic_declination
from autopilot_emu import quaternion as quat
from autopilot_emu.battery import BatteryParams, FleetBattery
from autopilot_emu.commander import Commander, Home, NavInput, NavOutput
from autopilot_emu.control.hover_thrust import HoverThrustEstimator, HoverThrustParams
from autopilot_emu.control.hover_thrust_kernel import hover_thrust_tick_kernel
from autopilot_emu.control.inner_loop_kernel import inner_loop_kernel
from autopilot_emu.control.mixer import MAX_ROTORS, Mixer, RotorGeometry
from autopilot_emu.control.nav_kernel import nav_kernel
from autopilot_emu.control.position import PositionController, PositionGains, PositionSetpoint
from autopilot_emu.control.rate import RateController
from autopilot_emu.control.trajectory import (
    JerkLimitedTrajectory,
    TrajectoryLimits,
    load_hold_point_kernel,
)
from autopilot_emu.estimator import EstimatorConfig, FleetEstimator
from autopilot_emu.hil_sensor_kernel import hil_sensor_kernel
from autopilot_emu.mavlink.vehicle_port import TelemetrySnapshot
from autopilot_emu.mission.camera_items import ComponentCommand
from autopilot_emu.mission.items import MissionItem, MissionType
from autopilot_emu.modes import LandedState
from autopilot_emu.modes.offboard import (
    AltitudeReference,
    GlobalSetpoint,
    LocalFrame,
    OffboardSetpoint,
    to_local_ned,
)
from autopilot_emu.params import ParamStore, param_column
from autopilot_emu.rangefinder import FleetRangefinders
from autopilot_emu.telemetry import FleetTelemetry
from autopilot_emu.terrain import FleetTerrain, TerrainParams

_HIL_SENSOR_FIELDS = operator.attrgetter(
    "xacc", "yacc", "zacc", "xgyro", "ygyro", "zgyro", "xmag", "ymag", "zmag", "pressure_alt",
    "fields_updated",
)  # fmt: skip
"""A HIL_SENSOR's fields in the order ``hil_sensor_kernel`` reads them."""
_MODE_DISARMED = mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
_MODE_ARMED = _MODE_DISARMED | mavlink2.MAV_MODE_FLAG_SAFETY_ARMED
"""HIL_ACTUATOR_CONTROLS mode of a disarmed / armed vehicle."""
_VERSION = operator.attrgetter("version")
_FAILURE_UNIT_GPS = mavlink2.FAILURE_UNIT_SENSOR_GPS
_FAILURE_UNIT_MAG = mavlink2.FAILURE_UNIT_SENSOR_MAG
_FAILURE_OK, _FAILURE_OFF = mavlink2.FAILURE_TYPE_OK, mavlink2.FAILURE_TYPE_OFF
_FAILURE_WRONG = mavlink2.FAILURE_TYPE_WRONG
_NO_CELL = 65535  # BATTERY_STATUS.voltages entry of a cell that is not there


@dataclass(frozen=True)
class FleetConfig:
    """Structure of the fleet's flight stacks."""

    n_vehicles: int
    nav_hz: float = 50.0
    """Commander, navigator and position control rate, Hz."""
    imu_hz: float = 250.0
    """Expected IMU rate, used for the very first sample only, Hz."""
    estimator: EstimatorConfig = field(default_factory=EstimatorConfig)

    def __post_init__(self) -> None:
        if self.n_vehicles < 1:
            raise ValueError(f"n_vehicles must be >= 1, got {self.n_vehicles}")
        if not (self.nav_hz > 0 and self.imu_hz > 0):
            raise ValueError("nav_hz and imu_hz must be positive")


class AutopilotFleet:
    """N PX4-flavoured flight stacks sharing vectorised estimation and control."""

    def __init__(self, config: FleetConfig, params: list[ParamStore] | None = None) -> None:
        n = config.n_vehicles
        self.config = config
        self.n = n
        self.params = params if params is not None else [ParamStore() for _ in range(n)]
        if len(self.params) != n:
            raise ValueError(f"expected {n} parameter stores, got {len(self.params)}")
        self.estimator = FleetEstimator(n, config.estimator)
        self.commanders = [Commander(p) for p in self.params]
        self.position_control = PositionController(n)
        self.trajectory = JerkLimitedTrajectory(n)
        """Auto-mode setpoint smoothing between the commander and the position controller."""
        self._smooth = np.zeros(n, dtype=bool)
        """Vehicles whose commander asks for a smoothed target (auto modes)."""
        self._smoothing = np.zeros(n, dtype=bool)
        """Vehicles whose position controller tracked the trajectory at the last tick."""
        for i, cmd in enumerate(self.commanders):
            cmd.trajectory_state = functools.partial(self._trajectory_state, i)
        load_hold_point_kernel()  # not at the first Hold, mid-flight
        self.rate_control = RateController(n)
        self.mixer = Mixer([RotorGeometry.from_params(p) for p in self.params])
        self.battery = FleetBattery(n)
        self.time_usec = 0
        self.thrust = np.zeros(n)
        self.outputs = np.zeros((n, MAX_ROTORS))
        """Motor outputs 0..1 in PX4's output order, (N, MAX_ROTORS); unused outputs 0."""
        self.active = np.zeros(n, dtype=bool)
        self.armed = np.zeros(n, dtype=bool)
        self.q_sp = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
        self.rate_sp = np.zeros((n, 3))
        """Body-rate setpoints of the attitude loop, (N, 3) rad/s."""
        self.last_sensors: list[mavlink2.MAVLink_hil_sensor_message] | None = None
        """The last HIL_SENSOR of each vehicle (HIGHRES_IMU)."""
        self.last_gps: list[mavlink2.MAVLink_hil_gps_message | None] = [None] * n
        self.gps_failed = np.zeros(n, dtype=bool)
        """GPS switched off by MAV_CMD_INJECT_FAILURE: its samples are dropped."""
        self.mag_failure = np.full(n, _FAILURE_OK)
        """MAV_CMD_INJECT_FAILURE type of each magnetometer (OK, OFF or WRONG)."""
        self._sp = PositionSetpoint.hold(n)
        self._nav_period_s = 1.0 / config.nav_hz
        self._nav_accum_s = self._nav_period_s  # run navigation on the first sample
        self._param_versions: list[int] = []
        self._gains: _Gains | None = None
        self.hover_thrust_estimator: HoverThrustEstimator | None = None
        """PX4's mc_hover_thrust_estimator for each vehicle (built with the gains)."""
        self.hover_thrust = np.zeros(n)
        """Hover thrust the position controller uses: the last valid estimate since arming, else
        MPC_THR_HOVER, (N,) 0..1."""
        self.hover_thrust_learned = np.zeros(n, dtype=bool)
        """The hover-thrust estimator has been valid since arming: ``hover_thrust`` is learned."""
        self._controls_tail = [0.0] * (16 - MAX_ROTORS)
        """HIL_ACTUATOR_CONTROLS entries after the motor outputs (always 0)."""
        self._pressure_alt_m = np.zeros(n)
        self.metres_per_degree = np.ones((n, 2))
        """Local projection scale of each vehicle's EKF origin (lat, lon), m/deg."""
        self._att_target_q = np.full((n, 4), np.nan)
        """Offboard attitude setpoints (NaN rows: none)."""
        self._overridden = np.zeros(n, dtype=bool)
        self._att_target_thrust = np.full(n, np.nan)
        """Offboard collective thrust of attitude / rate setpoints (NaN: position control)."""
        self._rate_target = np.full((n, 3), np.nan)
        """Offboard body-rate setpoints, rad/s (NaN: from the attitude loop)."""
        self.rangefinders = FleetRangefinders(n)
        """Latest DISTANCE_SENSOR reading of every sensor of every vehicle."""
        self.terrain = FleetTerrain(n)
        """Terrain under each vehicle from its downward range finder (EKF2_RNG_CTRL)."""
        self.terrain_params: TerrainParams | None = None
        self.terrain_updates = 0
        """Count of terrain updates (telemetry re-reads its rows when it changes)."""
        self.telemetry = FleetTelemetry(self)
        """Per-vehicle telemetry snapshots, read from these arrays once per instant."""

    # -- simulator side ------------------------------------------------------------------------
    def handle_sensors(
        self, msgs: list[mavlink2.MAVLink_hil_sensor_message]
    ) -> list[mavlink2.MAVLink_hil_actuator_controls_message]:
        """Consume one HIL_SENSOR per vehicle; return one HIL_ACTUATOR_CONTROLS per vehicle."""
        est = self.estimator
        n = self.n
        raw = np.array(list(map(_HIL_SENSOR_FIELDS, msgs)), dtype=np.float64)
        imu = np.empty((3, n, 3))
        baro = np.empty(n)
        flags = np.empty((2, n), dtype=np.bool_)
        hil_sensor_kernel(raw, self.mag_failure, self._pressure_alt_m, imu, baro, flags)
        acc, gyro, mag = imu[0], imu[1], imu[2]
        has_mag, has_baro = flags[0], flags[1]
        t_usec = int(msgs[0].time_usec)
        self.last_sensors = msgs
        if self.time_usec == 0 or t_usec <= self.time_usec:
            dt = 1.0 / self.config.imu_hz
        else:
            dt = min((t_usec - self.time_usec) * 1e-6, 0.05)
        self.time_usec = t_usec
        if not est.attitude_ok.all():
            est.align_heading(acc, mag, has_mag & ~est.attitude_ok)
        est.update_sensors(acc, gyro, dt, mag, has_mag, baro, has_baro)  # mag, IMU, baro

        gains = self._refresh_gains()
        self._nav_accum_s += dt
        if self._nav_accum_s >= self._nav_period_s - 1e-9:
            est.update_acceleration(self._nav_accum_s)
            self._update_hover_thrust(self._nav_accum_s, gains)
            self._navigate(self._nav_accum_s, gains)
            self._nav_accum_s = 0.0
        self._control(dt, gains)
        return self._actuator_messages(t_usec)

    def handle_battery(self, msgs: list[mavlink2.MAVLink_battery_status_message]) -> None:
        """Consume one BATTERY_STATUS per vehicle (pack voltage and current, as a power module).

        The pack voltage is the sum of the valid cell entries (a power module reports it whole
        in cell 0); a current of -1 is unknown.
        """
        self._refresh_gains()
        volts = np.array([sum(c for c in m.voltages if c != _NO_CELL) * 1e-3 for m in msgs])
        amps = np.array([m.current_battery * 0.01 for m in msgs], dtype=float)
        self.battery.update(volts, amps, self.time_usec * 1e-6)

    def handle_distance_sensors(
        self, msgs: list[list[mavlink2.MAVLink_distance_sensor_message]]
    ) -> None:
        """Consume DISTANCE_SENSOR messages, one list per vehicle (empty: none from it).

        Each becomes that sensor's latest reading (forwarded on the vehicle's MAVLink links); a
        downward-facing one also feeds the terrain estimate (``autopilot_emu.terrain``).
        """
        self._refresh_gains()
        new_down = self.rangefinders.update(msgs)
        if new_down.any() and self.terrain_params is not None:
            est, rf = self.estimator, self.rangefinders
            self.terrain.update(
                est.time_s,
                new_down,
                rf.down_distance_m,
                rf.down_valid,
                est.position_ned_m[:, 2],
                est.position_variance_m2[:, 2],
                est.velocity_ned_m_s,
                est.r,
                self.terrain_params,
            )
            self.terrain_updates += 1

    def handle_gps(self, msgs: list[mavlink2.MAVLink_hil_gps_message]) -> None:
        """Consume one HIL_GPS per vehicle."""
        est = self.estimator
        g = np.array(
            [
                (
                    m.lat,
                    m.lon,
                    m.alt,
                    m.vn,
                    m.ve,
                    m.vd,
                    m.fix_type,
                    m.eph,
                    m.epv,
                    m.satellites_visible,
                )
                for m in msgs
            ],
            dtype=float,
        )
        if self.gps_failed.any():
            g[self.gps_failed, 6] = 0  # no fix: the estimator ignores the sample
            msgs = [None if off else m for m, off in zip(msgs, self.gps_failed, strict=True)]
        self.last_gps = list(msgs)
        lla = np.stack((g[:, 0] * 1e-7, g[:, 1] * 1e-7, g[:, 2] * 1e-3), axis=1)
        vel = g[:, 3:6] * 0.01
        ned = geodesy.geodetic_to_ned(lla, est.origin_lla)
        # HIL_GPS eph/epv are cm (UINT16_MAX: unknown -> not usable); satellites 255: unknown.
        eph = np.where(g[:, 7] >= 65535, np.inf, g[:, 7] * 0.01)
        epv = np.where(g[:, 8] >= 65535, np.inf, g[:, 8] * 0.01)
        sats = np.where(g[:, 9] >= 255, 0.0, g[:, 9])
        new_origin = est.update_gps(ned, vel, g[:, 6], lla, self._pressure_alt_m, eph, epv, sats)
        if new_origin.any():
            self.metres_per_degree = geodesy.metres_per_degree(est.origin_lla)
            est.set_declination(  # PX4's geo lookup at the new origin (EKF2_DECL_TYPE bit 0)
                magnetic_declination.on_new_origin(
                    self.params, est.origin_lla, est.origin_set, new_origin
                )
            )

    # -- loops ------------------------------------------------------------------------------------
    def _navigate(self, dt: float, gains: _Gains) -> None:
        est = self.estimator
        pos, vel = est.position_ned_m, est.velocity_ned_m_s
        yaw = quat.yaw_of(est.r).tolist()
        ok = est.position_ok.tolist()
        origin = est.origin_lla.tolist()
        origin_set = est.origin_set.tolist()
        thrust = self.thrust.tolist()
        remaining = self.battery.remaining.tolist()
        # The commander gets the learned hover thrust only (NaN until the estimator is valid):
        # its land detector must not judge "low thrust" against the MPC_THR_HOVER guess.
        hover = np.where(self.hover_thrust_learned, self.hover_thrust, np.nan).tolist()
        sp = self._sp
        time_s = est.time_s
        for i, cmd in enumerate(self.commanders):
            lat, lon, alt = origin[i] if origin_set[i] else (math.nan, math.nan, 0.0)
            out: NavOutput = cmd.update(
                NavInput(
                    time_s,
                    pos[i],
                    vel[i],
                    yaw[i],
                    ok[i],
                    thrust[i],
                    alt,
                    (lat, lon),
                    remaining[i],
                    hover[i],
                )
            )
            sp.position_ned_m[i] = out.position_ned_m
            sp.velocity_ff_m_s[i] = out.velocity_ff_m_s
            sp.yaw_rad[i] = out.yaw_rad
            sp.max_speed_xy_m_s[i] = out.max_speed_xy_m_s
            sp.max_speed_up_m_s[i] = out.max_speed_up_m_s
            sp.max_speed_down_m_s[i] = out.max_speed_down_m_s
            sp.acceleration_ff_m_s2[i] = out.acceleration_ff_m_s2
            self._att_target_thrust[i] = out.thrust
            if math.isfinite(out.thrust):
                att = out.attitude_wxyz
                self._att_target_q[i] = att if att is not None else np.nan
                rates = out.body_rates_rad_s
                self._rate_target[i] = rates if rates is not None else np.nan
            self.active[i] = out.active
            self._smooth[i] = out.smooth
            self.armed[i] = cmd.armed
        self._control_positions(pos, vel, dt, gains)

    def _trajectory_state(self, i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """Vehicle i's smoothed setpoint (position, velocity, acceleration), None if unsmoothed."""
        if not self._smoothing[i]:
            return None
        t = self.trajectory
        return t.position_m[i], t.velocity_m_s[i], t.acceleration_m_s2[i]

    def _control_positions(
        self, pos: np.ndarray, vel: np.ndarray, dt: float, gains: _Gains
    ) -> None:
        """Trajectory smoothing, position control and offboard overrides: one compiled call.

        Auto-mode targets are replaced by the jerk-limited trajectory's state (position on the
        axes the commander controls by position, velocity and acceleration as feed-forward), and
        the controller's own limits become MPC_XY_VEL_MAX / MPC_Z_VEL_MAX_UP / _DN, as in PX4, so
        that it can catch up with the trajectory. Idle vehicles restart their position and rate
        controllers; offboard attitude / thrust setpoints replace the position loop's output.
        """
        sp, traj, pc = self._sp, self.trajectory, self.position_control
        nav_kernel(
            sp.position_ned_m, sp.velocity_ff_m_s, sp.yaw_rad, sp.max_speed_xy_m_s,
            sp.max_speed_up_m_s, sp.max_speed_down_m_s, sp.acceleration_ff_m_s2, sp.smoothed,
            gains.limits_packed, traj.position_m, traj.velocity_m_s, traj.acceleration_m_s2,
            self._smooth, self._smoothing,
            gains.position_axes, gains.position_vehicle, self.hover_thrust,
            pc.vel_int, pc.vel_sp, pc._prev_vel, self.rate_control.integral,
            pos, vel, dt, self.active,
            self._att_target_q, self._att_target_thrust,
            self.q_sp, self.thrust, self._overridden,
        )  # fmt: skip

    def _update_hover_thrust(self, dt: float, gains: _Gains) -> None:
        """Fuse one sample into the hover-thrust estimators; hand the result to the controller.

        Inputs are the autopilot's own: the estimated vertical acceleration and the upward part
        of the last collective thrust command. Until an estimate is valid the controller uses
        MPC_THR_HOVER; afterwards the last valid estimate (PX4 keeps it while a manoeuvre makes
        the estimate invalid). When the value in use changes, the vertical velocity integrator
        absorbs the change so the thrust stays continuous (as PX4's updateHoverThrust).
        """
        hte = self.hover_thrust_estimator
        assert hte is not None
        est, p, pc = self.estimator, hte.params, self.position_control
        flying = np.array(
            [c.in_air and c.landed_state != LandedState.TAKEOFF for c in self.commanders]
        )
        hover_thrust_tick_kernel(
            flying, self.armed, est.accel_ned_m_s2, self.thrust, est.r, est.velocity_ned_m_s,
            dt, p.initial, p.process_noise, p.gate, p.error_init, p.range,
            p.vxy_threshold_m_s, p.vz_threshold_m_s, hte.hover_thrust, hte.variance,
            hte.acc_variance, hte.residual_lpf, hte.ratio_lpf, hte.valid, hte._good_for_s,
            self.hover_thrust_learned, self.hover_thrust, pc.vel_int,
        )  # fmt: skip

    def _control(self, dt: float, gains: _Gains) -> None:
        """Attitude, rate control and mixer of every vehicle: one compiled call per IMU sample."""
        est, rc, mixer = self.estimator, self.rate_control, self.mixer
        inner_loop_kernel(
            est.q, est.rates_rad_s, self.q_sp, self.thrust, gains.inner, self._overridden,
            self._rate_target, dt, self.active, self.armed, rc.integrator_limit, rc.integral,
            rc._prev_rates, mixer.matrix, mixer.thrust_column, mixer.used, mixer.idle_output,
            self.rate_sp, self.outputs,
        )  # fmt: skip

    def _actuator_messages(
        self, t_usec: int
    ) -> list[mavlink2.MAVLink_hil_actuator_controls_message]:
        build = mavlink2.MAVLink_hil_actuator_controls_message
        # float32, as HIL_ACTUATOR_CONTROLS carries them: in memory or packed, the same numbers.
        outputs = self.outputs.astype(np.float32).tolist()
        armed, tail = self.armed.tolist(), self._controls_tail
        return [
            build(t_usec, outputs[i] + tail, _MODE_ARMED if armed[i] else _MODE_DISARMED, 0)
            for i in range(self.n)
        ]

    def _refresh_gains(self) -> _Gains:
        versions = list(map(_VERSION, self.params))
        if versions != self._param_versions or self._gains is None:
            self.estimator.set_params(self.params)
            self._gains = _Gains.from_params(self.params)
            self._param_versions = versions
            est = self.estimator
            est.set_declination(
                magnetic_declination.declinations_deg(self.params, est.origin_lla, est.origin_set)
            )
            self.battery.set_params(_battery_params(self.params))
            self.terrain_params = TerrainParams.from_params(self.params)
            hte_params = _hover_thrust_params(self.params)
            if self.hover_thrust_estimator is None:
                self.hover_thrust_estimator = HoverThrustEstimator(hte_params)
            else:
                self.hover_thrust_estimator.set_params(hte_params)
            if not self.hover_thrust.any():
                self.hover_thrust = hte_params.initial.copy()
            self._gains.position.hover_thrust = self.hover_thrust
            self._gains.hover_thrust = self.hover_thrust
            geometries = [RotorGeometry.from_params(p) for p in self.params]
            if any(
                g.moment_ratio_m.tolist() != o.moment_ratio_m.tolist()
                or g.position_m.tolist() != o.position_m.tolist()
                for g, o in zip(geometries, self.mixer.geometries, strict=True)
            ):
                self.mixer = Mixer(geometries, self.mixer.idle_output)
        return self._gains

    @property
    def setpoint(self) -> PositionSetpoint:
        """What the position controller tracks, (N, ...) arrays (NaN position: not controlled)."""
        return self._sp

    # -- per-vehicle views ---------------------------------------------------------------------
    def vehicle(self, i: int) -> FleetVehicle:
        """The VehiclePort of vehicle i (what its MAVLink endpoint talks to)."""
        return FleetVehicle(self, i)

    def sync_commands(self, i: int) -> None:
        """Reflect a command's effect on the arrays at once (not at the next nav tick)."""
        cmd = self.commanders[i]
        self.armed[i] = cmd.armed
        if not cmd.armed:
            self.active[i] = False
            self.outputs[i] = 0.0
            self.thrust[i] = 0.0

    def handle_vision(
        self,
        index: int,
        time_usec: int,
        position_ned_m: np.ndarray,
        position_var_m2: np.ndarray,
        yaw_rad: float,
        yaw_var_rad2: float,
        velocity_ned_m_s: np.ndarray | None = None,
        velocity_var_m2_s2: np.ndarray | None = None,
    ) -> None:
        """Fuse one external-vision sample of vehicle ``index`` (EKF2_EV_CTRL selects the parts).

        Position NED (m) in the vehicle's local frame with per-axis variances (m²); yaw (rad, NaN:
        none) and its variance; velocity NED (m/s) or None. ``time_usec`` is when the sample was
        taken on the autopilot's clock: its age (0 to 0.5 s; outside that taken as 0) adds to
        EKF2_EV_DELAY.
        """
        n = self.n
        mask = np.zeros(n, dtype=bool)
        mask[index] = True
        pos = np.full((n, 3), np.nan)
        pos[index] = position_ned_m
        pos_var = np.full((n, 3), np.inf)
        pos_var[index] = position_var_m2
        yaw = np.full(n, np.nan)
        yaw[index] = yaw_rad
        yaw_var = np.full(n, np.inf)
        yaw_var[index] = yaw_var_rad2
        vel = np.full((n, 3), np.nan)
        vel_var = np.zeros((n, 3))
        if velocity_ned_m_s is not None:
            vel[index] = velocity_ned_m_s
            if velocity_var_m2_s2 is not None:
                vel_var[index] = velocity_var_m2_s2
        age = (self.time_usec - int(time_usec)) * 1e-6
        if not 0.0 <= age <= 0.5:
            age = 0.0
        self.estimator.update_vision(mask, pos, pos_var, yaw, yaw_var, vel, vel_var, age)


def _hover_thrust_params(params: list[ParamStore]) -> HoverThrustParams:
    def col(name: str) -> np.ndarray:
        return param_column(params, name)

    return HoverThrustParams(
        initial=col("MPC_THR_HOVER"),
        process_noise=col("HTE_HT_NOISE"),
        gate=col("HTE_ACC_GATE"),
        error_init=col("HTE_HT_ERR_INIT"),
        vxy_threshold_m_s=col("HTE_VXY_THR"),
        vz_threshold_m_s=col("HTE_VZ_THR"),
        range=col("HTE_THR_RANGE"),
    )


def _battery_params(params: list[ParamStore]) -> BatteryParams:
    def col(name: str) -> np.ndarray:
        return param_column(params, name)

    return BatteryParams(
        n_cells=col("BAT1_N_CELLS"),
        capacity_mah=col("BAT1_CAPACITY"),
        v_empty=col("BAT1_V_EMPTY"),
        v_charged=col("BAT1_V_CHARGED"),
        r_internal=col("BAT1_R_INTERNAL"),
    )


@dataclass
class _Gains:
    position: PositionGains
    att_p: np.ndarray
    rate_p: np.ndarray
    rate_i: np.ndarray
    rate_d: np.ndarray
    rate_max: np.ndarray
    hover_thrust: np.ndarray
    limits: TrajectoryLimits
    """Trajectory acceleration, jerk and error limits; its speeds are the controller's own
    (MPC_XY_VEL_MAX, MPC_Z_VEL_MAX_UP / _DN): the trajectory's come from the commander."""
    inner: np.ndarray = field(init=False)
    """(5, N, 3) att_p, rate_max, rate_p, rate_i, rate_d stacked for ``inner_loop_kernel``."""
    position_axes: np.ndarray = field(init=False)
    """(4, N, 3) pos_p, vel_p, vel_i, vel_d stacked for ``nav_kernel``."""
    position_vehicle: np.ndarray = field(init=False)
    """(3, N) tilt_max_rad, cos_tilt_max, acc_hor_max_m_s2 stacked for ``nav_kernel``."""
    limits_packed: np.ndarray = field(init=False)
    """(8, N) the ``limits`` fields in declaration order, for ``nav_kernel``."""

    def __post_init__(self) -> None:
        # Kernel arguments cost per array: stack what only changes with the parameters.
        self.inner = np.stack((self.att_p, self.rate_max, self.rate_p, self.rate_i, self.rate_d))
        g, lim = self.position, self.limits
        self.position_axes = np.stack((g.pos_p, g.vel_p, g.vel_i, g.vel_d))
        self.position_vehicle = np.stack((g.tilt_max_rad, g.cos_tilt_max, g.acc_hor_max_m_s2))
        self.limits_packed = np.stack(
            (
                lim.speed_xy_m_s, lim.speed_up_m_s, lim.speed_down_m_s, lim.acc_xy_m_s2,
                lim.acc_up_m_s2, lim.acc_down_m_s2, lim.jerk_m_s3, lim.error_max_m,
            )
        )  # fmt: skip

    @classmethod
    def from_params(cls, params: list[ParamStore]) -> _Gains:
        def col(name: str) -> np.ndarray:
            return param_column(params, name)

        def rpy(fmt: str) -> np.ndarray:
            return np.stack([col(fmt.format(a)) for a in ("ROLL", "PITCH", "YAW")], axis=1)

        hover = col("MPC_THR_HOVER")
        xyz = ("MPC_XY_{}", "MPC_XY_{}", "MPC_Z_{}")

        def axes(suffix: str) -> np.ndarray:
            return np.stack([col(fmt.format(suffix)) for fmt in xyz], axis=1)

        position = PositionGains(
            pos_p=axes("P"),
            vel_p=axes("VEL_P_ACC"),
            vel_i=axes("VEL_I_ACC"),
            vel_d=axes("VEL_D_ACC"),
            hover_thrust=hover,
            tilt_max_rad=np.radians(col("MPC_TILTMAX_AIR")),
            acc_hor_max_m_s2=col("MPC_ACC_HOR"),
        )
        return cls(
            position=position,
            att_p=rpy("MC_{}_P"),
            rate_p=rpy("MC_{}RATE_P"),
            rate_i=rpy("MC_{}RATE_I"),
            rate_d=rpy("MC_{}RATE_D"),
            rate_max=np.radians(rpy("MC_{}RATE_MAX")),
            hover_thrust=hover,
            limits=TrajectoryLimits(
                speed_xy_m_s=col("MPC_XY_VEL_MAX"),
                speed_up_m_s=col("MPC_Z_VEL_MAX_UP"),
                speed_down_m_s=col("MPC_Z_VEL_MAX_DN"),
                acc_xy_m_s2=col("MPC_ACC_HOR"),
                acc_up_m_s2=col("MPC_ACC_UP_MAX"),
                acc_down_m_s2=col("MPC_ACC_DOWN_MAX"),
                jerk_m_s3=col("MPC_JERK_AUTO"),
                error_max_m=col("MPC_XY_ERR_MAX"),
            ),
        )


class FleetVehicle:
    """One vehicle of an AutopilotFleet seen through the VehiclePort interface."""

    def __init__(self, fleet: AutopilotFleet, index: int) -> None:
        self.fleet = fleet
        self.index = index
        self.commander = fleet.commanders[index]
        self.params = fleet.params[index]

    def _sync(self, result: int) -> int:
        self.fleet.sync_commands(self.index)
        return result

    def _to_ned(self, lat: float, lon: float, alt: float) -> np.ndarray:
        lla = np.array([lat, lon, alt], dtype=float)
        return geodesy.geodetic_to_ned(lla, self.fleet.estimator.origin_lla[self.index])

    def _to_ned_partial(self, lat: float, lon: float, alt: float) -> np.ndarray:
        """As :meth:`_to_ned`, with NaN meaning "keep the current target" on that axis.

        A NaN latitude or longitude leaves north and east NaN, a NaN altitude leaves down NaN.
        """
        # Project with the unknown parts zeroed, then mark them NaN.
        target = self._to_ned(np.nan_to_num(lat), np.nan_to_num(lon), np.nan_to_num(alt))
        if not (math.isfinite(lat) and math.isfinite(lon)):
            target[:2] = np.nan
        if not math.isfinite(alt):
            target[2] = np.nan
        return target

    # -- commands ----------------------------------------------------------------------------
    def arm(self, force: bool) -> int:
        """Arm (see Commander.arm), after the estimator's preflight heading check."""
        est = self.fleet.estimator
        if not force and not self.commander.armed and est.heading_failure[self.index]:
            # PX4's estimator check (pre_flt_fail_innov_heading): magnetometer data keep
            # failing the heading innovation gate.
            self.commander.status_texts.append(
                (mavlink2.MAV_SEVERITY_CRITICAL, "Preflight Fail: heading estimate not stable")
            )
            return mavlink2.MAV_RESULT_DENIED
        return self._sync(self.commander.arm(force))

    def disarm(self, force: bool) -> int:
        """Disarm or, forced, kill."""
        return self._sync(self.commander.disarm(force))

    def takeoff(self, alt_amsl_m: float | None) -> int:
        """Take off to an AMSL altitude or MIS_TAKEOFF_ALT."""
        return self._sync(self.commander.takeoff(alt_amsl_m))

    def land(self) -> int:
        """Land here."""
        return self._sync(self.commander.land())

    def set_mode(self, main_mode: int, sub_mode: int) -> int:
        """PX4 mode switch."""
        return self._sync(self.commander.set_mode(main_mode, sub_mode))

    def reposition(
        self, lat_deg: float, lon_deg: float, alt_amsl_m: float, yaw_rad: float, speed_m_s: float
    ) -> int:
        """Fly to a geodetic point and hold there (NaN keeps)."""
        if not self.fleet.estimator.origin_set[self.index]:
            return 1
        target = self._to_ned_partial(lat_deg, lon_deg, alt_amsl_m)
        return self._sync(self.commander.reposition(target, yaw_rad, speed_m_s))

    def change_speed(self, speed_m_s: float) -> int:
        """Cruise speed override."""
        return self.commander.change_speed(speed_m_s)

    def set_home(self, use_current: bool, lat_deg: float, lon_deg: float, alt_amsl_m: float) -> int:
        """Move home to here or to a geodetic point."""
        cmd = self.commander
        if use_current:
            cmd.set_home_here()
            return 0 if cmd.home is not None else 1
        if not all(math.isfinite(v) for v in (lat_deg, lon_deg, alt_amsl_m)):
            return 2
        if not self.fleet.estimator.origin_set[self.index]:
            return 1
        cmd.home = Home(self._to_ned(lat_deg, lon_deg, alt_amsl_m), alt_amsl_m)
        return 0

    def terminate(self) -> int:
        """Motors off now."""
        return self._sync(self.commander.terminate())

    def pop_status_texts(self) -> list[tuple[int, str]]:
        """Events since the last call."""
        texts, self.commander.status_texts = self.commander.status_texts, []
        return texts

    # -- missions ---------------------------------------------------------------------------------
    def mission_items(self, kind: MissionType) -> tuple[MissionItem, ...]:
        """A stored plan."""
        return self.commander.missions.items(kind)

    def upload_mission(self, kind: MissionType, items: tuple[MissionItem, ...]) -> int:
        """Store a plan (see Commander.upload_mission)."""
        return self._sync(self.commander.upload_mission(kind, items))

    def set_mission_current(self, seq: int) -> bool:
        """Continue the mission at ``seq``."""
        return self.commander.set_mission_current(seq)

    def start_mission(self, first_seq: int) -> int:
        """Arm and start the mission (MAV_CMD_MISSION_START)."""
        return self._sync(self.commander.start_mission(first_seq))

    def mission_status(self) -> tuple[int, int, int]:
        """(seq, total, MISSION_STATE)."""
        return self.commander.mission_status()

    def pop_mission_reached(self) -> list[int]:
        """Items completed since the last call."""
        reached, self.commander.mission_reached = self.commander.mission_reached, []
        return reached

    def pop_component_commands(self) -> list[ComponentCommand]:
        """Commands for the vehicle's other components (its camera) since the last call."""
        commands, self.commander.component_commands = self.commander.component_commands, []
        return commands

    def gcs_heartbeat(self) -> None:
        """A ground station is alive."""
        self.commander.gcs_heartbeat()

    # -- offboard ---------------------------------------------------------------------------------
    def offboard_setpoint(self, setpoint: OffboardSetpoint, frame: LocalFrame) -> bool:
        """A local or body-frame setpoint: converted to local NED at the current pose."""
        if not setpoint.is_attitude and not setpoint.thrust_only:
            est, i = self.fleet.estimator, self.index
            yaw = float(quat.yaw_of(est.r[i : i + 1])[0])
            setpoint = to_local_ned(setpoint, frame, est.position_ned_m[i], yaw)
        return self.commander.offboard_setpoint(setpoint)

    def offboard_setpoint_global(self, target: GlobalSetpoint) -> bool:
        """A geodetic setpoint; ignored without an origin (or a home, for relative altitudes)."""
        cmd = self.commander
        if not self.fleet.estimator.origin_set[self.index]:
            return False
        alt = target.alt_m
        if target.reference != AltitudeReference.AMSL and math.isfinite(alt):
            if cmd.home is None:
                return False
            alt += cmd.home.alt_amsl_m
        ned = self._to_ned_partial(target.lat_deg, target.lon_deg, alt)
        rest = target.setpoint
        return cmd.offboard_setpoint(
            OffboardSetpoint(
                position_ned_m=ned,
                velocity_ned_m_s=rest.velocity_ned_m_s,
                acceleration_ned_m_s2=rest.acceleration_ned_m_s2,
                yaw_rad=rest.yaw_rad,
                yaw_rate_rad_s=rest.yaw_rate_rad_s,
            )
        )

    def inject_failure(self, unit: int, failure_type: int, instance: int) -> int:
        """GPS off / on, magnetometer off / wrong / ok (PX4's failure injection; SYS_FAILURE_EN)."""
        if int(self.params.get("SYS_FAILURE_EN")) != 1:
            return mavlink2.MAV_RESULT_DENIED
        if unit == _FAILURE_UNIT_MAG and failure_type in (
            _FAILURE_OK,
            _FAILURE_OFF,
            _FAILURE_WRONG,
        ):
            self.fleet.mag_failure[self.index] = failure_type
            text = {
                _FAILURE_OK: "Mag ok",
                _FAILURE_OFF: "Failure injected: Mag off",
                _FAILURE_WRONG: "Failure injected: Mag wrong",
            }
            self.commander.status_texts.append((mavlink2.MAV_SEVERITY_WARNING, text[failure_type]))
            return mavlink2.MAV_RESULT_ACCEPTED
        if unit != _FAILURE_UNIT_GPS or failure_type not in (_FAILURE_OK, _FAILURE_OFF):
            return mavlink2.MAV_RESULT_UNSUPPORTED
        failed = failure_type == _FAILURE_OFF
        self.fleet.gps_failed[self.index] = failed
        self.commander.status_texts.append(
            (mavlink2.MAV_SEVERITY_WARNING, "Failure injected: GPS off" if failed else "GPS ok")
        )
        return mavlink2.MAV_RESULT_ACCEPTED

    def vision_measurement(
        self,
        time_usec: int,
        position_ned_m: np.ndarray,
        position_var_m2: np.ndarray,
        yaw_rad: float,
        yaw_var_rad2: float,
        velocity_ned_m_s: np.ndarray | None,
    ) -> None:
        """External vision (see VehiclePort.vision_measurement) -> the fleet's estimator."""
        self.fleet.handle_vision(
            self.index,
            time_usec,
            position_ned_m,
            position_var_m2,
            yaw_rad,
            yaw_var_rad2,
            velocity_ned_m_s,
        )

    # -- telemetry ------------------------------------------------------------------------------
    def telemetry(self) -> TelemetrySnapshot:
        """Snapshot of this vehicle's estimate, state and setpoints."""
        return self.fleet.telemetry.snapshot(self.index)
