"""SET_POSITION_TARGET_LOCAL_NED / _GLOBAL_INT and SET_ATTITUDE_TARGET -> offboard setpoints.

The wire side of offboard control: which fields a type_mask enables, which frames PX4 accepts,
and what makes a setpoint unusable. A message that cannot be flown (an unsupported frame, a
force setpoint, a type_mask that ignores everything, a NaN in a used field, a zero quaternion)
raises :class:`SetpointError`; :class:`SetpointReceiver` drops it and logs the reason once.
Ignored fields may hold anything, NaN included.

type_mask bits (POSITION_TARGET_TYPEMASK): 0-2 ignore x, y, z; 3-5 ignore vx, vy, vz; 6-8
ignore ax, ay, az; 9 accelerations are forces; 10 ignore yaw; 11 ignore yaw rate. Bits 12 and
up (old takeoff / land / loiter hints) are ignored, as current PX4 does.
ATTITUDE_TARGET_TYPEMASK: 0-2 ignore body roll, pitch, yaw rate; 6 ignore thrust; 7 ignore
attitude. (Bit 5, "thrust_body set", refers to a field the common dialect pymavlink ships does
not carry; ``thrust`` is always the collective thrust.)
"""

from __future__ import annotations

import logging
import math

import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink.endpoint_config import EndpointStats
from autopilot_emu.mavlink.forwarding import addressed_to
from autopilot_emu.mavlink.vehicle_port import VehiclePort
from autopilot_emu.modes.offboard import (
    GLOBAL_FRAMES,
    GlobalSetpoint,
    LocalFrame,
    OffboardSetpoint,
)

logger = logging.getLogger(__name__)

_POS_BITS = (1, 2, 4)
_VEL_BITS = (8, 16, 32)
_ACC_BITS = (64, 128, 256)
_FORCE = 1 << 9
_YAW_IGNORE = 1 << 10
_YAW_RATE_IGNORE = 1 << 11
_RATE_BITS = (1, 2, 4)
_THRUST_IGNORE = 1 << 6
_ATTITUDE_IGNORE = 1 << 7


class SetpointError(ValueError):
    """A setpoint message that cannot be flown; the text says why."""


def _vector(values: tuple[float, float, float], mask: int, bits: tuple[int, ...]) -> np.ndarray:
    out = np.array(values, dtype=float)
    for axis, bit in enumerate(bits):
        if mask & bit:
            out[axis] = np.nan
        elif not math.isfinite(out[axis]):
            raise SetpointError("non-finite value in a used field")
    return out


def _position_target(
    mask: int,
    position: tuple[float, float, float],
    velocity: tuple[float, float, float],
    acceleration: tuple[float, float, float],
    yaw: float,
    yaw_rate: float,
) -> OffboardSetpoint:
    pos = _vector(position, mask, _POS_BITS)
    vel = _vector(velocity, mask, _VEL_BITS)
    acc = _vector(acceleration, mask, _ACC_BITS)
    if not (np.isfinite(pos).any() or np.isfinite(vel).any() or np.isfinite(acc).any()):
        raise SetpointError("type_mask ignores position, velocity and acceleration")
    if mask & _FORCE and np.isfinite(acc).any():
        raise SetpointError("force setpoints are not supported")
    yaw_rad = math.nan if mask & _YAW_IGNORE else float(yaw)
    yaw_rate_rad_s = math.nan if mask & _YAW_RATE_IGNORE else float(yaw_rate)
    if not (mask & _YAW_IGNORE or math.isfinite(yaw_rad)) or not (
        mask & _YAW_RATE_IGNORE or math.isfinite(yaw_rate_rad_s)
    ):
        raise SetpointError("non-finite value in a used field")
    return OffboardSetpoint(pos, vel, acc, yaw_rad, yaw_rate_rad_s)


def decode_local(
    msg: mavlink2.MAVLink_set_position_target_local_ned_message,
) -> tuple[OffboardSetpoint, LocalFrame]:
    """SET_POSITION_TARGET_LOCAL_NED -> setpoint in its frame (see :func:`to_local_ned`)."""
    try:
        frame = LocalFrame(msg.coordinate_frame)
    except ValueError:
        raise SetpointError(f"unsupported frame {msg.coordinate_frame}") from None
    setpoint = _position_target(
        int(msg.type_mask),
        (msg.x, msg.y, msg.z),
        (msg.vx, msg.vy, msg.vz),
        (msg.afx, msg.afy, msg.afz),
        msg.yaw,
        msg.yaw_rate,
    )
    return setpoint, frame


def decode_global(msg: mavlink2.MAVLink_set_position_target_global_int_message) -> GlobalSetpoint:
    """SET_POSITION_TARGET_GLOBAL_INT -> geodetic target plus NED velocity / acceleration."""
    reference = GLOBAL_FRAMES.get(int(msg.coordinate_frame))
    if reference is None:
        raise SetpointError(f"unsupported frame {msg.coordinate_frame}")
    mask = int(msg.type_mask)
    lat_lon_alt = (msg.lat_int * 1e-7, msg.lon_int * 1e-7, msg.alt)
    setpoint = _position_target(
        mask,
        lat_lon_alt,
        (msg.vx, msg.vy, msg.vz),
        (msg.afx, msg.afy, msg.afz),
        msg.yaw,
        msg.yaw_rate,
    )
    lat, lon, alt = setpoint.position_ned_m.tolist()
    if math.isfinite(lat) != math.isfinite(lon):
        raise SetpointError("latitude and longitude must both be used or both ignored")
    if math.isfinite(lat) and not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
        raise SetpointError("latitude/longitude out of range")
    rest = OffboardSetpoint(
        velocity_ned_m_s=setpoint.velocity_ned_m_s,
        acceleration_ned_m_s2=setpoint.acceleration_ned_m_s2,
        yaw_rad=setpoint.yaw_rad,
        yaw_rate_rad_s=setpoint.yaw_rate_rad_s,
    )
    return GlobalSetpoint(lat, lon, alt, reference, rest)


def decode_attitude(msg: mavlink2.MAVLink_set_attitude_target_message) -> OffboardSetpoint:
    """SET_ATTITUDE_TARGET -> attitude + thrust, body rates + thrust, or a thrust alone.

    With the attitude used, body rates are not flown (the attitude loop makes its own).
    """
    mask = int(msg.type_mask)
    thrust = math.nan
    if not mask & _THRUST_IGNORE:
        thrust = float(msg.thrust)
        if not math.isfinite(thrust):
            raise SetpointError("non-finite value in a used field")
        thrust = min(max(thrust, 0.0), 1.0)
    attitude = None
    rates = None
    if not mask & _ATTITUDE_IGNORE:
        q = np.array(msg.q, dtype=float)
        norm = float(np.linalg.norm(q)) if np.isfinite(q).all() else math.nan
        if not norm > 1e-6:
            raise SetpointError("attitude quaternion is zero or not finite")
        attitude = q / norm
    else:
        used = [not mask & bit for bit in _RATE_BITS]
        if any(used):
            rates = _vector(
                (msg.body_roll_rate, msg.body_pitch_rate, msg.body_yaw_rate), mask, _RATE_BITS
            )
    if attitude is None and rates is None and not math.isfinite(thrust):
        raise SetpointError("type_mask ignores attitude, rates and thrust")
    return OffboardSetpoint(attitude_wxyz=attitude, body_rates_rad_s=rates, thrust=thrust)


_SET_ATTITUDE_TARGET = mavlink2.MAVLINK_MSG_ID_SET_ATTITUDE_TARGET
_SET_POSITION_TARGET_LOCAL_NED = mavlink2.MAVLINK_MSG_ID_SET_POSITION_TARGET_LOCAL_NED


class SetpointReceiver:
    """Passes one link's offboard setpoints addressed to the autopilot to the vehicle.

    Args:
        vehicle: takes the decoded setpoints.
        sysid: our system id.
        compid: our component id.
        stats: the link's counters (setpoints received and ignored).
    """

    def __init__(self, vehicle: VehiclePort, sysid: int, compid: int, stats: EndpointStats) -> None:
        self._vehicle = vehicle
        self._sysid = sysid
        self._compid = compid
        self._stats = stats
        self._problems: set[str] = set()
        """Reasons already logged (each once)."""

    def handle(self, msg: mavlink2.MAVLink_message) -> None:
        """SET_POSITION_TARGET_LOCAL_NED / _GLOBAL_INT, SET_ATTITUDE_TARGET -> the vehicle."""
        if not addressed_to(msg.target_system, msg.target_component, self._sysid, self._compid):
            return
        vehicle = self._vehicle
        try:
            msg_id = msg.get_msgId()
            if msg_id == _SET_ATTITUDE_TARGET:
                taken = vehicle.offboard_setpoint(decode_attitude(msg), LocalFrame.LOCAL_NED)
                reason = "a thrust alone without an attitude or rate setpoint"
            elif msg_id == _SET_POSITION_TARGET_LOCAL_NED:
                taken = vehicle.offboard_setpoint(*decode_local(msg))
                reason = ""
            else:
                taken = vehicle.offboard_setpoint_global(decode_global(msg))
                reason = "no global origin or home yet"
        except SetpointError as exc:
            taken, reason = False, str(exc)
        if taken:
            self._stats.setpoints_received += 1
            return
        self._stats.setpoints_ignored += 1
        key = f"{msg.get_type()}: {reason}"
        if key not in self._problems:
            self._problems.add(key)
            logger.warning("ignoring %s (type_mask 0x%04x)", key, int(msg.type_mask))
