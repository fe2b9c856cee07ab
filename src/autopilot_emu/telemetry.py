"""Telemetry snapshots of a fleet's vehicles, read from the fleet's arrays in one pass.

Every MAVLink link of every vehicle asks for a snapshot when one of its streams is due, and the
streams of all vehicles fall due at the same instants of simulation time. So the estimator,
controller and battery arrays are read once per instant for the whole fleet (a few numpy calls
and one ``tolist``) and each vehicle's snapshot is assembled from its row of plain floats: N
vehicles cost one vectorised read, not N. What commands change at once (armed, mode, home,
thrust) is read live, never from the cached rows.

Units and frames as :mod:`autopilot_emu.mavlink.vehicle_port`: SI, NED, body FRD, AMSL.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu import quaternion as quat
from autopilot_emu.mavlink.vehicle_port import (
    EstimatorSnapshot,
    HomeSnapshot,
    ImuSample,
    SetpointSnapshot,
    TelemetrySnapshot,
)

if TYPE_CHECKING:
    from autopilot_emu.commander import Commander
    from autopilot_emu.fleet import AutopilotFleet

SENSORS = (
    mavlink2.MAV_SYS_STATUS_SENSOR_3D_GYRO
    | mavlink2.MAV_SYS_STATUS_SENSOR_3D_ACCEL
    | mavlink2.MAV_SYS_STATUS_SENSOR_3D_MAG
    | mavlink2.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
    | mavlink2.MAV_SYS_STATUS_SENSOR_GPS
    | mavlink2.MAV_SYS_STATUS_AHRS
    | mavlink2.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
    | mavlink2.MAV_SYS_STATUS_SENSOR_BATTERY
    | mavlink2.MAV_SYS_STATUS_PREARM_CHECK
)
"""SYS_STATUS sensors the emulated vehicle has (present, enabled, healthy when all is well)."""
_NOT_READY = mavlink2.MAV_SYS_STATUS_SENSOR_GPS | mavlink2.MAV_SYS_STATUS_PREARM_CHECK
_GEOFENCE = mavlink2.MAV_SYS_STATUS_GEOFENCE
_LOCAL_FLAGS = (
    mavlink2.ESTIMATOR_VELOCITY_HORIZ
    | mavlink2.ESTIMATOR_VELOCITY_VERT
    | mavlink2.ESTIMATOR_POS_HORIZ_REL
    | mavlink2.ESTIMATOR_PRED_POS_HORIZ_REL
)
"""ESTIMATOR_STATUS flags of a valid local position (GNSS- or vision-aided)."""
_GLOBAL_FLAGS = mavlink2.ESTIMATOR_POS_HORIZ_ABS | mavlink2.ESTIMATOR_PRED_POS_HORIZ_ABS
"""Added when the position is also global (GNSS-aided, with an origin)."""
_NAN3 = (math.nan, math.nan, math.nan)


class FleetTelemetry:
    """Per-vehicle telemetry snapshots of an :class:`~autopilot_emu.fleet.AutopilotFleet`.

    The fleet's arrays are read in groups (motion, geodetic origin, estimator health,
    setpoints, battery, terrain), each once per instant for the whole fleet and only when a
    field of the group is first asked for: a poll whose due streams are all attitude and
    position reads the motion arrays alone.
    """

    def __init__(self, fleet: AutopilotFleet) -> None:
        self._fleet = fleet
        self._key: tuple[object, ...] | None = None
        self._motion: list[list[float]] | None = None
        self._origin: list[list[float]] | None = None
        self._origin_set: list[bool] | None = None
        self._health: list[tuple[bool, ...]] | None = None
        self._estimator: list[list[float]] | None = None
        self._setpoints: list[list[float]] | None = None
        self._battery: list[list[float]] | None = None
        self._terrain: list[list[float]] | None = None

    def _sync(self) -> None:
        """Forget the rows read at an earlier instant of simulation time."""
        f = self._fleet
        key = (f.time_usec, f.last_gps, f.last_sensors, f.terrain_updates)
        if key != self._key:
            self._key = key
            self._motion = self._origin = self._origin_set = self._health = None
            self._estimator = self._setpoints = self._battery = self._terrain = None

    # --- fleet-wide reads, once per instant and group ------------------------------------------

    def _motion_rows(self) -> list[list[float]]:
        """Position 0:3, velocity 3:6, quaternion 6:10, Euler angles 10:13, body rates 13:16."""
        rows = self._motion
        if rows is None:
            est = self._fleet.estimator
            rows = self._motion = np.concatenate(
                (
                    est.position_ned_m,
                    est.velocity_ned_m_s,
                    est.q,
                    quat.euler_of(est.r),
                    est.rates_rad_s,
                ),
                axis=1,
            ).tolist()
        return rows

    def _origin_rows(self) -> tuple[list[list[float]], list[bool]]:
        """EKF origin lat, lon, alt 0:3 and metres per degree 3:5; whether the origin is set."""
        rows = self._origin
        if rows is None:
            f = self._fleet
            est = f.estimator
            rows = self._origin = np.concatenate(
                (est.origin_lla, f.metres_per_degree), axis=1
            ).tolist()
            self._origin_set = est.origin_set.tolist()
        return rows, self._origin_set  # type: ignore[return-value]

    def _health_rows(self) -> list[tuple[bool, ...]]:
        """Estimator flags per vehicle.

        Position, attitude, global position, height aided, constant-position mode, GPS glitch,
        heading failure.
        """
        rows = self._health
        if rows is None:
            est = self._fleet.estimator
            local_ok, global_ok = est.position_validity()
            rows = self._health = list(
                zip(
                    local_ok.tolist(),
                    est.attitude_ok.tolist(),
                    global_ok.tolist(),
                    (est.time_s - est.height_aided_s <= est.params.noaid_tout_s).tolist(),
                    est.const_pos_mode.tolist(),
                    est.gps_glitch.tolist(),
                    est.heading_failure.tolist(),
                    strict=True,
                )
            )
        return rows

    def _estimator_rows(self) -> list[list[float]]:
        """First fix 0, position variance 1:4, velocity variance 4:7, test ratios 7:11."""
        rows = self._estimator
        if rows is None:
            est = self._fleet.estimator
            rows = self._estimator = np.concatenate(
                (
                    est.first_fix_s[:, None],
                    est.position_variance_m2,
                    est.velocity_variance_m2_s2,
                    est.vel_ratio[:, None],
                    est.pos_horiz_ratio[:, None],
                    est.pos_vert_ratio[:, None],
                    est.mag_ratio[:, None],
                ),
                axis=1,
            ).tolist()
        return rows

    def _setpoint_rows(self) -> list[list[float]]:
        """Position 0:3, velocity 3:6, yaw 6, attitude 7:11, body rates 11:14."""
        rows = self._setpoints
        if rows is None:
            f = self._fleet
            rows = self._setpoints = np.concatenate(
                (
                    f.setpoint.position_ned_m,
                    f.velocity_sp,
                    f.setpoint.yaw_rad[:, None],
                    f.q_sp,
                    f.rate_sp,
                ),
                axis=1,
            ).tolist()
        return rows

    def _battery_rows(self) -> list[list[float]]:
        """Voltage 0, current 1, remaining fraction 2, consumed charge 3."""
        rows = self._battery
        if rows is None:
            bat = self._fleet.battery
            rows = self._battery = np.stack(
                (bat.voltage_v, bat.current_a, bat.remaining, bat.consumed_mah), axis=1
            ).tolist()
        return rows

    def _terrain_rows(self) -> list[list[float]]:
        """Terrain down position 0, estimate valid 1 (1.0 / 0.0)."""
        rows = self._terrain
        if rows is None:
            f = self._fleet
            terrain = f.terrain
            rows = self._terrain = np.stack(
                (terrain.terrain_d_m, terrain.valid(f.estimator.time_s)), axis=1
            ).tolist()
        return rows

    # --- snapshots ---------------------------------------------------------------------------

    def snapshot(self, i: int) -> TelemetrySnapshot:
        """Vehicle i's estimate, state and setpoints now, every field read at once."""
        lazy = self.lazy_snapshot(i)
        return TelemetrySnapshot(**{name: getattr(lazy, name) for name in _FIELD_NAMES})

    def lazy_snapshot(self, i: int) -> TelemetrySnapshot:
        """Vehicle i's snapshot whose groups of fields are read when first accessed.

        For a reader that uses it at once (the MAVLink links within one poll): what
        commands change (armed, modes, thrust) and the motion (position, velocity, attitude,
        rates) are read now, the rest on first access, from the fleet's state at that moment.
        """
        self._sync()
        f = self._fleet
        cmd = f.commanders[i]
        snap = _LazySnapshot.__new__(_LazySnapshot)
        snap._telemetry = self
        snap._index = i
        armed = cmd.armed
        snap.time_usec = f.time_usec
        snap.armed = armed
        snap.main_mode = int(cmd.main_mode)
        snap.sub_mode = int(cmd.sub_mode)
        snap.landed_state = int(cmd.landed_state)
        snap.system_status = system_status(cmd)
        snap.throttle = float(f.thrust[i])
        snap.takeoff_alt_amsl_m = math.nan
        snap.distance_sensors = f.rangefinders.readings(i)
        self._fill_motion(snap)  # what nearly every poll's streams need (ATTITUDE at 100 Hz)
        return snap

    # --- per-vehicle groups of a lazy snapshot -------------------------------------------------

    def _fill_motion(self, s: _LazySnapshot) -> None:
        self._sync()
        row = self._motion_rows()[s._index]
        s.position_ned_m = (row[0], row[1], row[2])
        s.velocity_ned_m_s = (row[3], row[4], row[5])
        s.quaternion_wxyz = (row[6], row[7], row[8], row[9])
        s.euler_rad = (row[10], row[11], row[12])
        s.body_rates_rad_s = (row[13], row[14], row[15])

    def _fill_geodetic(self, s: _LazySnapshot) -> None:
        self._sync()
        i = s._index
        rows, origin_set = self._origin_rows()
        o_lat, o_lon, o_alt, m_lat, m_lon = rows[i]
        n, e, d = s.position_ned_m
        origin_ok = origin_set[i]
        if origin_ok:
            s.lat_deg, s.lon_deg, s.alt_amsl_m = o_lat + n / m_lat, o_lon + e / m_lon, o_alt - d
        else:
            s.lat_deg, s.lon_deg, s.alt_amsl_m = _NAN3
        home = self._fleet.commanders[i].home
        if home is not None and origin_ok:
            hn, he, hd = home.position_ned_m.tolist()
            s.home = HomeSnapshot(
                o_lat + hn / m_lat, o_lon + he / m_lon, home.alt_amsl_m, (hn, he, hd)
            )
            s.relative_alt_m = hd - d
        else:
            s.home = None
            s.relative_alt_m = 0.0

    def _fill_health(self, s: _LazySnapshot) -> None:
        self._sync()
        i = s._index
        cmd = self._fleet.commanders[i]
        pos_ok, att_ok, global_ok, height_ok, const_pos, glitch, hdg_fail = self._health_rows()[i]
        health = SENSORS
        if not pos_ok:
            health &= ~_NOT_READY
        if not global_ok:
            health &= ~mavlink2.MAV_SYS_STATUS_SENSOR_GPS
        if not att_ok:
            health &= ~mavlink2.MAV_SYS_STATUS_AHRS
        if hdg_fail:  # the magnetometer fails its innovation gate: mag and prearm unhealthy
            health &= ~(
                mavlink2.MAV_SYS_STATUS_SENSOR_3D_MAG | mavlink2.MAV_SYS_STATUS_PREARM_CHECK
            )
        # Geofence as MAVProxy reads it: healthy unless breached; present only when configured.
        s.sensors_present = SENSORS | (_GEOFENCE if cmd.fence_enabled else 0)
        if not cmd.fence_breached:
            health |= _GEOFENCE
        s.sensors_health = health
        flags = 0
        if att_ok:
            flags |= mavlink2.ESTIMATOR_ATTITUDE
            if pos_ok:
                flags |= _LOCAL_FLAGS | (_GLOBAL_FLAGS if global_ok else 0)
            if height_ok:
                flags |= mavlink2.ESTIMATOR_POS_VERT_ABS
            if const_pos:
                flags |= mavlink2.ESTIMATOR_CONST_POS_MODE
        if glitch:
            flags |= mavlink2.ESTIMATOR_GPS_GLITCH
        rows, origin_set = self._origin_rows()
        origin_ok = origin_set[i]
        o_lat, o_lon, o_alt = rows[i][0:3]
        row = self._estimator_rows()[i]
        var_n, var_e, var_d = row[1:4]
        s.estimator = EstimatorSnapshot(
            flags=flags,
            pos_horiz_accuracy_m=_std(var_n + var_e),
            pos_vert_accuracy_m=_std(var_d),
            position_variance_m2=(var_n, var_e, var_d),
            velocity_variance_m2_s2=(row[4], row[5], row[6]),
            origin_lla=(o_lat, o_lon, o_alt) if origin_ok else None,
            origin_time_usec=round(row[0] * 1e6) if origin_ok else 0,
            vel_ratio=row[7],
            pos_horiz_ratio=row[8],
            pos_vert_ratio=row[9],
            mag_ratio=row[10],
        )

    def _fill_setpoint(self, s: _LazySnapshot) -> None:
        self._sync()
        i = s._index
        if not self._fleet.active[i]:
            s.setpoint = None
            return
        row = self._setpoint_rows()[i]
        rows, origin_set = self._origin_rows()
        o_lat, o_lon, o_alt, m_lat, m_lon = rows[i]
        origin_ok = origin_set[i]
        sp_n, sp_e, sp_d = row[0:3]
        s.setpoint = SetpointSnapshot(
            position_ned_m=(sp_n, sp_e, sp_d),
            velocity_ned_m_s=(row[3], row[4], row[5]),
            acceleration_ned_m_s2=_NAN3,
            yaw_rad=row[6],
            yaw_rate_rad_s=math.nan,
            global_position=(
                o_lat + sp_n / m_lat if origin_ok else math.nan,
                o_lon + sp_e / m_lon if origin_ok else math.nan,
                o_alt - sp_d if origin_ok else math.nan,
            ),
            attitude_wxyz=(row[7], row[8], row[9], row[10]),
            body_rates_rad_s=(row[11], row[12], row[13]),
            thrust=s.throttle,
        )

    def _fill_battery(self, s: _LazySnapshot) -> None:
        self._sync()
        voltage, current, remaining, consumed = self._battery_rows()[s._index]
        s.battery_voltage_v = voltage
        s.battery_current_a = current
        s.battery_remaining_pct = round(100 * remaining) if math.isfinite(remaining) else -1
        s.battery_consumed_mah = consumed

    def _fill_gps(self, s: _LazySnapshot) -> None:
        gps = self._fleet.last_gps[s._index]
        if gps is None:
            s.gps_fix_type = 0
            s.gps_lat_deg = s.gps_lon_deg = s.gps_alt_amsl_m = math.nan
            s.gps_eph_m = s.gps_epv_m = math.nan
            s.gps_satellites = 0
            s.gps_velocity_ned_m_s = (0.0, 0.0, 0.0)
            return
        s.gps_fix_type = int(gps.fix_type)
        s.gps_lat_deg = gps.lat * 1e-7
        s.gps_lon_deg = gps.lon * 1e-7
        s.gps_alt_amsl_m = gps.alt * 1e-3
        s.gps_eph_m = gps.eph * 0.01
        s.gps_epv_m = gps.epv * 0.01
        s.gps_satellites = int(gps.satellites_visible)
        s.gps_velocity_ned_m_s = (gps.vn * 0.01, gps.ve * 0.01, gps.vd * 0.01)

    def _fill_imu(self, s: _LazySnapshot) -> None:
        s.imu = _imu_sample(self._fleet.last_sensors, s._index)

    def _fill_extra(self, s: _LazySnapshot) -> None:
        self._sync()
        i = s._index
        terrain_d, valid = self._terrain_rows()[i]
        extra: dict[str, float] = {}
        if valid:  # terrain valid: PX4's ALTITUDE fills terrain altitude and bottom clearance
            extra["bottom_clearance_m"] = terrain_d - s.position_ned_m[2]
            rows, origin_set = self._origin_rows()
            if origin_set[i]:
                extra["altitude_terrain_m"] = rows[i][2] - terrain_d
        s.extra = extra


class _LazySnapshot(TelemetrySnapshot):
    """A :class:`TelemetrySnapshot` whose groups of fields are read on first access.

    Its unread fields are empty slots: reading one falls through to :meth:`__getattr__`,
    which fills the field's whole group from the fleet's rows; later reads are plain slot
    reads.
    """

    __slots__ = ("_index", "_telemetry")

    def __getattr__(self, name: str) -> object:
        fill = _FILLER_OF.get(name)
        if fill is None:
            raise AttributeError(name)
        fill(object.__getattribute__(self, "_telemetry"), self)
        return object.__getattribute__(self, name)


_GROUPS: dict[Callable[[FleetTelemetry, _LazySnapshot], None], tuple[str, ...]] = {
    FleetTelemetry._fill_motion: (
        "position_ned_m",
        "velocity_ned_m_s",
        "quaternion_wxyz",
        "euler_rad",
        "body_rates_rad_s",
    ),
    FleetTelemetry._fill_geodetic: ("lat_deg", "lon_deg", "alt_amsl_m", "relative_alt_m", "home"),
    FleetTelemetry._fill_health: ("sensors_present", "sensors_health", "estimator"),
    FleetTelemetry._fill_setpoint: ("setpoint",),
    FleetTelemetry._fill_battery: (
        "battery_voltage_v",
        "battery_current_a",
        "battery_remaining_pct",
        "battery_consumed_mah",
    ),
    FleetTelemetry._fill_gps: (
        "gps_fix_type",
        "gps_lat_deg",
        "gps_lon_deg",
        "gps_alt_amsl_m",
        "gps_eph_m",
        "gps_epv_m",
        "gps_satellites",
        "gps_velocity_ned_m_s",
    ),
    FleetTelemetry._fill_imu: ("imu",),
    FleetTelemetry._fill_extra: ("extra",),
}
"""Which fields of a snapshot each group read fills."""
_FILLER_OF = {name: fill for fill, names in _GROUPS.items() for name in names}
_FIELD_NAMES = tuple(field.name for field in dataclasses.fields(TelemetrySnapshot))


def system_status(commander: Commander) -> int:
    """HEARTBEAT's MAV_STATE as PX4 sends it.

    ACTIVE armed, STANDBY disarmed; FLIGHT_TERMINATION after a flight termination (PX4's
    HEARTBEAT stream lets termination override the arming state).
    """
    if commander.terminated:
        return mavlink2.MAV_STATE_FLIGHT_TERMINATION
    return mavlink2.MAV_STATE_ACTIVE if commander.armed else mavlink2.MAV_STATE_STANDBY


def _imu_sample(
    sensors: list[mavlink2.MAVLink_hil_sensor_message] | None, i: int
) -> ImuSample | None:
    """Vehicle i's last HIL_SENSOR as an IMU sample (same units: m/s², rad/s, gauss, hPa)."""
    if sensors is None:
        return None
    m = sensors[i]
    return ImuSample(
        time_usec=int(m.time_usec),
        accel_m_s2=(m.xacc, m.yacc, m.zacc),
        gyro_rad_s=(m.xgyro, m.ygyro, m.zgyro),
        mag_gauss=(m.xmag, m.ymag, m.zmag),
        abs_pressure_hpa=m.abs_pressure,
        diff_pressure_hpa=m.diff_pressure,
        pressure_alt_m=m.pressure_alt,
        temperature_degc=m.temperature,
        fields_updated=int(m.fields_updated),
    )


def _std(variance: float) -> float:
    """Standard deviation of a variance; NaN for a negative one (as numpy's sqrt), never raises."""
    return math.sqrt(variance) if variance >= 0.0 else math.nan
