"""Telemetry snapshot -> pymavlink message objects, field by field as PX4 fills them.

Every builder is a pure function ``(snapshot, context) -> message | None`` (None: nothing to
report yet, e.g. HOME_POSITION before a home exists). Builders convert SI values to MAVLink wire
units (degE7, mm, cm/s, cdeg, mV, cA) and clamp them to the field's integer range, so a NaN or an
absurd value in a snapshot never makes packing fail. Field semantics follow MAVSDK_CONTRACT.md
sections 1, 2 and 6.
"""

from __future__ import annotations

import functools
import importlib.metadata
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink.vehicle_port import TelemetrySnapshot
from autopilot_emu.params import ParamStore

MAV_AUTOPILOT = mavlink2.MAV_AUTOPILOT_PX4
"""HEARTBEAT.autopilot: selects PX4 mode decoding and bytewise params in MAVSDK/QGC."""

CAPABILITIES = (
    mavlink2.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
    | mavlink2.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
    | mavlink2.MAV_PROTOCOL_CAPABILITY_MISSION_INT
    | mavlink2.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
    | mavlink2.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE
    | mavlink2.MAV_PROTOCOL_CAPABILITY_SET_ATTITUDE_TARGET
    | mavlink2.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
    | mavlink2.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
    | mavlink2.MAV_PROTOCOL_CAPABILITY_FLIGHT_TERMINATION
    | mavlink2.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    | mavlink2.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
    | mavlink2.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY
)
"""AUTOPILOT_VERSION.capabilities as PX4 advertises them (59871); MISSION_INT is essential."""

FIRMWARE_VERSION = (1, 15, 0)
"""PX4 release the emulator behaves like (major, minor, patch)."""
_FIRMWARE_TYPE_RELEASE = 0xFF
_UID_PREFIX = 0x5357_524D_0000_0000
"""AUTOPILOT_VERSION.uid = this prefix ("SWRM") | sysid: stable and distinct per vehicle."""

_MANUAL_INPUT = mavlink2.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
_STABILIZE = mavlink2.MAV_MODE_FLAG_STABILIZE_ENABLED
_GUIDED = mavlink2.MAV_MODE_FLAG_GUIDED_ENABLED
_AUTO = mavlink2.MAV_MODE_FLAG_AUTO_ENABLED
_MODE_FLAGS_BY_MAIN_MODE = {
    1: _MANUAL_INPUT | _STABILIZE,  # MANUAL (a multicopter's manual mode is self-levelling)
    2: _MANUAL_INPUT | _STABILIZE,  # ALTCTL
    3: _MANUAL_INPUT | _STABILIZE | _GUIDED,  # POSCTL
    4: _AUTO | _STABILIZE | _GUIDED,  # AUTO
    5: _MANUAL_INPUT,  # ACRO
    6: _AUTO | _STABILIZE | _GUIDED,  # OFFBOARD
    7: _MANUAL_INPUT | _STABILIZE,  # STABILIZED
    8: _MANUAL_INPUT | _STABILIZE,  # RATTITUDE
}
"""HEARTBEAT.base_mode flags PX4 adds for each main mode (besides CUSTOM_MODE_ENABLED)."""

UINT16_MAX = 0xFFFF
INT16_MAX = 0x7FFF
STATUSTEXT_CHUNK_LEN = 50
"""STATUSTEXT.text capacity, bytes."""
_MAX_CELLS_IN_VOLTAGES = 10
_MAX_CELLS = 14


@dataclass(frozen=True)
class MessageContext:
    """What builders need besides the snapshot."""

    sysid: int
    """Our MAVLink system id."""
    params: ParamStore
    """The vehicle's parameters (battery cell count and warning thresholds)."""
    epoch_start_us: int
    """Unix time at simulation t = 0, microseconds (SYSTEM_TIME)."""
    ftp: bool = False
    """MAVLink FTP is served (AUTOPILOT_VERSION advertises MAV_PROTOCOL_CAPABILITY_FTP)."""


Message = mavlink2.MAVLink_message
Builder = Callable[[TelemetrySnapshot, MessageContext], Message | None]
FieldsBuilder = Callable[[TelemetrySnapshot, MessageContext], tuple | None]
"""A builder of a message's field values, flat (arrays element by element) in wire order:
what the payload ``Struct`` packs, without a pymavlink object (the hot streams)."""


def custom_mode(main_mode: int, sub_mode: int) -> int:
    """PX4 HEARTBEAT.custom_mode: main mode in byte 2, sub mode in byte 3."""
    return ((main_mode & 0xFF) << 16) | ((sub_mode & 0xFF) << 24)


def base_mode(armed: bool, main_mode: int) -> int:
    """PX4 HEARTBEAT.base_mode: CUSTOM_MODE_ENABLED, the mode's flags, SAFETY_ARMED if armed."""
    flags = mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | _MODE_FLAGS_BY_MAIN_MODE.get(main_mode, 0)
    if armed:
        flags |= mavlink2.MAV_MODE_FLAG_SAFETY_ARMED
    return flags


def flight_sw_version(major: int, minor: int, patch: int, release_type: int = 0xFF) -> int:
    """PX4 packing of AUTOPILOT_VERSION.flight_sw_version (type 0xFF = release)."""
    return (major << 24) | (minor << 16) | (patch << 8) | release_type


@functools.cache
def _flight_custom_version() -> tuple[int, ...]:
    """AUTOPILOT_VERSION.flight_custom_version: vendor version in bytes 0-2, no git hash.

    MAVSDK reads bytes 2, 1, 0 as the vendor major, minor, patch and bytes 3-7 as a git hash;
    the vendor version reported is that of swarmsitl.
    """
    try:
        release = importlib.metadata.version("swarmsitl")
    except importlib.metadata.PackageNotFoundError:
        release = "0.0.0"
    numbers = [int(part) if part.isdigit() else 0 for part in release.split(".")[:3]]
    major, minor, patch = [*numbers, 0, 0, 0][:3]
    return (patch & 0xFF, minor & 0xFF, major & 0xFF, 0, 0, 0, 0, 0)


def _scaled(value: float, scale: float, low: int, high: int, unknown: int) -> int:
    """round(value * scale) clamped to [low, high]; ``unknown`` for NaN or infinity."""
    value = float(value)
    if value - value != 0.0:  # NaN or infinite (math.isfinite without the call)
        return unknown
    scaled = round(value * scale)
    return high if scaled > high else (low if scaled < low else scaled)


def _degrees_cdeg(angle_rad: float) -> int:
    """Angle -> 0..35999 centidegrees; 65535 (unknown) for NaN."""
    angle_rad = float(angle_rad)
    if not math.isfinite(angle_rad):
        return UINT16_MAX
    return round(math.degrees(angle_rad) * 100.0) % 36000


def _time_boot_ms(snapshot: TelemetrySnapshot) -> int:
    return (snapshot.time_usec // 1000) & 0xFFFFFFFF


def _floats(values: Sequence[float]) -> list[float]:
    return [float(v) for v in values]


def heartbeat(snapshot: TelemetrySnapshot, context: MessageContext) -> Message:
    """HEARTBEAT (0): PX4 autopilot, the airframe's MAV_TYPE, base/custom mode, system status."""
    return mavlink2.MAVLink_heartbeat_message(
        type=int(context.params.get("MAV_TYPE")),
        autopilot=MAV_AUTOPILOT,
        base_mode=base_mode(snapshot.armed, snapshot.main_mode),
        custom_mode=custom_mode(snapshot.main_mode, snapshot.sub_mode),
        system_status=snapshot.system_status & 0xFF,
        mavlink_version=3,
    )


def sys_status(snapshot: TelemetrySnapshot, context: MessageContext) -> Message:
    """SYS_STATUS (1): sensor present/enabled/health bits and the battery summary."""
    present = snapshot.sensors_present & 0xFFFFFFFF
    return mavlink2.MAVLink_sys_status_message(
        onboard_control_sensors_present=present,
        onboard_control_sensors_enabled=present,
        onboard_control_sensors_health=snapshot.sensors_health & 0xFFFFFFFF,
        load=0,
        voltage_battery=_scaled(snapshot.battery_voltage_v, 1000.0, 0, UINT16_MAX - 1, UINT16_MAX),
        current_battery=_current_ca(snapshot.battery_current_a),
        battery_remaining=_remaining_pct(snapshot.battery_remaining_pct),
        drop_rate_comm=0,
        errors_comm=0,
        errors_count1=0,
        errors_count2=0,
        errors_count3=0,
        errors_count4=0,
    )


def _current_ca(current_a: float) -> int:
    """Battery current in cA; -1 when unknown (NaN or negative)."""
    current_a = float(current_a)
    if not math.isfinite(current_a) or current_a < 0.0:
        return -1
    return _scaled(current_a, 100.0, 0, INT16_MAX, -1)


def _remaining_pct(remaining_pct: int) -> int:
    return remaining_pct if 0 <= remaining_pct <= 100 else -1


def extended_sys_state(snapshot: TelemetrySnapshot, context: MessageContext) -> Message:
    """EXTENDED_SYS_STATE (245): landed state (drives MAVSDK in_air); not a VTOL."""
    return mavlink2.MAVLink_extended_sys_state_message(
        vtol_state=mavlink2.MAV_VTOL_STATE_UNDEFINED, landed_state=snapshot.landed_state & 0xFF
    )


def global_position_int_fields(
    snapshot: TelemetrySnapshot, context: MessageContext
) -> tuple | None:
    """GLOBAL_POSITION_INT (33): fused position; None until lat/lon are known."""
    if not (math.isfinite(snapshot.lat_deg) and math.isfinite(snapshot.lon_deg)):
        return None
    vn, ve, vd = snapshot.velocity_ned_m_s
    return (
        _time_boot_ms(snapshot),
        _scaled(snapshot.lat_deg, 1e7, -900_000_000, 900_000_000, 0),
        _scaled(snapshot.lon_deg, 1e7, -1_800_000_000, 1_800_000_000, 0),
        _scaled(snapshot.alt_amsl_m, 1000.0, -(2**31), 2**31 - 1, 0),
        _scaled(snapshot.relative_alt_m, 1000.0, -(2**31), 2**31 - 1, 0),
        _scaled(vn, 100.0, -INT16_MAX, INT16_MAX, 0),
        _scaled(ve, 100.0, -INT16_MAX, INT16_MAX, 0),
        _scaled(vd, 100.0, -INT16_MAX, INT16_MAX, 0),
        _degrees_cdeg(snapshot.euler_rad[2]),
    )


def local_position_ned_fields(snapshot: TelemetrySnapshot, context: MessageContext) -> tuple | None:
    """LOCAL_POSITION_NED (32): position and velocity in the EKF-origin NED frame."""
    x, y, z = _floats(snapshot.position_ned_m)
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        return None
    vx, vy, vz = _floats(snapshot.velocity_ned_m_s)
    return (_time_boot_ms(snapshot), x, y, z, vx, vy, vz)


def attitude_fields(snapshot: TelemetrySnapshot, context: MessageContext) -> tuple:
    """ATTITUDE (30): roll, pitch, yaw and body rates, rad and rad/s."""
    roll, pitch, yaw = _floats(snapshot.euler_rad)
    p, q, r = _floats(snapshot.body_rates_rad_s)
    return (_time_boot_ms(snapshot), roll, pitch, yaw, p, q, r)


def attitude_quaternion_fields(snapshot: TelemetrySnapshot, context: MessageContext) -> tuple:
    """ATTITUDE_QUATERNION (31): q1..q4 = w, x, y, z (body FRD to NED) and body rates.

    repr_offset_q is all zero (no representation offset).
    """
    w, x, y, z = _floats(snapshot.quaternion_wxyz)
    p, q, r = _floats(snapshot.body_rates_rad_s)
    return (_time_boot_ms(snapshot), w, x, y, z, p, q, r, 0.0, 0.0, 0.0, 0.0)


def gps_raw_int_fields(snapshot: TelemetrySnapshot, context: MessageContext) -> tuple:
    """GPS_RAW_INT (24): raw receiver output; accuracies in h_acc/v_acc (mm)."""
    vn, ve, _ = _floats(snapshot.gps_velocity_ned_m_s)
    ground_speed = math.hypot(vn, ve)
    course_rad = math.atan2(ve, vn) if math.isfinite(ground_speed) else math.nan
    extra = snapshot.extra
    return (
        snapshot.time_usec,
        _scaled(snapshot.gps_lat_deg, 1e7, -900_000_000, 900_000_000, 0),
        _scaled(snapshot.gps_lon_deg, 1e7, -1_800_000_000, 1_800_000_000, 0),
        _scaled(snapshot.gps_alt_amsl_m, 1000.0, -(2**31), 2**31 - 1, 0),
        _scaled(extra.get("gps_hdop", math.nan), 100.0, 0, UINT16_MAX - 1, UINT16_MAX),  # eph
        _scaled(extra.get("gps_vdop", math.nan), 100.0, 0, UINT16_MAX - 1, UINT16_MAX),  # epv
        _scaled(ground_speed, 100.0, 0, UINT16_MAX - 1, UINT16_MAX),  # vel
        _degrees_cdeg(course_rad),  # cog
        snapshot.gps_fix_type & 0xFF,
        min(254, max(0, snapshot.gps_satellites)),
        0,  # alt_ellipsoid
        _scaled(snapshot.gps_eph_m, 1000.0, 0, 2**32 - 1, 0),  # h_acc
        _scaled(snapshot.gps_epv_m, 1000.0, 0, 2**32 - 1, 0),  # v_acc
        0,  # vel_acc
        0,  # hdg_acc
        0,  # yaw
    )


def battery_status(snapshot: TelemetrySnapshot, context: MessageContext) -> Message:
    """BATTERY_STATUS (147): per-cell voltages (BAT1_N_CELLS), current, charge state."""
    cells = min(_MAX_CELLS, max(1, int(context.params.get("BAT1_N_CELLS"))))
    cell_mv = _scaled(snapshot.battery_voltage_v / cells, 1000.0, 0, UINT16_MAX - 1, UINT16_MAX)
    voltages = [UINT16_MAX] * _MAX_CELLS_IN_VOLTAGES
    voltages_ext = [0] * (_MAX_CELLS - _MAX_CELLS_IN_VOLTAGES)
    for cell in range(cells):
        if cell < _MAX_CELLS_IN_VOLTAGES:
            voltages[cell] = cell_mv
        else:
            voltages_ext[cell - _MAX_CELLS_IN_VOLTAGES] = cell_mv
    consumed = float(snapshot.battery_consumed_mah)
    return mavlink2.MAVLink_battery_status_message(
        id=0,
        battery_function=mavlink2.MAV_BATTERY_FUNCTION_ALL,
        type=mavlink2.MAV_BATTERY_TYPE_LIPO,
        temperature=INT16_MAX,
        voltages=voltages,
        current_battery=_current_ca(snapshot.battery_current_a),
        current_consumed=_scaled(consumed, 1.0, 0, 2**31 - 1, -1) if consumed >= 0 else -1,
        energy_consumed=-1,
        battery_remaining=_remaining_pct(snapshot.battery_remaining_pct),
        time_remaining=0,
        charge_state=_charge_state(snapshot.battery_remaining_pct, context.params),
        voltages_ext=voltages_ext,
        mode=0,
        fault_bitmask=0,
    )


def _charge_state(remaining_pct: int, params: ParamStore) -> int:
    """MAV_BATTERY_CHARGE_STATE from the remaining charge and PX4's BAT_*_THR thresholds."""
    if not 0 <= remaining_pct <= 100:
        return mavlink2.MAV_BATTERY_CHARGE_STATE_UNDEFINED
    fraction = remaining_pct / 100.0
    if fraction <= params.get("BAT_EMERGEN_THR"):
        return mavlink2.MAV_BATTERY_CHARGE_STATE_EMERGENCY
    if fraction <= params.get("BAT_CRIT_THR"):
        return mavlink2.MAV_BATTERY_CHARGE_STATE_CRITICAL
    if fraction <= params.get("BAT_LOW_THR"):
        return mavlink2.MAV_BATTERY_CHARGE_STATE_LOW
    return mavlink2.MAV_BATTERY_CHARGE_STATE_OK


def home_position(snapshot: TelemetrySnapshot, context: MessageContext) -> Message | None:
    """HOME_POSITION (242); None while the vehicle has no home."""
    home = snapshot.home
    if home is None:
        return None
    x, y, z = _floats(home.local_ned_m)
    return mavlink2.MAVLink_home_position_message(
        latitude=_scaled(home.lat_deg, 1e7, -900_000_000, 900_000_000, 0),
        longitude=_scaled(home.lon_deg, 1e7, -1_800_000_000, 1_800_000_000, 0),
        altitude=_scaled(home.alt_amsl_m, 1000.0, -(2**31), 2**31 - 1, 0),
        x=x,
        y=y,
        z=z,
        q=[1.0, 0.0, 0.0, 0.0],
        approach_x=0.0,
        approach_y=0.0,
        approach_z=0.0,
        time_usec=snapshot.time_usec,
    )


def vfr_hud_fields(snapshot: TelemetrySnapshot, context: MessageContext) -> tuple:
    """VFR_HUD (74): speeds, heading (deg), throttle (%), AMSL altitude, climb rate."""
    vn, ve, vd = _floats(snapshot.velocity_ned_m_s)
    ground_speed = math.hypot(vn, ve)
    heading_cdeg = _degrees_cdeg(snapshot.euler_rad[2])
    return (
        ground_speed,  # airspeed
        ground_speed,
        float(snapshot.alt_amsl_m),
        -vd,  # climb
        0 if heading_cdeg == UINT16_MAX else round(heading_cdeg / 100.0) % 360,
        _scaled(snapshot.throttle, 100.0, 0, 100, 0),
    )


def altitude_fields(snapshot: TelemetrySnapshot, context: MessageContext) -> tuple:
    """ALTITUDE (141): AMSL, local (-z) and relative altitudes; terrain from the range finder.

    As PX4's ALTITUDE stream: ``altitude_terrain`` is the terrain's altitude AMSL and
    ``bottom_clearance`` the height above it, both NaN while the terrain estimate is invalid.
    """
    extra = snapshot.extra
    return (
        snapshot.time_usec,
        float(snapshot.alt_amsl_m),  # altitude_monotonic
        float(snapshot.alt_amsl_m),  # altitude_amsl
        -float(snapshot.position_ned_m[2]),  # altitude_local
        float(snapshot.relative_alt_m),
        float(extra.get("altitude_terrain_m", math.nan)),
        float(extra.get("bottom_clearance_m", math.nan)),
    )


def system_time(snapshot: TelemetrySnapshot, context: MessageContext) -> Message:
    """SYSTEM_TIME (2): Unix time of the simulation clock and time since boot."""
    return mavlink2.MAVLink_system_time_message(
        time_unix_usec=context.epoch_start_us + snapshot.time_usec,
        time_boot_ms=_time_boot_ms(snapshot),
    )


def flight_information(snapshot: TelemetrySnapshot, context: MessageContext) -> Message:
    """FLIGHT_INFORMATION (264): boot time only; arming/take-off times are not tracked (0)."""
    return mavlink2.MAVLink_flight_information_message(
        time_boot_ms=_time_boot_ms(snapshot),
        arming_time_utc=0,
        takeoff_time_utc=0,
        flight_uuid=0,
        landing_time=0,
    )


def autopilot_version(snapshot: TelemetrySnapshot, context: MessageContext) -> Message:
    """AUTOPILOT_VERSION (148): capabilities, PX4-packed version, uid derived from sysid."""
    version = flight_sw_version(*FIRMWARE_VERSION, _FIRMWARE_TYPE_RELEASE)
    return mavlink2.MAVLink_autopilot_version_message(
        capabilities=CAPABILITIES | (mavlink2.MAV_PROTOCOL_CAPABILITY_FTP if context.ftp else 0),
        flight_sw_version=version,
        middleware_sw_version=version,
        os_sw_version=0,
        board_version=0,
        flight_custom_version=list(_flight_custom_version()),
        middleware_custom_version=[0] * 8,
        os_custom_version=[0] * 8,
        vendor_id=0,
        product_id=0,
        uid=_UID_PREFIX | (context.sysid & 0xFF),
        uid2=[0] * 18,
    )


_POSITION_IGNORE_BITS = (
    mavlink2.POSITION_TARGET_TYPEMASK_X_IGNORE,
    mavlink2.POSITION_TARGET_TYPEMASK_Y_IGNORE,
    mavlink2.POSITION_TARGET_TYPEMASK_Z_IGNORE,
    mavlink2.POSITION_TARGET_TYPEMASK_VX_IGNORE,
    mavlink2.POSITION_TARGET_TYPEMASK_VY_IGNORE,
    mavlink2.POSITION_TARGET_TYPEMASK_VZ_IGNORE,
    mavlink2.POSITION_TARGET_TYPEMASK_AX_IGNORE,
    mavlink2.POSITION_TARGET_TYPEMASK_AY_IGNORE,
    mavlink2.POSITION_TARGET_TYPEMASK_AZ_IGNORE,
    mavlink2.POSITION_TARGET_TYPEMASK_YAW_IGNORE,
    mavlink2.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE,
)
_NAN_COVARIANCE = [math.nan] * 21
_COVARIANCE_DIAGONAL = (0, 6, 11)
"""Indices of the x, y, z variances in ODOMETRY's 21-entry upper-triangle covariances."""


def _ignore_mask(values: Sequence[float]) -> int:
    """POSITION_TARGET_TYPEMASK with the *_IGNORE bit of every NaN among x..yaw_rate."""
    mask = 0
    for bit, value in zip(_POSITION_IGNORE_BITS, values, strict=True):
        if value != value:  # NaN: not controlled
            mask |= bit
    return mask


def attitude_target_fields(snapshot: TelemetrySnapshot, context: MessageContext) -> tuple | None:
    """ATTITUDE_TARGET (83): attitude, body-rate and collective thrust setpoints.

    As PX4: type_mask 0 (every field is a live setpoint) and thrust = |thrust vector| in 0..1;
    nothing while no controller runs.
    """
    sp = snapshot.setpoint
    if sp is None:
        return None
    p, q, r = sp.body_rates_rad_s
    return (
        _time_boot_ms(snapshot),
        *sp.attitude_wxyz,
        p,
        q,
        r,
        min(1.0, max(0.0, sp.thrust)),
        0,  # type_mask
    )


def position_target_local_ned_fields(
    snapshot: TelemetrySnapshot, context: MessageContext
) -> tuple | None:
    """POSITION_TARGET_LOCAL_NED (85): the position controller's setpoint, as PX4 fills it.

    Every NaN field (an axis that is velocity-controlled, no acceleration setpoint, no yaw-rate
    setpoint) gets its *_IGNORE bit in type_mask. Nothing while no controller runs.
    """
    sp = snapshot.setpoint
    if sp is None:
        return None
    values = (*sp.position_ned_m, *sp.velocity_ned_m_s, *sp.acceleration_ned_m_s2)
    values += (sp.yaw_rad, sp.yaw_rate_rad_s)
    return (
        _time_boot_ms(snapshot),
        *values,
        _ignore_mask(values),
        mavlink2.MAV_FRAME_LOCAL_NED,
    )


def position_target_global_int_fields(
    snapshot: TelemetrySnapshot, context: MessageContext
) -> tuple | None:
    """POSITION_TARGET_GLOBAL_INT (87): the position setpoint as lat/lon (degE7) and AMSL alt.

    PX4 sends it only while a position setpoint is being flown (its triplet's current item, with
    finite lat/lon); so here: only while the horizontal position is controlled. Unlike PX4,
    whose type_mask is always 0, NaN fields (no acceleration or yaw-rate setpoint, altitude not
    controlled) get their *_IGNORE bits.
    """
    sp = snapshot.setpoint
    if sp is None:
        return None
    lat, lon, alt = sp.global_position
    if not (math.isfinite(lat) and math.isfinite(lon)):
        return None
    vx, vy, vz = sp.velocity_ned_m_s
    afx, afy, afz = sp.acceleration_ned_m_s2
    values = (lat, lon, alt, vx, vy, vz, afx, afy, afz, sp.yaw_rad, sp.yaw_rate_rad_s)
    return (
        _time_boot_ms(snapshot),
        _scaled(lat, 1e7, -900_000_000, 900_000_000, 0),
        _scaled(lon, 1e7, -1_800_000_000, 1_800_000_000, 0),
        *values[2:],
        _ignore_mask(values),
        mavlink2.MAV_FRAME_GLOBAL_INT,
    )


def estimator_status(snapshot: TelemetrySnapshot, context: MessageContext) -> Message | None:
    """ESTIMATOR_STATUS (230): solution flags, innovation test ratios and position accuracy.

    Test ratios as PX4's EKF2 reports them, sqrt(innovation² / (gate² x innovation variance)) of
    the last sample of each source: above 1 the sample was rejected by its gate.
    """
    est = snapshot.estimator
    if est is None:
        return None
    return mavlink2.MAVLink_estimator_status_message(
        time_usec=snapshot.time_usec,
        flags=est.flags & 0xFFFF,
        vel_ratio=est.vel_ratio,
        pos_horiz_ratio=est.pos_horiz_ratio,
        pos_vert_ratio=est.pos_vert_ratio,
        mag_ratio=est.mag_ratio,
        hagl_ratio=0.0,
        tas_ratio=0.0,
        pos_horiz_accuracy=est.pos_horiz_accuracy_m,
        pos_vert_accuracy=est.pos_vert_accuracy_m,
    )


def odometry_fields(snapshot: TelemetrySnapshot, context: MessageContext) -> tuple | None:
    """ODOMETRY (331): EKF pose and velocity in the local NED frame, as PX4's EKF2 publishes it.

    Velocity is NED (child_frame_id LOCAL_NED), angular velocity body FRD; the covariances carry
    the position and velocity variances on their diagonals and NaN elsewhere (unknown).
    Nothing before the local position is known.
    """
    x, y, z = snapshot.position_ned_m
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        return None
    pose_cov = list(_NAN_COVARIANCE)
    velocity_cov = list(_NAN_COVARIANCE)
    est = snapshot.estimator
    if est is not None:
        for index, pos_var, vel_var in zip(
            _COVARIANCE_DIAGONAL, est.position_variance_m2, est.velocity_variance_m2_s2, strict=True
        ):
            pose_cov[index] = pos_var
            velocity_cov[index] = vel_var
    return (
        snapshot.time_usec,
        x,
        y,
        z,
        *snapshot.quaternion_wxyz,
        *snapshot.velocity_ned_m_s,
        *snapshot.body_rates_rad_s,
        *pose_cov,
        *velocity_cov,
        mavlink2.MAV_FRAME_LOCAL_NED,  # frame_id
        mavlink2.MAV_FRAME_LOCAL_NED,  # child_frame_id
        0,  # reset_counter
        mavlink2.MAV_ESTIMATOR_TYPE_AUTOPILOT,
        0,  # quality
    )


def highres_imu_fields(snapshot: TelemetrySnapshot, context: MessageContext) -> tuple | None:
    """HIGHRES_IMU (105): the last IMU sample (body FRD; gauss, hPa, degC) and its update flags."""
    imu = snapshot.imu
    if imu is None:
        return None
    return (
        imu.time_usec,
        *imu.accel_m_s2,
        *imu.gyro_rad_s,
        *imu.mag_gauss,
        imu.abs_pressure_hpa,
        imu.diff_pressure_hpa,
        imu.pressure_alt_m,
        imu.temperature_degc,
        imu.fields_updated & 0xFFFF,
        0,  # id
    )


def gps_global_origin(snapshot: TelemetrySnapshot, context: MessageContext) -> Message | None:
    """GPS_GLOBAL_ORIGIN (49): the EKF origin of LOCAL_POSITION_NED; nothing before it is set."""
    est = snapshot.estimator
    if est is None or est.origin_lla is None:
        return None
    lat, lon, alt = est.origin_lla
    return mavlink2.MAVLink_gps_global_origin_message(
        latitude=_scaled(lat, 1e7, -900_000_000, 900_000_000, 0),
        longitude=_scaled(lon, 1e7, -1_800_000_000, 1_800_000_000, 0),
        altitude=_scaled(alt, 1000.0, -(2**31), 2**31 - 1, 0),
        time_usec=est.origin_time_usec,
    )


def timesync_request_fields(snapshot: TelemetrySnapshot, context: MessageContext) -> tuple:
    """TIMESYNC (111) as PX4's onboard stream sends it: tc1 = 0 (a request), ts1 = boot time, ns.

    The companion answers with its own clock in tc1; this emulator needs no offset estimate (the
    simulation clock is authoritative), so the answers are not used.
    """
    return (0, snapshot.time_usec * 1000)


def timesync_reply(request: Message, now_ns: int) -> Message:
    """TIMESYNC answer to a request (tc1 == 0), as PX4's timesync.

    tc1 = our boot time in ns, ts1 echoed so the requester can match it to its own request.
    """
    return mavlink2.MAVLink_timesync_message(tc1=now_ns, ts1=request.ts1)


def mission_current(seq: int, total: int, state: int) -> Message:
    """MISSION_CURRENT (42): current item, item count (65535: none), MISSION_STATE and mode.

    Built from the vehicle's live mission status, not the per-poll snapshot, so a reply to
    MISSION_SET_CURRENT carries the new item.
    """
    mode = (
        0
        if state == mavlink2.MISSION_STATE_NO_MISSION
        else (1 if state == mavlink2.MISSION_STATE_ACTIVE else 2)
    )
    return mavlink2.MAVLink_mission_current_message(
        seq=seq & 0xFFFF, total=total & 0xFFFF, mission_state=state & 0xFF, mission_mode=mode
    )


def message_interval(message_id: int, interval_us: int) -> Message:
    """MESSAGE_INTERVAL (244): -1 disabled, 0 not available, > 0 the interval in us."""
    return mavlink2.MAVLink_message_interval_message(message_id=message_id, interval_us=interval_us)


def statustext_chunks(severity: int, text: str, chunk_id: int) -> list[Message]:
    """STATUSTEXT (253) messages for ``text``; longer than 50 bytes -> chunks sharing ``chunk_id``.

    A single message carries id 0. Chunked texts end with a chunk shorter than 50 bytes (the
    receiver sees its NUL terminator), so a text of an exact multiple of 50 bytes gets an empty
    final chunk.
    """
    data = text.encode("utf-8", errors="replace")
    severity &= 0xFF
    if len(data) <= STATUSTEXT_CHUNK_LEN:
        return [mavlink2.MAVLink_statustext_message(severity, data, 0, 0)]
    pieces = [
        data[start : start + STATUSTEXT_CHUNK_LEN]
        for start in range(0, len(data), STATUSTEXT_CHUNK_LEN)
    ]
    if len(pieces[-1]) == STATUSTEXT_CHUNK_LEN:
        pieces.append(b"")
    return [
        mavlink2.MAVLink_statustext_message(severity, piece, chunk_id, seq & 0xFF)
        for seq, piece in enumerate(pieces)
    ]


def _message_of(cls: type[Message], fields: FieldsBuilder) -> Builder:
    """The builder of pymavlink ``cls`` objects from a builder of its wire-order fields."""
    layout = tuple(zip(cls.ordered_fieldnames, cls.array_lengths, strict=True))

    def build(snapshot: TelemetrySnapshot, context: MessageContext) -> Message | None:
        values = fields(snapshot, context)
        if values is None:
            return None
        kwargs: dict[str, object] = {}
        k = 0
        for name, length in layout:
            if length:
                kwargs[name] = list(values[k : k + length])
                k += length
            else:
                kwargs[name] = values[k]
                k += 1
        return cls(**kwargs)

    build.__name__ = build.__qualname__ = fields.__name__.removesuffix("_fields")
    build.__doc__ = fields.__doc__
    return build


FIELDS: dict[int, FieldsBuilder] = {
    mavlink2.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: global_position_int_fields,
    mavlink2.MAVLINK_MSG_ID_LOCAL_POSITION_NED: local_position_ned_fields,
    mavlink2.MAVLINK_MSG_ID_ATTITUDE: attitude_fields,
    mavlink2.MAVLINK_MSG_ID_ATTITUDE_QUATERNION: attitude_quaternion_fields,
    mavlink2.MAVLINK_MSG_ID_GPS_RAW_INT: gps_raw_int_fields,
    mavlink2.MAVLINK_MSG_ID_VFR_HUD: vfr_hud_fields,
    mavlink2.MAVLINK_MSG_ID_ALTITUDE: altitude_fields,
    mavlink2.MAVLINK_MSG_ID_ATTITUDE_TARGET: attitude_target_fields,
    mavlink2.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED: position_target_local_ned_fields,
    mavlink2.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT: position_target_global_int_fields,
    mavlink2.MAVLINK_MSG_ID_ODOMETRY: odometry_fields,
    mavlink2.MAVLINK_MSG_ID_HIGHRES_IMU: highres_imu_fields,
    mavlink2.MAVLINK_MSG_ID_TIMESYNC: timesync_request_fields,
}
"""The hot streams (10 Hz or more in PX4's onboard or normal profile, streams.PROFILES): message
id -> builder of its wire-order fields, which the endpoint packs straight into a frame
(framing.encode_fields); their pymavlink-object builders below are made from the same fields."""

global_position_int = _message_of(
    mavlink2.MAVLink_global_position_int_message, global_position_int_fields
)
local_position_ned = _message_of(
    mavlink2.MAVLink_local_position_ned_message, local_position_ned_fields
)
attitude = _message_of(mavlink2.MAVLink_attitude_message, attitude_fields)
attitude_quaternion = _message_of(
    mavlink2.MAVLink_attitude_quaternion_message, attitude_quaternion_fields
)
gps_raw_int = _message_of(mavlink2.MAVLink_gps_raw_int_message, gps_raw_int_fields)
vfr_hud = _message_of(mavlink2.MAVLink_vfr_hud_message, vfr_hud_fields)
altitude = _message_of(mavlink2.MAVLink_altitude_message, altitude_fields)
attitude_target = _message_of(mavlink2.MAVLink_attitude_target_message, attitude_target_fields)
position_target_local_ned = _message_of(
    mavlink2.MAVLink_position_target_local_ned_message, position_target_local_ned_fields
)
position_target_global_int = _message_of(
    mavlink2.MAVLink_position_target_global_int_message, position_target_global_int_fields
)
odometry = _message_of(mavlink2.MAVLink_odometry_message, odometry_fields)
highres_imu = _message_of(mavlink2.MAVLink_highres_imu_message, highres_imu_fields)
timesync_request = _message_of(mavlink2.MAVLink_timesync_message, timesync_request_fields)

BUILDERS: dict[int, Builder] = {
    mavlink2.MAVLINK_MSG_ID_HEARTBEAT: heartbeat,
    mavlink2.MAVLINK_MSG_ID_SYS_STATUS: sys_status,
    mavlink2.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: extended_sys_state,
    mavlink2.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: global_position_int,
    mavlink2.MAVLINK_MSG_ID_LOCAL_POSITION_NED: local_position_ned,
    mavlink2.MAVLINK_MSG_ID_ATTITUDE: attitude,
    mavlink2.MAVLINK_MSG_ID_ATTITUDE_QUATERNION: attitude_quaternion,
    mavlink2.MAVLINK_MSG_ID_GPS_RAW_INT: gps_raw_int,
    mavlink2.MAVLINK_MSG_ID_BATTERY_STATUS: battery_status,
    mavlink2.MAVLINK_MSG_ID_HOME_POSITION: home_position,
    mavlink2.MAVLINK_MSG_ID_VFR_HUD: vfr_hud,
    mavlink2.MAVLINK_MSG_ID_ALTITUDE: altitude,
    mavlink2.MAVLINK_MSG_ID_SYSTEM_TIME: system_time,
    mavlink2.MAVLINK_MSG_ID_FLIGHT_INFORMATION: flight_information,
    mavlink2.MAVLINK_MSG_ID_AUTOPILOT_VERSION: autopilot_version,
    mavlink2.MAVLINK_MSG_ID_ATTITUDE_TARGET: attitude_target,
    mavlink2.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED: position_target_local_ned,
    mavlink2.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT: position_target_global_int,
    mavlink2.MAVLINK_MSG_ID_ESTIMATOR_STATUS: estimator_status,
    mavlink2.MAVLINK_MSG_ID_ODOMETRY: odometry,
    mavlink2.MAVLINK_MSG_ID_HIGHRES_IMU: highres_imu,
    mavlink2.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN: gps_global_origin,
    mavlink2.MAVLINK_MSG_ID_TIMESYNC: timesync_request,
}
"""Message id -> builder, for streams and MAV_CMD_REQUEST_MESSAGE."""
