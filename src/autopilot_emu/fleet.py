"""The flight stacks of N vehicles, advanced together from HIL sensor messages.

Inputs and outputs are the PX4 simulator messages (pymavlink objects): HIL_SENSOR at the IMU
rate, HIL_GPS at the GPS rate and BATTERY_STATUS (the power module's voltage and current) in,
HIL_ACTUATOR_CONTROLS out, one per vehicle. Whether they come
from PyBullet in memory or from a socket makes no difference here. Each IMU sample runs estimator
prediction and the inner control loop (attitude, rate control, mixer) for the whole fleet;
navigation (commanders, hover-thrust estimator, trajectory and position control) runs at
``nav_hz``. Each control loop of :mod:`autopilot_emu.control` owns its state and gains; the
fleet wires their inputs and outputs.
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
from autopilot_emu.control.hover_thrust import HoverThrustLoop, HoverThrustParams
from autopilot_emu.control.inner_loop import InnerLoop
from autopilot_emu.control.mixer import MAX_ROTORS
from autopilot_emu.control.nav import NavGains, NavLoop, PositionSetpoint
from autopilot_emu.control.trajectory import load_hold_point_kernel
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
from autopilot_emu.params import ParamStore
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
        self.nav_loop = NavLoop(n, NavGains.from_params(self.params))
        """Trajectory smoothing and position control, at ``nav_hz``."""
        self.hover_thrust_loop = HoverThrustLoop(n)
        """PX4's mc_hover_thrust_estimator, at ``nav_hz`` (parameters set at the first message)."""
        self.inner_loop = InnerLoop.from_params(self.params, config.imu_hz)
        """Attitude, rate control and mixer, at each IMU sample."""
        self._smooth = np.zeros(n, dtype=bool)
        """Vehicles whose commander asks for a smoothed target (auto modes)."""
        for i, cmd in enumerate(self.commanders):
            cmd.trajectory_state = functools.partial(self.nav_loop.trajectory_state, i)
        load_hold_point_kernel()  # not at the first Hold, mid-flight
        self.battery = FleetBattery(n)
        self.time_usec = 0
        self.active = np.zeros(n, dtype=bool)
        self.armed = np.zeros(n, dtype=bool)
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
        self._param_versions: list[int] | None = None
        """ParamStore versions the loops' gains were read at (None: not yet)."""
        self._controls_tail = [0.0] * (16 - MAX_ROTORS)
        """HIL_ACTUATOR_CONTROLS entries after the motor outputs (always 0)."""
        self._pressure_alt_m = np.zeros(n)
        self.metres_per_degree = np.ones((n, 2))
        """Local projection scale of each vehicle's EKF origin (lat, lon), m/deg."""
        self._att_target_q = np.full((n, 4), np.nan)
        """Offboard attitude setpoints (NaN rows: none)."""
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

        self._refresh_params()
        self._nav_accum_s += dt
        if self._nav_accum_s >= self._nav_period_s - 1e-9:
            est.update_acceleration(self._nav_accum_s)
            self._update_hover_thrust(self._nav_accum_s)
            self._navigate(self._nav_accum_s)
            self._nav_accum_s = 0.0
        self.inner_loop.step(
            q=est.q,
            rates_rad_s=est.rates_rad_s,
            q_sp=self.nav_loop.state.q_sp,
            thrust=self.nav_loop.state.thrust,
            overridden=self.nav_loop.state.overridden,
            rate_target_rad_s=self._rate_target,
            dt_s=dt,
            active=self.active,
            armed=self.armed,
        )
        return self._actuator_messages(t_usec)

    def handle_battery(self, msgs: list[mavlink2.MAVLink_battery_status_message]) -> None:
        """Consume one BATTERY_STATUS per vehicle (pack voltage and current, as a power module).

        The pack voltage is the sum of the valid cell entries (a power module reports it whole
        in cell 0); a current of -1 is unknown.
        """
        self._refresh_params()
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
        self._refresh_params()
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
    def _navigate(self, dt: float) -> None:
        est = self.estimator
        pos, vel = est.position_ned_m, est.velocity_ned_m_s
        yaw = quat.yaw_of(est.r).tolist()
        ok = est.position_ok.tolist()
        origin = est.origin_lla.tolist()
        origin_set = est.origin_set.tolist()
        thrust = self.nav_loop.state.thrust.tolist()
        remaining = self.battery.remaining.tolist()
        # The commander gets the learned hover thrust only (NaN until the estimator is valid):
        # its land detector must not judge "low thrust" against the MPC_THR_HOVER guess.
        hts = self.hover_thrust_loop.state
        hover = np.where(hts.learned, hts.in_use, np.nan).tolist()
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
        self.nav_loop.step(
            setpoint=sp,
            smooth=self._smooth,
            hover_thrust=self.hover_thrust_loop.state.in_use,
            position_ned_m=pos,
            velocity_ned_m_s=vel,
            dt_s=dt,
            active=self.active,
            attitude_target=self._att_target_q,
            thrust_target=self._att_target_thrust,
            rate_integral=self.inner_loop.state.rate_integral,
            heading_rad=np.asarray(yaw),
        )

    def _update_hover_thrust(self, dt: float) -> None:
        """Fuse one sample into the hover-thrust estimators; hand the result to the controller.

        Inputs are the autopilot's own: the estimated vertical acceleration and the upward part
        of the last collective thrust command (see :mod:`autopilot_emu.control.hover_thrust`).
        """
        est = self.estimator
        flying = np.array(
            [c.in_air and c.landed_state != LandedState.TAKEOFF for c in self.commanders]
        )
        self.hover_thrust_loop.step(
            flying=flying,
            armed=self.armed,
            accel_ned_m_s2=est.accel_ned_m_s2,
            thrust=self.nav_loop.state.thrust,
            rotation=est.r,
            velocity_ned_m_s=est.velocity_ned_m_s,
            dt_s=dt,
            velocity_integral=self.nav_loop.state.velocity_integral,
        )

    def _actuator_messages(
        self, t_usec: int
    ) -> list[mavlink2.MAVLink_hil_actuator_controls_message]:
        build = mavlink2.MAVLink_hil_actuator_controls_message
        # float32, as HIL_ACTUATOR_CONTROLS carries them: in memory or packed, the same numbers.
        outputs = self.inner_loop.state.outputs.astype(np.float32).tolist()
        armed, tail = self.armed.tolist(), self._controls_tail
        return [
            build(t_usec, outputs[i] + tail, _MODE_ARMED if armed[i] else _MODE_DISARMED, 0)
            for i in range(self.n)
        ]

    def _refresh_params(self) -> None:
        """Re-read every part's parameters when a vehicle's ParamStore changed."""
        versions = list(map(_VERSION, self.params))
        if versions == self._param_versions:
            return
        self._param_versions = versions
        params, est = self.params, self.estimator
        est.set_params(params)
        self.nav_loop.gains = NavGains.from_params(params)
        est.set_declination(
            magnetic_declination.declinations_deg(params, est.origin_lla, est.origin_set)
        )
        self.battery.set_params(BatteryParams.from_params(params))
        self.terrain_params = TerrainParams.from_params(params)
        self.hover_thrust_loop.set_params(HoverThrustParams.from_params(params))
        self.inner_loop.set_params(params)

    @property
    def setpoint(self) -> PositionSetpoint:
        """What the position controller tracks, (N, ...) arrays (NaN position: not controlled)."""
        return self._sp

    @property
    def velocity_sp(self) -> np.ndarray:
        """Velocity setpoints of the position controller, (N, 3) m/s NED."""
        return self.nav_loop.state.velocity_sp_m_s

    @property
    def q_sp(self) -> np.ndarray:
        """Attitude setpoints, (N, 4) wxyz."""
        return self.nav_loop.state.q_sp

    @property
    def thrust(self) -> np.ndarray:
        """Collective thrust setpoints, (N,) 0..1."""
        return self.nav_loop.state.thrust

    @property
    def rate_sp(self) -> np.ndarray:
        """Body-rate setpoints of the attitude loop (or offboard), (N, 3) rad/s."""
        return self.inner_loop.state.rate_sp_rad_s

    @property
    def outputs(self) -> np.ndarray:
        """Motor outputs 0..1 in PX4's output order, (N, MAX_ROTORS); unused outputs 0."""
        return self.inner_loop.state.outputs

    @property
    def hover_thrust(self) -> np.ndarray:
        """Hover thrust the position controller uses, (N,) 0..1 (see ``HoverThrustState``)."""
        return self.hover_thrust_loop.state.in_use

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
            self.inner_loop.state.outputs[i] = 0.0
            self.nav_loop.state.thrust[i] = 0.0

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
