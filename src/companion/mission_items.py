"""MAVSDK mission items as the shipped companions fly them: waypoints at a height above home.

A survey mission is a row of fly-through waypoints at the survey speed and height, the heading
left to the autopilot (it faces the direction of travel), no gimbal or camera action; a stop is
the same item held for ``hold_s``. Written once for every program that uploads missions.
"""

from __future__ import annotations

import math
from typing import Any


def waypoint_item(
    item_cls: Any,
    lat_deg: float,
    lon_deg: float,
    altitude_m: float,
    speed_m_s: float,
    acceptance_m: float,
    hold_s: float = 0.0,
) -> Any:
    """A mission item (``item_cls``: mavsdk's ``MissionItem``) at ``altitude_m`` above home.

    Fly-through when ``hold_s`` is 0, else a stop of ``hold_s`` seconds there.
    """
    return item_cls(
        latitude_deg=float(lat_deg),
        longitude_deg=float(lon_deg),
        relative_altitude_m=float(altitude_m),
        speed_m_s=float(speed_m_s),
        is_fly_through=hold_s <= 0.0,
        gimbal_pitch_deg=math.nan,
        gimbal_yaw_deg=math.nan,
        camera_action=item_cls.CameraAction.NONE,
        loiter_time_s=float(hold_s),
        camera_photo_interval_s=math.nan,
        acceptance_radius_m=float(acceptance_m),
        yaw_deg=math.nan,  # face the direction of travel
        camera_photo_distance_m=math.nan,
        vehicle_action=item_cls.VehicleAction.NONE,
    )
