"""Checks of uploaded plans, split the way PX4 splits them.

* :func:`check_item` runs on every item as it arrives (PX4's mavlink_mission.cpp parser): a
  frame or command the plan type cannot hold, a coordinate out of range or a polygon with fewer
  than three vertices aborts the transfer with the MAV_MISSION_RESULT in MISSION_ACK.
* :func:`check_fence_plan` runs on a complete fence (vertex runs must be whole).
* :func:`mission_problem` is PX4's feasibility checker: a mission that transfers fine but cannot
  be flown (outside the geofence, beyond GF_MAX_*, relative altitudes without home) is still
  ACCEPTED, then marked invalid: MISSION_CURRENT reports NO_MISSION, Mission mode is refused,
  and STATUSTEXT says why. MIS_DIST_1WP only warns, as in PX4 since v1.14.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu import geodesy
from autopilot_emu.mission.geofence import (
    CIRCLE_EXCLUSION,
    CIRCLE_INCLUSION,
    FENCE_COMMANDS,
    POLYGON_EXCLUSION,
    POLYGON_INCLUSION,
    Fence,
    FenceError,
    build_fence,
)
from autopilot_emu.mission.items import (
    GLOBAL_FRAMES,
    GLOBAL_FRAMES_RELATIVE,
    MISSION_FRAME,
    MissionItem,
    MissionType,
)

POSITION_COMMANDS = frozenset(
    {
        mavlink2.MAV_CMD_NAV_WAYPOINT,
        mavlink2.MAV_CMD_NAV_LOITER_UNLIM,
        mavlink2.MAV_CMD_NAV_LOITER_TIME,
        mavlink2.MAV_CMD_NAV_LAND,
        mavlink2.MAV_CMD_NAV_TAKEOFF,
    }
)
"""Items that fly somewhere (need a global frame)."""
INSTANT_COMMANDS = frozenset(
    {
        mavlink2.MAV_CMD_DO_DIGICAM_CONTROL,
        mavlink2.MAV_CMD_DO_MOUNT_CONFIGURE,
        mavlink2.MAV_CMD_DO_MOUNT_CONTROL,
        mavlink2.MAV_CMD_DO_SET_CAM_TRIGG_DIST,
        mavlink2.MAV_CMD_DO_SET_CAM_TRIGG_INTERVAL,
        mavlink2.MAV_CMD_DO_TRIGGER_CONTROL,
        mavlink2.MAV_CMD_IMAGE_START_CAPTURE,
        mavlink2.MAV_CMD_IMAGE_STOP_CAPTURE,
        mavlink2.MAV_CMD_VIDEO_START_CAPTURE,
        mavlink2.MAV_CMD_VIDEO_STOP_CAPTURE,
        mavlink2.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW,
        mavlink2.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE,
        mavlink2.MAV_CMD_DO_SET_SERVO,
        mavlink2.MAV_CMD_DO_SET_ACTUATOR,
        mavlink2.MAV_CMD_DO_VTOL_TRANSITION,
    }
)
"""Camera, gimbal and actuator items: accepted and complete at once (no payload simulated yet)."""
ROI_COMMANDS = frozenset({mavlink2.MAV_CMD_DO_SET_ROI_LOCATION, mavlink2.MAV_CMD_DO_SET_ROI_NONE})
FLOW_COMMANDS = frozenset(
    {
        mavlink2.MAV_CMD_NAV_RETURN_TO_LAUNCH,
        mavlink2.MAV_CMD_NAV_DELAY,
        mavlink2.MAV_CMD_DO_JUMP,
        mavlink2.MAV_CMD_DO_CHANGE_SPEED,
    }
)
MISSION_COMMANDS = POSITION_COMMANDS | INSTANT_COMMANDS | ROI_COMMANDS | FLOW_COMMANDS
RALLY_POINT = mavlink2.MAV_CMD_NAV_RALLY_POINT


class ItemRejected(ValueError):
    """An item the transfer must refuse; ``result`` is the MAV_MISSION_RESULT for MISSION_ACK."""

    def __init__(self, result: int, seq: int, message: str) -> None:
        super().__init__(message)
        self.result = result
        self.seq = seq
        self.message = message


def check_item(kind: MissionType, item: MissionItem, seq: int) -> None:
    """Raise :class:`ItemRejected` if item ``seq`` cannot be part of a plan of type ``kind``."""
    command, frame = item.command, item.frame
    if kind == MissionType.MISSION:
        if command in FENCE_COMMANDS or command == RALLY_POINT:
            raise ItemRejected(
                mavlink2.MAV_MISSION_ERROR, seq, f"item {seq}: fence/rally item in a mission"
            )
        if command not in MISSION_COMMANDS:
            raise ItemRejected(
                mavlink2.MAV_MISSION_UNSUPPORTED, seq, f"item {seq}: unsupported cmd: {command}"
            )
        needs_position = command in POSITION_COMMANDS or command == (
            mavlink2.MAV_CMD_DO_SET_ROI_LOCATION
        )
        allowed = GLOBAL_FRAMES if needs_position else GLOBAL_FRAMES | {MISSION_FRAME}
    elif kind == MissionType.FENCE:
        if command not in FENCE_COMMANDS:
            raise ItemRejected(
                mavlink2.MAV_MISSION_UNSUPPORTED, seq, f"item {seq}: {command} is not a fence item"
            )
        allowed = GLOBAL_FRAMES
    else:
        if command != RALLY_POINT:
            raise ItemRejected(
                mavlink2.MAV_MISSION_UNSUPPORTED, seq, f"item {seq}: {command} is not a rally point"
            )
        allowed = GLOBAL_FRAMES
    if frame not in allowed:
        raise ItemRejected(
            mavlink2.MAV_MISSION_UNSUPPORTED_FRAME, seq, f"item {seq}: unsupported frame {frame}"
        )
    if frame in GLOBAL_FRAMES:
        _check_coordinates(item, seq, needs_altitude=command != mavlink2.MAV_CMD_NAV_LAND)
    _check_params(item, seq)


def _check_coordinates(item: MissionItem, seq: int, needs_altitude: bool) -> None:
    if abs(item.x) > 900_000_000:
        raise ItemRejected(
            mavlink2.MAV_MISSION_INVALID_PARAM5_X, seq, f"item {seq}: latitude out of range"
        )
    if abs(item.y) > 1_800_000_000:
        raise ItemRejected(
            mavlink2.MAV_MISSION_INVALID_PARAM6_Y, seq, f"item {seq}: longitude out of range"
        )
    if math.isinf(item.z) or (needs_altitude and not math.isfinite(item.z)):
        raise ItemRejected(
            mavlink2.MAV_MISSION_INVALID_PARAM7, seq, f"item {seq}: altitude {item.z}"
        )


def _whole(value: float) -> bool:
    return math.isfinite(value) and value == int(value)


def _check_params(item: MissionItem, seq: int) -> None:
    """Parameters the navigator interprets: values it cannot use are refused."""
    for index, value in enumerate(item.params):
        if math.isinf(value):
            raise ItemRejected(
                mavlink2.MAV_MISSION_INVALID_PARAM1 + index, seq, f"item {seq}: param{index + 1}"
            )
    p1, p2 = item.params[0], item.params[1]
    command = item.command
    bad_param1 = (
        (command in (POLYGON_INCLUSION, POLYGON_EXCLUSION) and not (_whole(p1) and p1 >= 3))
        or (command in (CIRCLE_INCLUSION, CIRCLE_EXCLUSION) and not (p1 >= 0))
        or (command == mavlink2.MAV_CMD_DO_JUMP and not (_whole(p1) and p1 >= 0))
        # NAV_DELAY param1 = -1 selects a time of day (params 2-4): no UTC clock is emulated.
        or (command == mavlink2.MAV_CMD_NAV_DELAY and not (math.isfinite(p1) and p1 >= 0))
        or (command in (mavlink2.MAV_CMD_NAV_WAYPOINT, mavlink2.MAV_CMD_NAV_LOITER_TIME) and p1 < 0)
    )
    if bad_param1:
        result = (
            mavlink2.MAV_MISSION_ERROR
            if command in (POLYGON_INCLUSION, POLYGON_EXCLUSION)
            else mavlink2.MAV_MISSION_INVALID_PARAM1
        )
        raise ItemRejected(result, seq, f"item {seq}: param1 {p1} invalid for command {command}")
    if command == mavlink2.MAV_CMD_DO_JUMP and not (_whole(p2) and p2 >= -1):
        raise ItemRejected(
            mavlink2.MAV_MISSION_INVALID_PARAM2, seq, f"item {seq}: DO_JUMP repeat count {p2}"
        )


def check_fence_plan(items: tuple[MissionItem, ...]) -> None:
    """Raise :class:`ItemRejected` (MAV_MISSION_ERROR) if a complete fence is malformed."""
    try:
        build_fence(items)
    except FenceError as error:
        raise ItemRejected(mavlink2.MAV_MISSION_ERROR, error.seq, str(error)) from error


@dataclass(frozen=True)
class PlanContext:
    """What the feasibility check needs to know about the vehicle."""

    home_lat_lon_alt: tuple[float, float, float] | None
    """Home latitude, longitude (deg) and AMSL altitude (m); None before the vehicle has one."""
    fence: Fence
    """The stored geofence."""
    max_hor_dist_m: float
    """GF_MAX_HOR_DIST (0 = off)."""
    max_ver_dist_m: float
    """GF_MAX_VER_DIST (0 = off)."""
    dist_1wp_m: float
    """MIS_DIST_1WP (0 = off): a farther first waypoint only raises a warning."""


@dataclass(frozen=True)
class Feasibility:
    """Outcome of the feasibility check of a mission."""

    problem: str | None
    """Why the mission cannot be flown (STATUSTEXT), or None when it is valid."""
    warnings: tuple[str, ...] = ()


def mission_feasibility(items: tuple[MissionItem, ...], context: PlanContext) -> Feasibility:
    """PX4's feasibility checker on a stored mission."""
    home = context.home_lat_lon_alt
    warnings: list[str] = []
    first_position = True
    for seq, item in enumerate(items):
        if item.command == mavlink2.MAV_CMD_DO_JUMP and int(item.params[0]) >= len(items):
            return Feasibility(f"Mission rejected: item {seq + 1}: DO_JUMP target out of range")
        if item.command not in POSITION_COMMANDS:
            continue
        if home is None and item.frame in GLOBAL_FRAMES_RELATIVE:
            return Feasibility(f"Mission rejected: No home pos, WP {seq + 1} uses rel alt")
        if not item.has_position:
            continue
        if not context.fence.contains(item.lat_deg, item.lon_deg):
            return Feasibility(f"Geofence violation for waypoint {seq + 1}")
        if home is None:
            continue
        dist = horizontal_distance_m(home[0], home[1], item.lat_deg, item.lon_deg)
        if 0 < context.max_hor_dist_m < dist:
            return Feasibility(
                f"Geofence violation for waypoint {seq + 1}: {dist:.0f} m from home, "
                f"GF_MAX_HOR_DIST {context.max_hor_dist_m:.0f} m"
            )
        height = item.alt_amsl_m(home[2]) - home[2]
        if 0 < context.max_ver_dist_m < height:
            return Feasibility(
                f"Geofence violation for waypoint {seq + 1}: {height:.0f} m above home, "
                f"GF_MAX_VER_DIST {context.max_ver_dist_m:.0f} m"
            )
        if first_position:
            first_position = False
            if 0 < context.dist_1wp_m < dist:
                warnings.append(
                    f"First waypoint too far away: {dist:.0f}m, {context.dist_1wp_m:.0f} max"
                )
    return Feasibility(None, tuple(warnings))


def horizontal_distance_m(lat0: float, lon0: float, lat1: float, lon1: float) -> float:
    """Distance between two nearby points on the local tangent plane of the first, m."""
    ned = geodesy.geodetic_to_ned(np.array([lat1, lon1, 0.0]), np.array([lat0, lon0, 0.0]))
    return float(math.hypot(ned[0], ned[1]))
