"""Camera items of a mission, re-emitted as commands to the vehicle's camera, as PX4 does.

PX4 does not execute a mission's camera items itself: its navigator publishes each one as a
vehicle command addressed to the camera (``Navigator::publish_vehicle_command``: target
component = param1 when it is 1..255, else 100 = MAV_COMP_ID_CAMERA), which the MAVLink links
send to the other components as COMMAND_LONG, and the mission goes on at once. Covered here:
IMAGE_START_CAPTURE (2000), IMAGE_STOP_CAPTURE (2001), VIDEO_START_CAPTURE (2500),
VIDEO_STOP_CAPTURE (2501) and SET_CAMERA_MODE (530).

A single capture (param3 = 1) carries a capture sequence number in param4, counted per vehicle
from 1, so that a camera can tell a retransmission from a new shot (PX4 routes single shots
through its camera_trigger module, whose MAVLink backend numbers them the same way). Distance
triggering (DO_SET_CAM_TRIGG_DIST) needs PX4's camera_trigger module and stays a no-op item.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mission.items import MissionItem

MAV_COMP_ID_CAMERA = mavlink2.MAV_COMP_ID_CAMERA
"""Component the camera commands go to unless the item's param1 names one."""

CAMERA_ITEM_COMMANDS = frozenset(
    {
        mavlink2.MAV_CMD_IMAGE_START_CAPTURE,
        mavlink2.MAV_CMD_IMAGE_STOP_CAPTURE,
        mavlink2.MAV_CMD_VIDEO_START_CAPTURE,
        mavlink2.MAV_CMD_VIDEO_STOP_CAPTURE,
        mavlink2.MAV_CMD_SET_CAMERA_MODE,
    }
)
"""Mission items sent on to the camera."""


@dataclass(frozen=True)
class ComponentCommand:
    """A COMMAND_LONG the autopilot sends to another component of its own system."""

    command: int
    """MAV_CMD."""
    params: tuple[float, float, float, float, float, float, float]
    """param1..param7."""
    target_component: int
    """Component id it is addressed to."""


class CameraItemEmitter:
    """Turns a mission's camera items into commands for the camera; numbers single captures."""

    def __init__(self) -> None:
        self._capture_sequence = 0

    def command_for(self, item: MissionItem) -> ComponentCommand | None:
        """The command to send for ``item``; None when it is not a camera item."""
        if item.command not in CAMERA_ITEM_COMMANDS:
            return None
        p1, p2, p3, p4 = (float(v) for v in item.params)
        target = int(p1) if math.isfinite(p1) and 1 <= p1 <= 255 else MAV_COMP_ID_CAMERA
        if item.command == mavlink2.MAV_CMD_IMAGE_START_CAPTURE and p3 == 1.0:
            self._capture_sequence += 1
            p4 = float(self._capture_sequence)
        return ComponentCommand(
            command=item.command,
            params=(p1, p2, p3, p4, float(item.x), float(item.y), float(item.z)),
            target_component=target,
        )
