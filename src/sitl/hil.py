"""The PX4 simulator messages the simulator sends, and HIL_ACTUATOR_CONTROLS, which it reads.

Out: HIL_SENSOR, HIL_GPS, HIL_STATE_QUATERNION, BATTERY_STATUS and DISTANCE_SENSOR.

Units and frames are MAVLink's: body FRD, m/s^2, rad/s, gauss, hPa, degE7, mm, cm, cm/s, cdeg.
``time_usec`` is simulation time. Messages are built only when a sensor is due.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

from sitl.sensors.baro import BaroSample
from sitl.sensors.gps import GpsSample
from sitl.sensors.rangefinder import MAV_DISTANCE_SENSOR_ULTRASOUND, RangeReadings
from sitl.truth import TruthState

FIELDS_IMU = (
    mavlink2.HIL_SENSOR_UPDATED_XACC
    | mavlink2.HIL_SENSOR_UPDATED_YACC
    | mavlink2.HIL_SENSOR_UPDATED_ZACC
    | mavlink2.HIL_SENSOR_UPDATED_XGYRO
    | mavlink2.HIL_SENSOR_UPDATED_YGYRO
    | mavlink2.HIL_SENSOR_UPDATED_ZGYRO
)
"""HIL_SENSOR fields_updated bits of accelerometer and gyroscope (0x3F)."""
FIELDS_MAG = (
    mavlink2.HIL_SENSOR_UPDATED_XMAG
    | mavlink2.HIL_SENSOR_UPDATED_YMAG
    | mavlink2.HIL_SENSOR_UPDATED_ZMAG
)
"""HIL_SENSOR fields_updated bits of the magnetometer (0x1C0)."""
FIELDS_BARO = (
    mavlink2.HIL_SENSOR_UPDATED_ABS_PRESSURE
    | mavlink2.HIL_SENSOR_UPDATED_PRESSURE_ALT
    | mavlink2.HIL_SENSOR_UPDATED_TEMPERATURE
)
"""HIL_SENSOR fields_updated bits of the barometer (0x1A00)."""

COG_UNKNOWN = 65535
"""HIL_GPS cog when the course is unknown."""
ACCURACY_UNKNOWN = 65535
"""HIL_GPS eph / epv when the accuracy is unknown (no fix)."""
COG_MIN_SPEED_M_S = 0.3
"""Ground speed below which the course over ground is reported unknown, m/s."""

_ARMED = mavlink2.MAV_MODE_FLAG_SAFETY_ARMED


def read_actuator_controls(
    messages: Sequence[mavlink2.MAVLink_hil_actuator_controls_message | None],
    controls_out: np.ndarray,
) -> bool | None:
    """Copy the motor commands of the given messages into ``controls_out`` (N, n_rotors).

    A ``None`` entry leaves that vehicle's row unchanged; a message without the SAFETY_ARMED mode
    flag sets it to zero. Values are copied raw (NaN included): clipping is the caller's.

    Returns:
        None if no row was written, else whether any written value was NaN.
    """
    n_rotors = controls_out.shape[1]
    written = False
    nan_seen = False
    for i, msg in enumerate(messages):
        if msg is None:
            continue
        written = True
        if msg.mode & _ARMED:
            values = msg.controls[:n_rotors]
            total = sum(values)
            nan_seen = nan_seen or total != total  # NaN (or +inf and -inf together)
            controls_out[i] = values
        else:
            controls_out[i] = 0.0
    return nan_seen if written else None


def hil_sensor_messages(
    time_usec: int, imu_mag_frd: np.ndarray, baro: BaroSample, fields_updated: int
) -> list[mavlink2.MAVLink_hil_sensor_message]:
    """One HIL_SENSOR per vehicle.

    The float fields hold float32 values, as the wire carries them: handed over in memory or
    packed for TCP, the autopilot reads the same numbers.

    Args:
        time_usec: simulation time, us.
        imu_mag_frd: ``(N, 9)``, body FRD: specific force (m/s^2), angular rate (rad/s),
            magnetic field (gauss).
        baro: barometer reading (its latest, flagged or not).
        fields_updated: HIL_SENSOR_UPDATED_FLAGS bitmask.
    """
    make = mavlink2.MAVLink_hil_sensor_message
    return [
        make(time_usec, *row, p_hpa, 0.0, alt_m, t_c, fields_updated, 0)
        for row, p_hpa, alt_m, t_c in zip(
            imu_mag_frd.astype(np.float32).tolist(),
            baro.abs_pressure_hpa.astype(np.float32).tolist(),
            baro.pressure_alt_m.astype(np.float32).tolist(),
            baro.temperature_c.astype(np.float32).tolist(),
            strict=True,
        )
    ]


def hil_gps_messages(time_usec: int, fix: GpsSample) -> list[mavlink2.MAVLink_hil_gps_message]:
    """One HIL_GPS per vehicle, sent at ``time_usec`` with the content of ``fix``.

    ``time_usec`` is the send time; the fix was measured at ``fix.time_s`` (earlier by the
    receiver's delay), as a real receiver's message reaches the autopilot after its epoch.
    eph / epv carry the 1-sigma accuracy in cm (as PX4's simulator reads them), 65535 if unknown.
    """
    v = fix.velocity_ned_m_s
    speed = np.hypot(v[:, 0], v[:, 1])
    course_deg = np.degrees(np.arctan2(v[:, 1], v[:, 0])) % 360.0
    scaled = np.column_stack(
        [fix.lat_deg * 1e7, fix.lon_deg * 1e7, fix.alt_amsl_m * 1e3, speed * 100.0, v * 100.0]
    )
    np.clip(scaled[:, 3:], -32767.0, 32767.0, out=scaled[:, 3:])  # uint16 / int16 fields
    ints = np.rint(scaled).astype(np.int64).tolist()
    cogs = np.rint(course_deg * 100.0).astype(np.int64).tolist()
    known = (speed >= COG_MIN_SPEED_M_S).tolist()
    accuracy = np.column_stack((fix.eph_m, fix.epv_m)) * 100.0
    accuracy = np.where(
        np.isfinite(accuracy), np.minimum(accuracy, ACCURACY_UNKNOWN - 1), ACCURACY_UNKNOWN
    )
    acc = np.rint(accuracy).astype(np.int64).tolist()
    make = mavlink2.MAVLink_hil_gps_message
    return [
        make(
            time_usec,
            fix_type,
            lat,
            lon,
            alt,
            eph,
            epv,
            vel,
            vn,
            ve,
            vd,
            cog % 36000 if ok else COG_UNKNOWN,
            sats,
            0,
            0,
        )
        for (lat, lon, alt, vel, vn, ve, vd), cog, ok, (eph, epv), fix_type, sats in zip(
            ints,
            cogs,
            known,
            acc,
            fix.fix_type.tolist(),
            fix.satellites.tolist(),
            strict=True,
        )
    ]


_UINT16_MAX = 65535
_NO_CELLS_EXT = [0, 0, 0, 0]


def battery_status_messages(
    voltage_v: np.ndarray, current_a: np.ndarray
) -> list[mavlink2.MAVLink_battery_status_message]:
    """One BATTERY_STATUS per vehicle as a power module measures it: pack voltage and current.

    Cell voltages are not measured: the whole pack voltage goes in ``voltages[0]`` (mV; above
    65534 mV the rest spills into ``voltages[1]``), the other cells are UINT16_MAX, as MAVLink
    specifies. ``current_battery`` in cA; consumed charge, energy and remaining are unknown (-1):
    estimating them is the autopilot's job.
    """
    mv = np.rint(np.clip(voltage_v, 0.0, 2.0 * (_UINT16_MAX - 1) / 1000.0) * 1000.0)
    ca = np.rint(np.clip(current_a, 0.0, 32767 / 100.0) * 100.0)
    make = mavlink2.MAVLink_battery_status_message
    msgs = []
    for v, c in zip(mv.astype(np.int64).tolist(), ca.astype(np.int64).tolist(), strict=True):
        cells = [_UINT16_MAX] * 10
        cells[0] = min(v, _UINT16_MAX - 1)
        if v > _UINT16_MAX - 1:
            cells[1] = v - (_UINT16_MAX - 1)
        msgs.append(
            make(
                0,
                mavlink2.MAV_BATTERY_FUNCTION_ALL,
                mavlink2.MAV_BATTERY_TYPE_LIPO,
                32767,
                cells,
                c,
                -1,
                -1,
                -1,
                0,
                mavlink2.MAV_BATTERY_CHARGE_STATE_UNDEFINED,
                _NO_CELLS_EXT,
                0,
                0,
            )
        )
    return msgs


SIGNAL_QUALITY_ECHO = 100
"""DISTANCE_SENSOR signal_quality of a reading with an echo (MAVLink: 100 = perfect signal)."""
SIGNAL_QUALITY_NO_ECHO = 1
"""DISTANCE_SENSOR signal_quality without an echo (MAVLink: 1 = invalid signal; 0 = unknown)."""
COVARIANCE_UNKNOWN = 255
"""DISTANCE_SENSOR covariance when unknown (UINT8_MAX), here: no echo."""
_NO_QUATERNION = [0.0, 0.0, 0.0, 0.0]


def distance_sensor_messages(
    readings: RangeReadings, n_vehicles: int
) -> list[list[mavlink2.MAVLink_distance_sensor_message]]:
    """DISTANCE_SENSOR of each reading, as one list per vehicle (vehicle order; may be empty).

    As the PX4 simulator interface carries them (simulator_mavlink.cpp handles DISTANCE_SENSOR
    from the simulator): ``time_boot_ms`` simulation time; distances in cm; ``type`` ULTRASOUND;
    ``id`` and ``orientation`` (MAV_SENSOR_ROTATION) of the mount; ``covariance`` the noise
    variance at the measured range in cm^2 (at most 254); fields of view the full beam angle, rad;
    ``quaternion`` zero (the orientation is not CUSTOM). No echo (nothing in range, or a dropout):
    ``current_distance = max_distance + 1`` cm, outside the valid range so every consumer (PX4's
    EKF2 included) discards it, with ``signal_quality`` 1 (invalid) and covariance unknown (255);
    a reading with an echo has ``signal_quality`` 100.
    """
    out: list[list[mavlink2.MAVLink_distance_sensor_message]] = [[] for _ in range(n_vehicles)]
    time_boot_ms = readings.time_usec // 1000
    make = mavlink2.MAVLink_distance_sensor_message
    distances = readings.distance_m.tolist()
    for i, spec, d in zip(readings.vehicle.tolist(), readings.specs, distances, strict=True):
        min_cm = round(spec.min_range_m * 100.0)
        max_cm = round(spec.max_range_m * 100.0)
        if d == d:  # an echo (not NaN)
            current = min(max(round(d * 100.0), min_cm), max_cm)
            covariance = min(round((spec.noise_sigma_at(d) * 100.0) ** 2), 254)
            quality = SIGNAL_QUALITY_ECHO
        else:
            current, covariance, quality = max_cm + 1, COVARIANCE_UNKNOWN, SIGNAL_QUALITY_NO_ECHO
        fov = spec.fov_rad
        out[i].append(
            make(
                time_boot_ms,
                min_cm,
                max_cm,
                current,
                MAV_DISTANCE_SENSOR_ULTRASOUND,
                spec.id,
                spec.orientation,
                covariance,
                fov,
                fov,
                _NO_QUATERNION,
                quality,
            )
        )
    return out


G_MG = 9.80665 / 1000.0
"""One milli-g, m/s^2 (HIL_STATE_QUATERNION accelerations are in mG)."""


def hil_state_quaternion_messages(
    time_usec: int, truth: TruthState, specific_force_frd_m_s2: np.ndarray
) -> list[mavlink2.MAVLink_hil_state_quaternion_message]:
    """One HIL_STATE_QUATERNION per vehicle: the true state, PX4's ground truth.

    Attitude body FRD -> NED (w, x, y, z); body rates FRD, rad/s; latitude and longitude degE7,
    altitude mm AMSL; velocity NED cm/s; air speeds cm/s (the true air-relative speed in both);
    accelerations the specific force in body FRD, mG (what the accelerometer measures without
    noise is not kept: the latest HIL_SENSOR's is given, ``specific_force_frd_m_s2`` (N, 3)).
    PX4's simulator_mavlink publishes it as ``vehicle_*_groundtruth``; nothing in the flight
    stack reads those topics.
    """
    q = truth.quaternion_ned_frd_wxyz.tolist()
    rates = truth.angular_velocity_body_frd_rad_s.tolist()
    lat = np.rint(truth.lat_deg * 1e7).astype(np.int64).tolist()
    lon = np.rint(truth.lon_deg * 1e7).astype(np.int64).tolist()
    alt = np.rint(truth.alt_amsl_m * 1e3).astype(np.int64).tolist()
    vel = np.clip(np.rint(truth.velocity_ned_m_s * 100.0), -32768, 32767).astype(np.int64)
    air = np.linalg.norm(truth.velocity_enu_m_s - truth.wind_enu_m_s, axis=1)
    air_cms = np.clip(np.rint(air * 100.0), 0, 65535).astype(np.int64).tolist()
    acc = np.clip(np.rint(specific_force_frd_m_s2 / G_MG), -32768, 32767).astype(np.int64)
    make = mavlink2.MAVLink_hil_state_quaternion_message
    return [
        make(
            time_usec,
            q[i],
            *rates[i],
            lat[i],
            lon[i],
            alt[i],
            *vel[i].tolist(),
            air_cms[i],
            air_cms[i],
            *acc[i].tolist(),
        )
        for i in range(len(q))
    ]
