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

import math
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
_NO_GPS = dict(
    gps_fix_type=0,
    gps_lat_deg=math.nan,
    gps_lon_deg=math.nan,
    gps_alt_amsl_m=math.nan,
    gps_eph_m=math.nan,
    gps_epv_m=math.nan,
    gps_satellites=0,
    gps_velocity_ned_m_s=(0.0, 0.0, 0.0),
)


class FleetTelemetry:
    """Per-vehicle telemetry snapshots of an :class:`~autopilot_emu.fleet.AutopilotFleet`."""

    def __init__(self, fleet: AutopilotFleet) -> None:
        self._fleet = fleet
        self._key: tuple[object, ...] | None = None
        self._rows: list[list[float]] = []
        self._flags: list[tuple[bool, ...]] = []

    def _refresh(self) -> None:
        """Read the fleet's arrays into per-vehicle rows, once per instant of simulation time."""
        f = self._fleet
        key = (f.time_usec, f.last_gps, f.last_sensors, f.terrain_updates)
        if key == self._key:
            return
        est, bat, sp = f.estimator, f.battery, f.setpoint
        remaining = bat.remaining
        self._rows = np.concatenate(
            (
                est.position_ned_m,  # 0:3
                est.velocity_ned_m_s,  # 3:6
                est.q,  # 6:10
                quat.euler_of(est.r),  # 10:13
                est.rates_rad_s,  # 13:16
                sp.position_ned_m,  # 16:19
                f.position_control.vel_sp,  # 19:22
                sp.yaw_rad[:, None],  # 22
                f.q_sp,  # 23:27
                f.rate_sp,  # 27:30
                bat.voltage_v[:, None],  # 30
                bat.current_a[:, None],  # 31
                remaining[:, None],  # 32
                bat.consumed_mah[:, None],  # 33
                est.origin_lla,  # 34:37
                f.metres_per_degree,  # 37:39
                est.first_fix_s[:, None],  # 39
                est.position_variance_m2,  # 40:43
                est.velocity_variance_m2_s2,  # 43:46
                est.vel_ratio[:, None],  # 46
                est.pos_horiz_ratio[:, None],  # 47
                est.pos_vert_ratio[:, None],  # 48
                est.mag_ratio[:, None],  # 49
                f.terrain.terrain_d_m[:, None],  # 50
                f.terrain.valid(est.time_s)[:, None],  # 51
            ),
            axis=1,
        ).tolist()
        self._flags = list(
            zip(
                est.position_ok.tolist(),
                est.attitude_ok.tolist(),
                est.origin_set.tolist(),
                est.global_position_ok.tolist(),
                (est.time_s - est.height_aided_s <= est.params.noaid_tout_s).tolist(),
                est.const_pos_mode.tolist(),
                est.gps_glitch.tolist(),
                est.heading_failure.tolist(),
                strict=True,
            )
        )
        self._key = key

    def snapshot(self, i: int) -> TelemetrySnapshot:
        """Vehicle i's estimate, state and setpoints now."""
        self._refresh()
        f = self._fleet
        cmd = f.commanders[i]
        row = self._rows[i]
        pos_ok, att_ok, origin_ok, global_ok, height_ok, const_pos, glitch, hdg_fail = self._flags[
            i
        ]
        n, e, d = row[0:3]
        o_lat, o_lon, o_alt, m_lat, m_lon = row[34:39]
        if origin_ok:
            lat, lon, alt = o_lat + n / m_lat, o_lon + e / m_lon, o_alt - d
        else:
            lat, lon, alt = _NAN3
        home = None
        rel_alt = 0.0
        if cmd.home is not None and origin_ok:
            hn, he, hd = cmd.home.position_ned_m.tolist()
            home = HomeSnapshot(
                o_lat + hn / m_lat, o_lon + he / m_lon, cmd.home.alt_amsl_m, (hn, he, hd)
            )
            rel_alt = hd - d
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
        present = SENSORS | (_GEOFENCE if cmd.fence_enabled else 0)
        if not cmd.fence_breached:
            health |= _GEOFENCE
        thrust = float(f.thrust[i])
        setpoint = None
        if f.active[i]:
            sp_n, sp_e, sp_d = row[16:19]
            setpoint = SetpointSnapshot(
                position_ned_m=(sp_n, sp_e, sp_d),
                velocity_ned_m_s=tuple(row[19:22]),
                acceleration_ned_m_s2=_NAN3,
                yaw_rad=row[22],
                yaw_rate_rad_s=math.nan,
                global_position=(
                    o_lat + sp_n / m_lat if origin_ok else math.nan,
                    o_lon + sp_e / m_lon if origin_ok else math.nan,
                    o_alt - sp_d if origin_ok else math.nan,
                ),
                attitude_wxyz=tuple(row[23:27]),
                body_rates_rad_s=tuple(row[27:30]),
                thrust=thrust,
            )
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
        var_n, var_e, var_d = row[40:43]
        estimator = EstimatorSnapshot(
            flags=flags,
            pos_horiz_accuracy_m=math.sqrt(var_n + var_e),
            pos_vert_accuracy_m=math.sqrt(var_d),
            position_variance_m2=(var_n, var_e, var_d),
            velocity_variance_m2_s2=tuple(row[43:46]),
            origin_lla=(o_lat, o_lon, o_alt) if origin_ok else None,
            origin_time_usec=round(row[39] * 1e6) if origin_ok else 0,
            vel_ratio=row[46],
            pos_horiz_ratio=row[47],
            pos_vert_ratio=row[48],
            mag_ratio=row[49],
        )
        gps = f.last_gps[i]
        gps_fields = _NO_GPS if gps is None else _gps_fields(gps)
        extra = {}
        if row[51]:  # terrain valid: PX4's ALTITUDE fills terrain altitude and bottom clearance
            extra["bottom_clearance_m"] = row[50] - d
            if origin_ok:
                extra["altitude_terrain_m"] = o_alt - row[50]
        return TelemetrySnapshot(
            time_usec=f.time_usec,
            armed=cmd.armed,
            main_mode=int(cmd.main_mode),
            sub_mode=int(cmd.sub_mode),
            landed_state=int(cmd.landed_state),
            system_status=4 if cmd.armed else 3,
            sensors_present=present,
            sensors_health=health,
            lat_deg=lat,
            lon_deg=lon,
            alt_amsl_m=alt,
            relative_alt_m=rel_alt,
            position_ned_m=(n, e, d),
            velocity_ned_m_s=tuple(row[3:6]),
            quaternion_wxyz=tuple(row[6:10]),
            euler_rad=tuple(row[10:13]),
            body_rates_rad_s=tuple(row[13:16]),
            throttle=thrust,
            battery_voltage_v=row[30],
            battery_current_a=row[31],
            battery_remaining_pct=round(100 * row[32]) if math.isfinite(row[32]) else -1,
            battery_consumed_mah=row[33],
            home=home,
            setpoint=setpoint,
            imu=_imu_sample(f.last_sensors, i),
            estimator=estimator,
            distance_sensors=f.rangefinders.readings(i),
            extra=extra,
            **gps_fields,
        )


def _gps_fields(gps: mavlink2.MAVLink_hil_gps_message) -> dict[str, object]:
    """GPS_RAW_INT fields of the snapshot from the last HIL_GPS sample (SI units)."""
    return dict(
        gps_fix_type=int(gps.fix_type),
        gps_lat_deg=gps.lat * 1e-7,
        gps_lon_deg=gps.lon * 1e-7,
        gps_alt_amsl_m=gps.alt * 1e-3,
        gps_eph_m=gps.eph * 0.01,
        gps_epv_m=gps.epv * 0.01,
        gps_satellites=int(gps.satellites_visible),
        gps_velocity_ned_m_s=(gps.vn * 0.01, gps.ve * 0.01, gps.vd * 0.01),
    )


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
