"""Assertions on the reports of the mission clients, shared by the classic and native modules.

Each function states what a client's JSON report must show; on failure the message carries the
report part concerned. Mission, geofence and rally expectations follow MAVSDK_CONTRACT.md
section 7 and PX4 (plans are independent; an infeasible upload is refused and the previous plan
kept).
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

from e2e_support import ClientResult, Swarm
from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink2

MISSION_TOTAL = 3
"""Mission items of the ``mission`` clients (progress counts MissionItems, not MAVLink items)."""
MISSION_COMMANDS = [
    mavlink2.MAV_CMD_NAV_WAYPOINT,
    mavlink2.MAV_CMD_DO_CHANGE_SPEED,
    mavlink2.MAV_CMD_NAV_WAYPOINT,
    mavlink2.MAV_CMD_NAV_WAYPOINT,
    mavlink2.MAV_CMD_NAV_DELAY,
    mavlink2.MAV_CMD_NAV_RETURN_TO_LAUNCH,
]
"""speed -> +DO_CHANGE_SPEED, loiter -> +NAV_DELAY, RTL after mission -> +NAV_RETURN_TO_LAUNCH."""
FENCE_COMMANDS = [mavlink2.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION] * 4 + [
    mavlink2.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION
]
NOT_A_REJECTION = {"SUCCESS", "TIMEOUT", "BUSY", "NO_SYSTEM", "UNKNOWN", "NEXT"}
"""Results that do not come from a MISSION_ACK error of the vehicle."""


MISSION_MESSAGES = [
    "MISSION_COUNT",
    "MISSION_REQUEST_INT",
    "MISSION_REQUEST",
    "MISSION_ITEM_INT",
    "MISSION_ITEM",
    "MISSION_ACK",
    "MISSION_REQUEST_LIST",
    "MISSION_CLEAR_ALL",
    "MISSION_SET_CURRENT",
    "MISSION_ITEM_REACHED",
]


def mission_traffic(tlog: Path) -> str:
    """Mission-protocol messages in a vehicle tlog (both directions), counted, plus STATUSTEXTs.

    MISSION_CURRENT is left out (streamed); an upload that times out shows as MISSION_COUNT from
    system 245 repeated with nothing from system 1.
    """
    if not tlog.is_file():
        return f"{tlog} not written yet"
    counts: Counter = Counter()
    acks: list[str] = []
    texts: list[str] = []
    log = mavutil.mavlink_connection(str(tlog))
    try:
        while (msg := log.recv_match(type=[*MISSION_MESSAGES, "STATUSTEXT"])) is not None:
            kind = msg.get_type()
            if kind == "STATUSTEXT":
                texts.append(msg.text)
                continue
            counts[(kind, msg.get_srcSystem(), getattr(msg, "mission_type", None))] += 1
            if kind == "MISSION_ACK":
                acks.append(f"from {msg.get_srcSystem()}: type {msg.type} ({msg.mission_type})")
    finally:
        log.close()
    lines = [f"  {k} from {src} mission_type {t}: {n}" for (k, src, t), n in sorted(counts.items())]
    lines += [f"  MISSION_ACK {a}" for a in acks[-10:]]
    lines += [f"  STATUSTEXT {t}" for t in texts[-10:]]
    return "\n".join(lines) or "  (no mission messages, no STATUSTEXT)"


def require_ok(result: ClientResult, swarm: Swarm) -> dict:
    """The client's report; fail with its stage, error, stderr and the vehicle's mission traffic."""
    if not result.ok:
        hint = ""
        if "TIMEOUT" in str(result.data.get("error")):
            hint = (
                "\nhint: a transfer TIMEOUT means the vehicle did not answer (MISSION_COUNT ->"
                " MISSION_REQUEST_INT, MISSION_REQUEST_LIST -> MISSION_COUNT, MISSION_CLEAR_ALL ->"
                " MISSION_ACK; MAVSDK_CONTRACT.md section 7)"
            )
        traffic = mission_traffic(swarm.tlog(0))
        raise AssertionError(
            f"{result.describe()}{hint}\n--- mission traffic in {swarm.tlog(0)} ---\n{traffic}"
        )
    return result.data


def _show(part) -> str:
    return json.dumps(part, default=str)


def check_mission_flight(data: dict) -> None:
    """Upload/download round trip, progress to the end with a pause, RTL landing, clear."""
    assert data["download_diff"] == [], _show(data["download_diff"])
    assert data["download_rtl_after_mission"] is True
    assert data["raw_commands"] == MISSION_COMMANDS, data["raw_commands"]

    progress = data["progress"]
    currents = [c for c, _ in progress]
    assert all(t == MISSION_TOTAL for _, t in progress), _show(progress)
    assert currents == sorted(currents), f"progress went backwards: {progress}"
    assert {1, 2, MISSION_TOTAL} <= set(currents), _show(progress)
    assert progress[-1] == [MISSION_TOTAL, MISSION_TOTAL], _show(progress)

    pause = data["pause"]
    assert pause["mode"] == "HOLD", _show(pause)
    assert pause["in_air"] is True, _show(pause)
    assert pause["finished"] is False, _show(pause)
    assert 1 <= pause["progress_at_pause"][0] < MISSION_TOTAL, _show(pause)
    assert pause["progress_after_hold"] == pause["progress_at_pause"], _show(pause)
    modes = data["modes"]
    first_mission = modes.index("MISSION")
    hold = modes.index("HOLD", first_mission)
    assert "MISSION" in modes[hold:], f"mission not resumed after the pause: {modes}"

    final = data["final"]
    assert final["in_air"] is False, _show(final)
    assert final["armed"] is False, _show(final)
    assert final["is_mission_finished"] is True, _show(final)
    assert final["horizontal_from_home_m"] < 2.0, _show(final)
    assert data["items_after_clear"] == 0


def check_raw_plans(data: dict) -> None:
    """Mission, fence and rally round trip; infeasible missions refused; clear keeps the fence."""
    for name, down in data["downloads"].items():
        assert down["count"] == down["uploaded"], f"{name}: {_show(down)}"
        assert down["diff"] == [], f"{name}: {_show(down)}"
    for name, rejection in data["rejections"].items():
        assert rejection["result"] not in NOT_A_REJECTION, f"{name}: {_show(rejection)}"
        # PX4: a bad frame fails the transfer; a mission outside the fence transfers, is found
        # infeasible and Mission mode is refused.
        expected_stage = "upload" if name == "unsupported_frame" else "start"
        assert rejection["stage"] == expected_stage, f"{name}: {_show(rejection)}"
    assert data["mission_after_rejections_diff"] == [], _show(data["mission_after_rejections_diff"])
    assert data["mission_count_after_clear"] == 0
    assert data["geofence_count_after_mission_clear"] == len(FENCE_COMMANDS)


def check_geofence(data: dict) -> None:
    """GeofenceData arrives as MAVSDK encodes it, reads back through the plugin, and clears."""
    raw = data["raw_geofence"]
    assert data["raw_geofence_commands"] == FENCE_COMMANDS, data["raw_geofence_commands"]
    assert raw["diff"] == [], _show(raw)
    global_frames = {mavlink2.MAV_FRAME_GLOBAL, mavlink2.MAV_FRAME_GLOBAL_INT}
    assert set(data["raw_geofence_frames"]) <= global_frames, data["raw_geofence_frames"]
    assert data["plugin_geofence"]["diff"] == [], _show(data["plugin_geofence"])
    assert data["raw_geofence_count_after_clear"] == 0
    assert data["plugin_geofence_after_clear"] == {"polygons": 0, "circles": 0}
