"""Mission items as the vehicle stores them, and the three plans it keeps.

A :class:`MissionItem` is the content of one MISSION_ITEM_INT, independent of the wire: the
MAVLink layer converts messages to and from it. Positions keep the wire's integer degE7 for
global frames (``x``/``y``), exactly as uploaded, so a download returns the same numbers; local
frames (not accepted here) would carry metres.

The vehicle keeps one plan per MAV_MISSION_TYPE (mission, geofence, rally), each replaced as a
whole by an upload, as PX4 does (its dataman holds one of each).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

from pymavlink.dialects.v20 import common as mavlink2


class MissionType(IntEnum):
    """MAV_MISSION_TYPE."""

    MISSION = mavlink2.MAV_MISSION_TYPE_MISSION
    FENCE = mavlink2.MAV_MISSION_TYPE_FENCE
    RALLY = mavlink2.MAV_MISSION_TYPE_RALLY
    ALL = mavlink2.MAV_MISSION_TYPE_ALL
    """Only valid for MISSION_CLEAR_ALL."""


class MissionState(IntEnum):
    """MISSION_STATE reported in MISSION_CURRENT.mission_state."""

    UNKNOWN = 0
    NO_MISSION = 1
    NOT_STARTED = 2
    ACTIVE = 3
    PAUSED = 4
    COMPLETE = 5


MAX_ITEMS: dict[MissionType, int] = {
    MissionType.MISSION: 500,
    MissionType.FENCE: 64,
    MissionType.RALLY: 32,
}
"""Capacity of each plan, items (PX4's dataman: 500 waypoints on a Pixhawk-class board, 64 fence
points, 32 rally points); a larger MISSION_COUNT gets MAV_MISSION_NO_SPACE."""

GLOBAL_FRAMES_AMSL = frozenset({mavlink2.MAV_FRAME_GLOBAL, mavlink2.MAV_FRAME_GLOBAL_INT})
GLOBAL_FRAMES_RELATIVE = frozenset(
    {mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT}
)
GLOBAL_FRAMES = GLOBAL_FRAMES_AMSL | GLOBAL_FRAMES_RELATIVE
MISSION_FRAME = mavlink2.MAV_FRAME_MISSION
"""Frame of items without a position (DO_* commands, RTL)."""


@dataclass(frozen=True)
class MissionItem:
    """One stored item (the fields of MISSION_ITEM_INT except seq, target and mission_type)."""

    command: int
    """MAV_CMD."""
    frame: int
    """MAV_FRAME of x, y, z."""
    params: tuple[float, float, float, float]
    """param1..param4 as sent."""
    x: int
    """Latitude, degE7 (global frames)."""
    y: int
    """Longitude, degE7 (global frames)."""
    z: float
    """Altitude, m: AMSL or above home depending on ``frame``."""
    autocontinue: bool = True
    """Continue with the next item once this one completes."""

    @property
    def lat_deg(self) -> float:
        """Latitude, degrees."""
        return self.x * 1e-7

    @property
    def lon_deg(self) -> float:
        """Longitude, degrees."""
        return self.y * 1e-7

    @property
    def has_position(self) -> bool:
        """A global frame with a non-zero latitude/longitude (0/0 means "here" in PX4)."""
        return self.frame in GLOBAL_FRAMES and (self.x != 0 or self.y != 0)

    def alt_amsl_m(self, home_alt_amsl_m: float) -> float:
        """The item's altitude AMSL; NaN when it has none."""
        if not math.isfinite(self.z) or self.frame not in GLOBAL_FRAMES:
            return math.nan
        if self.frame in GLOBAL_FRAMES_RELATIVE:
            return home_alt_amsl_m + self.z
        return self.z


class MissionStore:
    """The vehicle's mission, geofence and rally plans and its current mission item."""

    def __init__(self) -> None:
        self._plans: dict[MissionType, tuple[MissionItem, ...]] = {kind: () for kind in MAX_ITEMS}
        self.version = 0
        """Incremented on every change of any plan (consumers rebuild derived state)."""

    def items(self, kind: MissionType) -> tuple[MissionItem, ...]:
        """The stored items of one plan."""
        return self._plans[MissionType(kind)]

    def replace(self, kind: MissionType, items: tuple[MissionItem, ...]) -> None:
        """Store a whole plan (an upload) or an empty one (a clear)."""
        kind = MissionType(kind)
        if len(items) > MAX_ITEMS[kind]:
            raise ValueError(f"{len(items)} items exceed the {kind.name} capacity")
        self._plans[kind] = tuple(items)
        self.version += 1
