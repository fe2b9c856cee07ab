"""Plans (mission, geofence, rally) shared by the mission clients, and how to compare them.

Everything is placed in metres north/east of the vehicle's home and converted to degrees with
pymap3d, so the plans follow wherever the emulator puts home. Raw items are plain dicts with the
field names of MAVSDK's ``mission_raw.MissionItem`` (identical in ``mavsdk_grpc`` and in the 4.x
native ``mavsdk``), built into either API's class with :func:`build`.

The MAVSDK calls used by the raw and geofence flows have the same names and arguments in both
APIs (``upload_mission``, ``upload_geofence``, ``upload_rally_points``, ``download_mission``,
``download_geofence``, ``download_rallypoints``, ``clear_mission``; ``geofence.upload_geofence``,
``download_geofence``, ``clear_geofence``), so :func:`raw_plans_flow` and :func:`geofence_flow`
drive both; only the error classes differ (:func:`result_name` reads either).
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import pymap3d
from _common import Report
from pymavlink.dialects.v20 import common as mavlink2

NAN = math.nan
RAW_FIELDS = (
    "seq",
    "frame",
    "command",
    "current",
    "autocontinue",
    "param1",
    "param2",
    "param3",
    "param4",
    "x",
    "y",
    "z",
    "mission_type",
)
"""Fields of a MISSION_ITEM_INT as MAVSDK's mission_raw exposes them."""

MISSION_FIELDS = (
    "latitude_deg",
    "longitude_deg",
    "relative_altitude_m",
    "speed_m_s",
    "is_fly_through",
    "loiter_time_s",
    "acceptance_radius_m",
    "yaw_deg",
    "camera_action",
    "vehicle_action",
)
"""Fields of mission.MissionItem that a download must give back as uploaded."""

DEG_TOLERANCE = 1.5e-7
"""Latitude/longitude round trip through degE7 integers, deg."""
FLOAT_TOLERANCE = 1e-4
"""Round trip of a float through float32, relative."""

WAYPOINTS = (
    # north m, east m, relative alt m, speed m/s, fly-through, loiter s
    (10.0, 0.0, 6.0, 3.0, False, NAN),
    (10.0, 10.0, 7.0, NAN, True, NAN),
    (0.0, 10.0, 8.0, NAN, False, 2.0),
)
"""The mission of the ``mission`` clients: a 10 m square corner, all within 15 m of home."""
FENCE_HALF_SIDE_M = 30.0
"""Half side of the square inclusion polygon around home, m."""
EXCLUSION_CENTRE_NE_M = (-15.0, -15.0)
EXCLUSION_RADIUS_M = 5.0
RALLY_NE_M = ((-10.0, 10.0), (10.0, -10.0))
RALLY_ALT_M = 10.0


def latlon(ref: tuple[float, float, float], north: float, east: float) -> tuple[float, float]:
    """Latitude and longitude (deg) of the point ``north``/``east`` metres from ``ref``."""
    lat, lon, _ = pymap3d.ned2geodetic(north, east, 0.0, *ref)
    return float(lat), float(lon)


def deg_e7(deg: float) -> int:
    return round(deg * 1e7)


# --- mission plan (mission plugin) -----------------------------------------------------------


def mission_items(item_cls, ref: tuple[float, float, float]) -> list:
    """:data:`WAYPOINTS` as ``item_cls`` (mission.MissionItem of either API)."""
    items = []
    for north, east, alt, speed, fly_through, loiter in WAYPOINTS:
        lat, lon = latlon(ref, north, east)
        items.append(
            item_cls(
                latitude_deg=lat,
                longitude_deg=lon,
                relative_altitude_m=alt,
                speed_m_s=speed,
                is_fly_through=fly_through,
                gimbal_pitch_deg=NAN,
                gimbal_yaw_deg=NAN,
                camera_action=item_cls.CameraAction.NONE,
                loiter_time_s=loiter,
                camera_photo_interval_s=1.0,
                acceptance_radius_m=1.0,
                yaw_deg=NAN,
                camera_photo_distance_m=NAN,
                vehicle_action=item_cls.VehicleAction.NONE,
            )
        )
    return items


def mission_item_dict(item) -> dict:
    """The compared fields of a mission.MissionItem (enums by name)."""
    out = {}
    for name in MISSION_FIELDS:
        value = getattr(item, name)
        out[name] = value.name if hasattr(value, "name") else value
    return out


# --- raw items (mission_raw plugin) ----------------------------------------------------------


def raw(seq: int, frame: int, command: int, **fields) -> dict:
    """One raw item; ``current`` is 1 for seq 0 (MAVSDK requires exactly one current item)."""
    item = {
        "seq": seq,
        "frame": frame,
        "command": command,
        "current": int(seq == 0),
        "autocontinue": 1,
        "param1": 0.0,
        "param2": 0.0,
        "param3": 0.0,
        "param4": 0.0,
        "x": 0,
        "y": 0,
        "z": 0.0,
        "mission_type": mavlink2.MAV_MISSION_TYPE_MISSION,
    }
    item.update(fields)
    return item


def raw_waypoint(seq: int, ref, north: float, east: float, alt: float, **fields) -> dict:
    lat, lon = latlon(ref, north, east)
    return raw(
        seq,
        mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        mavlink2.MAV_CMD_NAV_WAYPOINT,
        param1=0.0,  # hold s
        param2=1.0,  # acceptance radius m
        param4=NAN,  # yaw: keep
        x=deg_e7(lat),
        y=deg_e7(lon),
        z=alt,
        **fields,
    )


def raw_rtl(seq: int) -> dict:
    return raw(seq, mavlink2.MAV_FRAME_MISSION, mavlink2.MAV_CMD_NAV_RETURN_TO_LAUNCH)


def raw_mission(ref) -> list[dict]:
    """Waypoint, speed change, waypoint, RTL: inside the fence of :func:`raw_fence`."""
    return [
        raw_waypoint(0, ref, 8.0, 0.0, 6.0),
        raw(
            1,
            mavlink2.MAV_FRAME_MISSION,
            mavlink2.MAV_CMD_DO_CHANGE_SPEED,
            param1=1.0,
            param2=3.0,
            param3=-1.0,
            z=NAN,
        ),
        raw_waypoint(2, ref, 8.0, 8.0, 7.0),
        raw_rtl(3),
    ]


def raw_fence(ref) -> list[dict]:
    """A square inclusion polygon (4 vertices) around home and an exclusion circle inside it."""
    fence_type = mavlink2.MAV_MISSION_TYPE_FENCE
    h = FENCE_HALF_SIDE_M
    corners = ((h, h), (h, -h), (-h, -h), (-h, h))
    items = []
    for seq, (north, east) in enumerate(corners):
        lat, lon = latlon(ref, north, east)
        items.append(
            raw(
                seq,
                mavlink2.MAV_FRAME_GLOBAL_INT,
                mavlink2.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                autocontinue=0,
                param1=float(len(corners)),  # vertex count
                x=deg_e7(lat),
                y=deg_e7(lon),
                mission_type=fence_type,
            )
        )
    lat, lon = latlon(ref, *EXCLUSION_CENTRE_NE_M)
    items.append(
        raw(
            len(corners),
            mavlink2.MAV_FRAME_GLOBAL_INT,
            mavlink2.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION,
            autocontinue=0,
            param1=EXCLUSION_RADIUS_M,
            x=deg_e7(lat),
            y=deg_e7(lon),
            mission_type=fence_type,
        )
    )
    return items


def raw_rally(ref) -> list[dict]:
    items = []
    for seq, (north, east) in enumerate(RALLY_NE_M):
        lat, lon = latlon(ref, north, east)
        items.append(
            raw(
                seq,
                mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                mavlink2.MAV_CMD_NAV_RALLY_POINT,
                autocontinue=0,
                x=deg_e7(lat),
                y=deg_e7(lon),
                z=RALLY_ALT_M,
                mission_type=mavlink2.MAV_MISSION_TYPE_RALLY,
            )
        )
    return items


def infeasible_missions(ref) -> dict[str, list[dict]]:
    """Missions PX4 refuses once :func:`raw_fence` is set.

    ``unsupported_frame`` is refused by the transfer itself (MISSION_ACK with an error, the stored
    mission unchanged); the others transfer fine and are then found infeasible by the vehicle's
    feasibility check, as PX4 does: Mission mode is refused.
    """
    local = raw(
        1,
        mavlink2.MAV_FRAME_LOCAL_NED,
        mavlink2.MAV_CMD_NAV_WAYPOINT,
        param2=1.0,
        x=50_000,  # local frames: m * 1e4
        y=0,
        z=-6.0,
    )
    return {
        "unsupported_frame": [raw_waypoint(0, ref, 8.0, 0.0, 6.0), local, raw_rtl(2)],
        "outside_inclusion_polygon": [
            raw_waypoint(0, ref, 8.0, 0.0, 6.0),
            raw_waypoint(1, ref, 150.0, 0.0, 6.0),
            raw_rtl(2),
        ],
        "inside_exclusion_circle": [
            raw_waypoint(0, ref, 8.0, 0.0, 6.0),
            raw_waypoint(1, ref, *EXCLUSION_CENTRE_NE_M, 6.0),
            raw_rtl(2),
        ],
    }


# --- comparison ------------------------------------------------------------------------------


def same(a, b, tolerance: float) -> bool:
    if isinstance(a, float) or isinstance(b, float):
        a, b = float(a), float(b)
        if math.isnan(a) or math.isnan(b):
            return math.isnan(a) and math.isnan(b)
        return abs(a - b) <= tolerance * max(1.0, abs(a))
    return a == b


def diff(uploaded: list[dict], downloaded: list[dict]) -> list[str]:
    """Human-readable differences between two lists of item dicts (empty: identical)."""
    out = []
    if len(uploaded) != len(downloaded):
        out.append(f"count {len(uploaded)} uploaded, {len(downloaded)} downloaded")
    for i, (up, down) in enumerate(zip(uploaded, downloaded, strict=False)):
        for name, want in up.items():
            got = down.get(name)
            tolerance = DEG_TOLERANCE if name.endswith("_deg") else FLOAT_TOLERANCE
            if not same(want, got, tolerance):
                out.append(f"item {i} {name}: uploaded {want!r}, downloaded {got!r}")
    return out


def raw_dict(item) -> dict:
    return {name: getattr(item, name) for name in RAW_FIELDS}


def build(item_cls, dicts: list[dict]) -> list:
    """Raw item dicts as ``item_cls`` (mission_raw.MissionItem of either API)."""
    return [item_cls(**d) for d in dicts]


def result_name(exc: BaseException) -> str:
    """Result enum name of a MAVSDK plugin error (classic ``_result.result``, native ``result``)."""
    wrapped = getattr(exc, "_result", None)
    result = wrapped.result if wrapped is not None else getattr(exc, "result", None)
    return getattr(result, "name", str(result))


# --- flows shared by the classic and the native API -------------------------------------------


async def raw_plans_flow(r: Report, mission_raw, item_cls, error_cls, ref) -> None:
    """Upload mission, fence and rally; download and compare; infeasible uploads; clear."""
    plans = {
        "mission": (raw_mission(ref), mission_raw.upload_mission, mission_raw.download_mission),
        "geofence": (raw_fence(ref), mission_raw.upload_geofence, mission_raw.download_geofence),
        "rally": (
            raw_rally(ref),
            mission_raw.upload_rally_points,
            mission_raw.download_rallypoints,
        ),
    }
    for name, (items, upload, _) in plans.items():
        r.stage(f"upload_{name}")
        await upload(build(item_cls, items))
    downloads = {}
    r["downloads"] = downloads
    for name, (items, _, download) in plans.items():
        r.stage(f"download_{name}")
        got = [raw_dict(i) for i in await download()]
        downloads[name] = {"count": len(got), "uploaded": len(items), "diff": diff(items, got)}

    r.stage("infeasible")
    rejections = {}
    r["rejections"] = rejections
    for name, items in infeasible_missions(ref).items():
        try:
            await mission_raw.upload_mission(build(item_cls, items))
        except error_cls as exc:
            rejections[name] = {"stage": "upload", "result": result_name(exc)}
            if name == "unsupported_frame":
                kept = [raw_dict(i) for i in await mission_raw.download_mission()]
                r["mission_after_rejections_diff"] = diff(plans["mission"][0], kept)
            continue
        try:
            await mission_raw.start_mission()
            rejections[name] = {"stage": "start", "result": "SUCCESS"}
            await mission_raw.pause_mission()
        except error_cls as exc:
            rejections[name] = {"stage": "start", "result": result_name(exc)}

    r.stage("clear_mission")
    await mission_raw.clear_mission()
    r["mission_count_after_clear"] = len(await mission_raw.download_mission())
    r["geofence_count_after_mission_clear"] = len(await mission_raw.download_geofence())


def geofence_data(types: SimpleNamespace, ref):
    """GeofenceData of :func:`raw_fence`'s shapes, built with either API's geofence types."""
    h = FENCE_HALF_SIDE_M
    corners = ((h, h), (h, -h), (-h, -h), (-h, h))
    points = [types.Point(*latlon(ref, n, e)) for n, e in corners]
    circle = types.Circle(
        point=types.Point(*latlon(ref, *EXCLUSION_CENTRE_NE_M)),
        radius=EXCLUSION_RADIUS_M,
        fence_type=types.FenceType.EXCLUSION,
    )
    polygon = types.Polygon(points=points, fence_type=types.FenceType.INCLUSION)
    return types.GeofenceData(polygons=[polygon], circles=[circle])


def geofence_dict(data) -> dict:
    """GeofenceData as plain lists (fence types by name)."""
    return {
        "polygons": [
            {
                "fence_type": p.fence_type.name,
                "points": [[q.latitude_deg, q.longitude_deg] for q in p.points],
            }
            for p in data.polygons
        ],
        "circles": [
            {
                "fence_type": c.fence_type.name,
                "point": [c.point.latitude_deg, c.point.longitude_deg],
                "radius": c.radius,
            }
            for c in data.circles
        ],
    }


def geofence_diff(want: dict, got: dict) -> list[str]:
    out = []
    for kind in ("polygons", "circles"):
        if len(want[kind]) != len(got[kind]):
            out.append(f"{kind}: {len(want[kind])} uploaded, {len(got[kind])} downloaded")
    for i, (a, b) in enumerate(zip(want["polygons"], got["polygons"], strict=False)):
        if a["fence_type"] != b["fence_type"] or len(a["points"]) != len(b["points"]):
            out.append(f"polygon {i}: uploaded {a}, downloaded {b}")
            continue
        for j, (p, q) in enumerate(zip(a["points"], b["points"], strict=True)):
            if not all(same(u, v, DEG_TOLERANCE) for u, v in zip(p, q, strict=True)):
                out.append(f"polygon {i} vertex {j}: uploaded {p}, downloaded {q}")
    for i, (a, b) in enumerate(zip(want["circles"], got["circles"], strict=False)):
        ok = (
            a["fence_type"] == b["fence_type"]
            and all(same(u, v, DEG_TOLERANCE) for u, v in zip(a["point"], b["point"], strict=True))
            and same(float(a["radius"]), float(b["radius"]), FLOAT_TOLERANCE)
        )
        if not ok:
            out.append(f"circle {i}: uploaded {a}, downloaded {b}")
    return out


async def geofence_flow(r: Report, geofence, mission_raw, types: SimpleNamespace, ref) -> None:
    """Geofence plugin upload; read back raw and through the plugin; clear; read back again."""
    data = geofence_data(types, ref)
    r.stage("upload_geofence")
    await geofence.upload_geofence(data)

    r.stage("download_raw_geofence")
    got_raw = [raw_dict(i) for i in await mission_raw.download_geofence()]
    # The plugin's frame depends on the MAVSDK version: mavsdk_server 4.0.5 sends GLOBAL_INT (5),
    # the native 4.1.0 library GLOBAL (0); both are AMSL global frames, checked by the test.
    r["raw_geofence_frames"] = [i.pop("frame") for i in got_raw]
    want_raw = [{k: v for k, v in i.items() if k != "frame"} for i in raw_fence(ref)]
    r["raw_geofence"] = {"count": len(got_raw), "diff": diff(want_raw, got_raw)}
    r["raw_geofence_commands"] = [i["command"] for i in got_raw]

    r.stage("download_geofence")
    want = geofence_dict(data)
    got = geofence_dict(await geofence.download_geofence())
    r["plugin_geofence"] = {"downloaded": got, "diff": geofence_diff(want, got)}

    r.stage("clear_geofence")
    await geofence.clear_geofence()
    r["raw_geofence_count_after_clear"] = len(await mission_raw.download_geofence())
    after = geofence_dict(await geofence.download_geofence())
    r["plugin_geofence_after_clear"] = {k: len(v) for k, v in after.items()}
