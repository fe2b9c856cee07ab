"""VISION_POSITION_ESTIMATE (#102) and ODOMETRY (#331) -> one external-vision measurement.

The wire side of external vision (EKF2_EV_CTRL), decoded as PX4's ``mavlink_receiver.cpp`` fills
``vehicle_visual_odometry``:

- VISION_POSITION_ESTIMATE: position x, y, z in the local NED frame, yaw from the Euler angles;
  ``covariance`` is the row-major upper triangle of the 6x6 pose covariance (x, y, z, roll,
  pitch, yaw), so the variances are its entries 0, 6, 11 (position) and 20 (yaw); NaN in entry 0
  means "unknown".
- ODOMETRY: pose in ``frame_id`` MAV_FRAME_LOCAL_NED or LOCAL_FRD (taken as is), LOCAL_ENU or
  LOCAL_FLU (converted); attitude ``q`` (w, x, y, z) body FRD to that frame; velocity in
  ``child_frame_id`` (a local frame as above, or MAV_FRAME_BODY_FRD, rotated by ``q``), or NaN;
  ``pose_covariance`` as above. PX4 ignores the covariances of estimator_type NAIVE and accepts
  UNKNOWN, NAIVE, VISION and VIO for EKF2; MOCAP goes to another topic (vehicle_mocap_odometry)
  that EKF2 does not fuse, and any other type is refused with an error.

An FRD local frame is passed on as if its x axis pointed north: this estimator has no estimate of
the rotation between a vision frame and NED (PX4 learns it unless vision yaw is fused).

A message that cannot be used (non-finite position, unsupported frame or estimator type, a
non-finite or negative variance where the covariance is given) raises :class:`VisionError`;
:class:`VisionReceiver` drops it and logs the reason once.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink.endpoint_config import EndpointStats
from autopilot_emu.mavlink.link_clock import LinkClock
from autopilot_emu.mavlink.vehicle_port import VehiclePort

logger = logging.getLogger(__name__)

_POS_VAR = (0, 6, 11)
_YAW_VAR = 20
_LOCAL_NED, _LOCAL_ENU = mavlink2.MAV_FRAME_LOCAL_NED, mavlink2.MAV_FRAME_LOCAL_ENU
_LOCAL_FRD, _LOCAL_FLU = mavlink2.MAV_FRAME_LOCAL_FRD, mavlink2.MAV_FRAME_LOCAL_FLU
_BODY_FRAMES = (
    mavlink2.MAV_FRAME_BODY_FRD,
    mavlink2.MAV_FRAME_BODY_NED,  # deprecated aliases PX4 still maps to body FRD
    mavlink2.MAV_FRAME_BODY_OFFSET_NED,
)
_EKF2_TYPES = (
    mavlink2.MAV_ESTIMATOR_TYPE_UNKNOWN,
    mavlink2.MAV_ESTIMATOR_TYPE_NAIVE,
    mavlink2.MAV_ESTIMATOR_TYPE_VISION,
    mavlink2.MAV_ESTIMATOR_TYPE_VIO,
)


class VisionError(ValueError):
    """An external-vision message that cannot be fused; the text says why."""


@dataclass(frozen=True)
class VisionMeasurement:
    """One external-vision sample in the vehicle's local frame (NaN: not measured / unknown)."""

    position_ned_m: np.ndarray
    """Position, local NED, m, (3,)."""
    position_var_m2: np.ndarray
    """Position variances, m², (3,); NaN: unknown (the estimator uses EKF2_EVP_NOISE)."""
    yaw_rad: float
    """Heading, rad; NaN if the message has no usable attitude."""
    yaw_var_rad2: float
    """Heading variance, rad²; NaN: unknown (EKF2_EVA_NOISE)."""
    velocity_ned_m_s: np.ndarray | None
    """Velocity, local NED, m/s, (3,); None if not given."""


def _to_ned(frame: int, x: float, y: float, z: float) -> np.ndarray:
    if frame in (_LOCAL_NED, _LOCAL_FRD):
        return np.array([x, y, z], dtype=float)
    if frame == _LOCAL_ENU:
        return np.array([y, x, -z], dtype=float)
    if frame == _LOCAL_FLU:
        return np.array([x, -y, -z], dtype=float)
    raise VisionError(f"unsupported frame {frame}")


def _variances(covariance: list[float], use: bool) -> tuple[np.ndarray, float]:
    """Position variances and yaw variance from a 21-entry upper triangle (NaN if unknown)."""
    if not use or not math.isfinite(covariance[0]):
        return np.full(3, np.nan), math.nan
    position = np.array([covariance[i] for i in _POS_VAR], dtype=float)
    if not (np.isfinite(position).all() and (position >= 0.0).all()):
        raise VisionError("non-finite or negative position variance")
    yaw = float(covariance[_YAW_VAR])
    if math.isfinite(yaw) and yaw < 0.0:
        raise VisionError("negative yaw variance")
    return position, yaw if math.isfinite(yaw) else math.nan


def _finite_position(p: np.ndarray) -> np.ndarray:
    if not np.isfinite(p).all():
        raise VisionError("non-finite position")
    return p


def decode_vision_position_estimate(msg: mavlink2.MAVLink_message) -> VisionMeasurement:
    """VISION_POSITION_ESTIMATE -> measurement (local NED, as PX4)."""
    position = _finite_position(np.array([msg.x, msg.y, msg.z], dtype=float))
    variances, yaw_var = _variances(list(msg.covariance), use=True)
    yaw = float(msg.yaw)
    return VisionMeasurement(
        position_ned_m=position,
        position_var_m2=variances,
        yaw_rad=math.remainder(yaw, math.tau) if math.isfinite(yaw) else math.nan,
        yaw_var_rad2=yaw_var,
        velocity_ned_m_s=None,
    )


def _yaw_and_rotation(q: list[float], frame: int) -> tuple[float, np.ndarray | None]:
    """Heading in NED and the body-to-NED rotation of an ODOMETRY quaternion (NaN, None if bad)."""
    w, x, y, z = (float(v) for v in q)
    norm = math.sqrt(w * w + x * x + y * y + z * z)
    if not (math.isfinite(norm) and norm > 0.5):
        return math.nan, None
    w, x, y, z = w / norm, x / norm, y / norm, z / norm
    r = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
    if frame in (_LOCAL_ENU, _LOCAL_FLU):
        return math.nan, None  # PX4 copies such a q unconverted; here its heading is unknown
    return math.atan2(r[1, 0], r[0, 0]), r


def decode_odometry(msg: mavlink2.MAVLink_message) -> VisionMeasurement:
    """ODOMETRY -> measurement; frames and covariances as PX4's receiver takes them."""
    if msg.estimator_type == mavlink2.MAV_ESTIMATOR_TYPE_MOCAP:
        raise VisionError("estimator_type MOCAP is not fused by EKF2 (vehicle_mocap_odometry)")
    if msg.estimator_type not in _EKF2_TYPES:
        raise VisionError(f"unsupported estimator_type {msg.estimator_type}")
    position = _finite_position(_to_ned(msg.frame_id, msg.x, msg.y, msg.z))
    naive = msg.estimator_type == mavlink2.MAV_ESTIMATOR_TYPE_NAIVE
    variances, yaw_var = _variances(list(msg.pose_covariance), use=not naive)
    yaw, rotation = _yaw_and_rotation(list(msg.q), msg.frame_id)
    velocity = np.array([msg.vx, msg.vy, msg.vz], dtype=float)
    if not np.isfinite(velocity).all():
        velocity_ned = None
    elif msg.child_frame_id in _BODY_FRAMES:
        velocity_ned = rotation @ velocity if rotation is not None else None
    else:
        try:
            velocity_ned = _to_ned(msg.child_frame_id, *velocity)
        except VisionError:
            velocity_ned = None  # PX4 drops an unsupported velocity frame, keeps the pose
    return VisionMeasurement(
        position_ned_m=position,
        position_var_m2=variances,
        yaw_rad=yaw,
        yaw_var_rad2=yaw_var if math.isfinite(yaw) else math.nan,
        velocity_ned_m_s=velocity_ned,
    )


_ODOMETRY = mavlink2.MAVLINK_MSG_ID_ODOMETRY


class VisionReceiver:
    """Passes one link's external-vision messages to the vehicle's estimator.

    Args:
        vehicle: takes the measurements.
        clock: simulation time of the poll (the samples' time stamp).
        stats: the link's counters (vision samples received and ignored).
    """

    def __init__(self, vehicle: VehiclePort, clock: LinkClock, stats: EndpointStats) -> None:
        self._vehicle = vehicle
        self._clock = clock
        self._stats = stats
        self._problems: set[str] = set()
        """Reasons already logged (each once)."""

    def handle(self, msg: mavlink2.MAVLink_message) -> None:
        """VISION_POSITION_ESTIMATE / ODOMETRY -> the vehicle's external-vision input.

        Stamped with the arrival time: without a converged timesync offset PX4 stamps such
        samples with their arrival too (``sync_stamp``); EKF2_EV_DELAY covers the latency.
        """
        try:
            if msg.get_msgId() == _ODOMETRY:
                m = decode_odometry(msg)
            else:
                m = decode_vision_position_estimate(msg)
        except VisionError as exc:
            self._stats.vision_ignored += 1
            key = f"{msg.get_type()}: {exc}"
            if key not in self._problems:
                self._problems.add(key)
                logger.warning("ignoring %s", key)
            return
        self._vehicle.vision_measurement(
            self._clock.now_us,
            m.position_ned_m,
            m.position_var_m2,
            m.yaw_rad,
            m.yaw_var_rad2,
            m.velocity_ned_m_s,
        )
        self._stats.vision_received += 1
