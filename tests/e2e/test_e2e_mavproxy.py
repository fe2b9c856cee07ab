"""MAVProxy (``mavproxy.py`` from PyPI) as the ground station on the vehicle's GCS port.

One MAVProxy session for the module, typed into through its stdin: mode changes, ``arm
throttle``, ``takeoff``, ``wp load`` (QGC WPL 110), ``fence load``, ``rally load``, ``ftp list``
and ``ftp get``. Every step waits on MAVProxy's own acknowledgement lines ("Got COMMAND_ACK:
...", "Sent all N ...", "Got MISSION_ACK: ...", "Wrote N bytes") and on the vehicle's state
seen by a raw pymavlink client listening in parallel (HEARTBEAT custom_mode and armed flag,
GLOBAL_POSITION_INT, EXTENDED_SYS_STATE, and the uploaded lists read back with
MISSION_REQUEST_LIST). The tests run in file order on one vehicle.

Mode changes use the ``long DO_SET_MODE 1 MAIN SUB`` commands of the table in docs/cli.md
("MAVProxy as the ground station"), read from the file: MAVProxy's own ``mode NAME`` cannot reach
a PX4 vehicle (see :func:`test_mode_by_name_fails_as_documented`).

MAVProxy talks to a PX4 autopilot the way it does to PX4 SITL: the vehicle's ground-station
link (PX4's normal stream profile) streams from ``--gcs-listen-port`` to ``--gcs-port``, and
MAVProxy (``--master=udpin:127.0.0.1:<port>``) answers to where the stream comes from. The raw
observer sits on the other link, the onboard one (``--listen-port``), as a companion would: what
MAVProxy changes must show there too.
"""

from __future__ import annotations

import contextlib
import math
import re
from functools import cache

import pytest
from e2e_support import (
    REPO_ROOT,
    MavProxy,
    RawLink,
    download_items,
    from_autopilot,
    module_ports,
    running_swarm,
)
from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink2

pytestmark = pytest.mark.e2e

PORTS = module_ports()
ARMED_FLAG = mavlink2.MAV_MODE_FLAG_SAFETY_ARMED
ACK_WAIT_S = 40.0
"""Simulated seconds for an acknowledgement (every wait of this module is simulated time)."""
STARTUP_WAIT_S = 120.0
"""Simulated seconds for MAVProxy to start, detect the vehicle and load its parameters."""
HOME_LAT, HOME_LON = 47.397742, 8.545594
"""Vehicle 1's home (PX4 SITL's, as ``swarmsitl up`` spawns it)."""
DOCS = REPO_ROOT / "docs" / "cli.md"
DOCS_SECTION = "### MAVProxy as the ground station"
DOCS_ROW = re.compile(
    r"^\| [^|`]*\(`(\w+)`\) \| `(long DO_SET_MODE (\d+) (\d+) (\d+))` \| (0x[0-9A-Fa-f]{8}) \|$",
    re.MULTILINE,
)
"""A row of the mode table: | Land (`LAND`) | `long DO_SET_MODE 1 4 6` | 0x06040000 |"""
EARTH_RADIUS_M = 6371000.0


def px4_custom_mode(name: str) -> int:
    """HEARTBEAT.custom_mode of PX4 mode ``name`` as MAVProxy maps it (pymavlink ``px4_map``)."""
    _, main, sub = mavutil.px4_map[name]
    return (main << 16) | (sub << 24)


@cache
def documented_rows() -> dict[str, re.Match]:
    """The rows of docs/cli.md's MAVProxy mode table, by MAVProxy mode name."""
    text = DOCS.read_text()
    assert DOCS_SECTION in text, f"{DOCS} has no section {DOCS_SECTION!r}"
    section = text.split(DOCS_SECTION, 1)[1].split("\n## ", 1)[0]
    return {row.group(1): row for row in DOCS_ROW.finditer(section)}


def documented_command(name: str) -> str:
    """The MAVProxy command docs/cli.md gives for PX4 mode ``name``, e.g. long DO_SET_MODE 1 4 6."""
    rows = documented_rows()
    assert name in rows, f"{DOCS} ({DOCS_SECTION}) gives no command for {name}: {sorted(rows)}"
    return rows[name].group(2)


def distance_m(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Horizontal distance between two nearby points (degrees), flat-earth."""
    north = math.radians(lat2 - lat1) * EARTH_RADIUS_M
    east = math.radians(lon2 - lon1) * EARTH_RADIUS_M * math.cos(math.radians(lat1))
    return math.hypot(north, east)


# --- fixtures --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def swarm(tmp_path_factory):
    out = tmp_path_factory.mktemp("mavproxy") / "run"
    with running_swarm(1, PORTS, out, gcs_port=PORTS.gcs) as s:
        yield s


@pytest.fixture(scope="module")
def link(swarm):
    """A raw observer on the vehicle's onboard link (sysid 245, as MAVSDK)."""
    lk = RawLink(PORTS.listen, swarm.clock)
    lk.send(mavlink2.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3))  # makes the vehicle stream to us
    yield lk
    lk.close()


@pytest.fixture(scope="module")
def mavproxy(swarm, link, tmp_path_factory):
    """MAVProxy connected to vehicle 1, parameters downloaded, vehicle ready to arm."""
    mp = MavProxy(PORTS.gcs, tmp_path_factory.mktemp("mavproxy-logs"), swarm.clock)
    try:
        mp.wait_for(r"Detected vehicle 1:1", timeout_s=STARTUP_WAIT_S)
        mp.wait_for(r"Received \d+ parameters", timeout_s=STARTUP_WAIT_S)
        wait_ready(link)
        yield mp
    finally:
        mp.close()


_UNUSABLE_AFTER: dict[str, str] = {}
"""Test that left the vehicle armed beyond recovery -> why; the module's later tests skip."""


@pytest.fixture(autouse=True)
def disarmed_on_the_ground(request):
    """Each test that drives MAVProxy starts with the vehicle disarmed on the ground.

    The tests share one vehicle; a test that fails in the air leaves it armed. After each such
    test the vehicle is brought back (LAND, then ``disarm force``); a failure there is recorded
    rather than raised (the test has already reported its own), and if the vehicle stays armed
    the later tests skip, naming the test that left it so: one miss fails one test.
    """
    if "mavproxy" not in request.fixturenames:
        yield
        return
    if _UNUSABLE_AFTER:
        (name, why), *_ = _UNUSABLE_AFTER.items()
        pytest.skip(f"the vehicle stayed armed after {name} ({why})")
    mp = request.getfixturevalue("mavproxy")
    lk = request.getfixturevalue("link")
    yield
    try:
        land_and_disarm(mp, lk)
    except (Exception, pytest.fail.Exception) as exc:
        still_armed = True
        with contextlib.suppress(Exception, pytest.fail.Exception):
            still_armed = bool(heartbeat(lk).base_mode & ARMED_FLAG)
        if still_armed:
            _UNUSABLE_AFTER[request.node.name] = str(exc).splitlines()[0]


# --- vehicle state through the raw observer --------------------------------------------------


def heartbeat(lk: RawLink):
    lk.drain()
    return lk.heartbeats(1)[0]


def wait_ready(lk: RawLink) -> None:
    """SYS_STATUS reports GPS and pre-arm checks healthy."""
    ready = mavlink2.MAV_SYS_STATUS_SENSOR_GPS | mavlink2.MAV_SYS_STATUS_PREARM_CHECK
    msg = lk.wait_for(
        lambda m: (
            m.get_type() == "SYS_STATUS" and m.onboard_control_sensors_health & ready == ready
        ),
        timeout_s=60,
    )
    assert msg is not None, "vehicle never became ready to arm"


def wait_heartbeat(lk: RawLink, mp: MavProxy, predicate, what: str, timeout_s: float = ACK_WAIT_S):
    lk.drain()
    hb = lk.wait_for(
        lambda m: m.get_type() == "HEARTBEAT" and from_autopilot(m) and predicate(m),
        timeout_s,
    )
    if hb is None:
        mp.fail(f"vehicle HEARTBEAT never showed {what} within {timeout_s} simulated s")
    return hb


def switch_until_disarmed(lk: RawLink, mp: MavProxy, mode: str, what: str, timeout_s: float):
    """Switch to ``mode`` the documented way, see it in HEARTBEAT, then wait for the disarm
    that ends it (still in ``mode``); the disarmed HEARTBEAT."""
    assert set_mode(mp, mode) == "ACCEPTED", mp.tail()
    custom = px4_custom_mode(mode)
    wait_heartbeat(lk, mp, lambda m: m.custom_mode == custom, mode)
    disarmed = wait_heartbeat(lk, mp, lambda m: not m.base_mode & ARMED_FLAG, what, timeout_s)
    assert disarmed.custom_mode == custom
    return disarmed


def wait_relative_alt(lk: RawLink, mp: MavProxy, above_m: float, timeout_s: float):
    """First GLOBAL_POSITION_INT more than ``above_m`` above home."""
    lk.drain()
    best = -1e9

    def climbed(m) -> bool:
        nonlocal best
        if m.get_type() != "GLOBAL_POSITION_INT":
            return False
        best = max(best, m.relative_alt / 1000.0)
        return m.relative_alt / 1000.0 > above_m

    msg = lk.wait_for(climbed, timeout_s)
    if msg is None:
        mp.fail(
            f"vehicle did not climb above {above_m} m in {timeout_s} simulated s "
            f"(highest {best:.2f} m)"
        )
    return msg


def home_amsl_m(lk: RawLink) -> float:
    lk.drain()
    gpi = lk.wait_for(lambda m: m.get_type() == "GLOBAL_POSITION_INT", 10)
    assert gpi is not None, "no GLOBAL_POSITION_INT"
    return (gpi.alt - gpi.relative_alt) / 1000.0


# --- driving MAVProxy ------------------------------------------------------------------------


def command_ack(mp: MavProxy, command: str, since: int) -> str:
    """The result MAVProxy printed for the next COMMAND_ACK of ``command`` (e.g. DO_SET_MODE)."""
    return mp.wait_for(rf"Got COMMAND_ACK: {command}: (\w+)", since, ACK_WAIT_S).group(1)


def set_mode(mp: MavProxy, name: str) -> str:
    """The documented command for PX4 mode ``name``; returns the DO_SET_MODE result printed.

    ``long DO_SET_MODE 1 MAIN SUB`` as docs/cli.md gives it, not ``mode NAME``: with MAVProxy
    1.8.75 / pymavlink 2.4.50 ModeModule hands the ``px4_map`` tuple to ``set_mode_px4``, which
    packs it as param1 and fails ("required argument is not a float"), sending nothing.
    """
    mark = mp.send(documented_command(name))
    return command_ack(mp, "DO_SET_MODE", mark)


def wait_position(lk: RawLink, mp: MavProxy, predicate, what: str, timeout_s: float):
    """First GLOBAL_POSITION_INT with ``predicate(lat_deg, lon_deg, relative_alt_m)``."""
    lk.drain()
    msg = lk.wait_for(
        lambda m: (
            m.get_type() == "GLOBAL_POSITION_INT"
            and predicate(m.lat * 1e-7, m.lon * 1e-7, m.relative_alt / 1000.0)
        ),
        timeout_s,
    )
    if msg is None:
        mp.fail(f"vehicle never {what} within {timeout_s} simulated s")
    return msg


def set_param(mp: MavProxy, name: str, value: float) -> None:
    """``param set NAME VALUE``, confirmed by reading it back with ``param fetch NAME``."""
    mp.send(f"param set {name} {value}")
    for _ in range(3):
        mark = mp.send(f"param fetch {name}")
        found = mp.wait_for(rf"{name} = ([-\d.]+)", mark, ACK_WAIT_S)
        if float(found.group(1)) == pytest.approx(value):
            return
    mp.fail(f"{name} did not become {value}")


def arm(mp: MavProxy, lk: RawLink) -> None:
    mark = mp.send("arm throttle")
    assert command_ack(mp, "COMPONENT_ARM_DISARM", mark) == "ACCEPTED", mp.tail()
    mp.wait_for(r"\bARMED\b", mark, ACK_WAIT_S)
    wait_heartbeat(lk, mp, lambda m: m.base_mode & ARMED_FLAG, "armed")


def land_and_disarm(mp: MavProxy, lk: RawLink) -> None:
    """``mode LAND``, wait for the landing auto-disarm; ``disarm force`` if it never comes."""
    if not heartbeat(lk).base_mode & ARMED_FLAG:
        return
    set_mode(mp, "LAND")
    lk.drain()
    disarmed = lk.wait_for(
        lambda m: (
            m.get_type() == "HEARTBEAT" and from_autopilot(m) and not m.base_mode & ARMED_FLAG
        ),
        60,
    )
    if disarmed is None:
        mp.send("disarm force")
        wait_heartbeat(lk, mp, lambda m: not m.base_mode & ARMED_FLAG, "disarmed after force")
        mp.fail("vehicle still armed 60 simulated s after LAND (disarmed with 'disarm force')")


def upload(mp: MavProxy, kind: str, path, count: int, plural: str, mission_type: str) -> None:
    """``<kind> load <path>``: MAVProxy sends ``count`` items and the vehicle ACKs them."""
    mark = mp.send(f"{kind} load {path}")
    mp.wait_for(rf"Loaded {count} {plural} from", mark, ACK_WAIT_S)
    mp.wait_for(rf"Sent all {count} {plural}", mark, ACK_WAIT_S)
    result = mp.wait_for(rf"Got MISSION_ACK: {mission_type}: (\w+)", mark, ACK_WAIT_S).group(1)
    assert result == "ACCEPTED", mp.tail()


def same_position(item, lat: float, lon: float) -> bool:
    """``item`` (degE7) is at lat/lon: MAVProxy truncates degrees * 1e7 to an int."""
    return abs(item.x - lat * 1e7) <= 1 and abs(item.y - lon * 1e7) <= 1


def qgc_wpl(items: list[tuple]) -> str:
    """A QGC WPL 110 file: (seq, current, frame, command, p1..p4, lat, lon, alt, autocontinue)."""
    lines = ["QGC WPL 110"] + ["\t".join(str(v) for v in item) for item in items]
    return "\n".join(lines) + "\n"


# --- the tests, in flight order --------------------------------------------------------------


def test_documented_mode_commands_are_px4s():
    """docs/cli.md's MAVProxy mode table: each ``long DO_SET_MODE`` row is base mode 1
    (CUSTOM_MODE_ENABLED) with the main and sub mode pymavlink's ``px4_map`` gives that name, and
    its custom_mode column is the HEARTBEAT value; LAND, RTL, TAKEOFF and LOITER are there."""
    rows = documented_rows()
    assert {"LAND", "RTL", "TAKEOFF", "LOITER"} <= rows.keys(), sorted(rows)
    for name, row in rows.items():
        _, base, main, sub, custom_mode = row.groups()[1:]
        _, px4_main, px4_sub = mavutil.px4_map[name]
        assert int(base) == mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, row.group(0)
        assert (int(main), int(sub)) == (px4_main, px4_sub), row.group(0)
        assert int(custom_mode, 16) == px4_custom_mode(name), row.group(0)


def test_connect_does_not_report_a_fence_breach(mavproxy, link):
    """With no fence loaded, MAVProxy's fence module stays silent (no "fence breach").

    MAVProxy says "fence breach" when a SYS_STATUS lacks MAV_SYS_STATUS_GEOFENCE in
    onboard_control_sensors_health (its fence module starts out "healthy"); PX4 reports the
    geofence healthy unless the geofence check has an error, whether or not a fence exists.
    """
    link.drain()
    statuses = [link.wait_for(lambda m: m.get_type() == "SYS_STATUS", 10) for _ in range(3)]
    assert all(statuses), "no SYS_STATUS"
    health = statuses[-1].onboard_control_sensors_health
    if "fence breach" in mavproxy.output():
        mavproxy.fail(
            "said 'fence breach' without a fence: SYS_STATUS health "
            f"0x{health:08x} lacks MAV_SYS_STATUS_GEOFENCE (0x{mavlink2.MAV_SYS_STATUS_GEOFENCE:x})"
        )


def test_mode_changes_show_in_heartbeat(mavproxy, link):
    """RTL and back to LOITER (Hold) on the ground are ACCEPTED and show in HEARTBEAT.custom_mode;
    POSCTL without RC is DENIED and leaves the mode unchanged."""
    for name in ("RTL", "LOITER"):
        assert set_mode(mavproxy, name) == "ACCEPTED", mavproxy.tail()
        wait_heartbeat(
            link, mavproxy, lambda m, name=name: m.custom_mode == px4_custom_mode(name), name
        )
    assert set_mode(mavproxy, "POSCTL") == "DENIED", mavproxy.tail()
    beats = [heartbeat(link) for _ in range(2)]
    assert [b.custom_mode for b in beats] == [px4_custom_mode("LOITER")] * 2


def test_arm_takeoff_to_amsl_altitude_and_land(mavproxy, link):
    """``arm throttle``; ``takeoff <home AMSL + 10>`` climbs to 10 m and holds; LAND disarms.

    MAVProxy's ``takeoff ALT`` puts ALT into param7 of NAV_TAKEOFF, which PX4 reads as AMSL.
    """
    target = home_amsl_m(link) + 10.0
    arm(mavproxy, link)
    try:
        mark = mavproxy.send(f"takeoff {target:.1f}")
        assert command_ack(mavproxy, "NAV_TAKEOFF", mark) == "ACCEPTED", mavproxy.tail()
        wait_relative_alt(link, mavproxy, 8.0, timeout_s=60)
        ext = link.wait_for(lambda m: m.get_type() == "EXTENDED_SYS_STATE", 10)
        assert ext is not None and ext.landed_state == mavlink2.MAV_LANDED_STATE_IN_AIR
        # Takeoff complete: PX4 switches to Hold (AUTO.LOITER) by itself.
        wait_heartbeat(
            link, mavproxy, lambda m: m.custom_mode == px4_custom_mode("LOITER"), "LOITER", 20
        )
    finally:
        land_and_disarm(mavproxy, link)
    assert heartbeat(link).custom_mode == px4_custom_mode("LAND")


def test_takeoff_below_home_climbs_to_the_minimum_takeoff_altitude(mavproxy, link):
    """``takeoff 10`` (param7 = 10 m AMSL, below the 488 m home) still takes off.

    PX4 raises a takeoff altitude below home + MIS_TAKEOFF_ALT to that minimum ("Using minimum
    takeoff altitude"); the vehicle must climb (> 1.5 m) and not stay on the ground.
    """
    arm(mavproxy, link)
    try:
        mark = mavproxy.send("takeoff 10")
        assert command_ack(mavproxy, "NAV_TAKEOFF", mark) == "ACCEPTED", mavproxy.tail()
        wait_relative_alt(link, mavproxy, 1.5, timeout_s=40)
    finally:
        land_and_disarm(mavproxy, link)


def test_documented_takeoff_then_return_flies_home(mavproxy, link):
    """docs/cli.md's flight: ``long DO_SET_MODE 1 4 2`` (Takeoff) climbs to MIS_TAKEOFF_ALT (set
    to 10 m with ``param set``) and switches to Hold; ``guided`` flies 33 m north; ``long
    DO_SET_MODE 1 4 5`` (Return) shows in HEARTBEAT, flies back, lands within 2 m of the take-off
    point and disarms."""
    start = wait_position(link, mavproxy, lambda *_: True, "sent GLOBAL_POSITION_INT", 10)
    home = (start.lat * 1e-7, start.lon * 1e-7)
    set_param(mavproxy, "MIS_TAKEOFF_ALT", 10.0)
    try:
        arm(mavproxy, link)
        try:
            assert set_mode(mavproxy, "TAKEOFF") == "ACCEPTED", mavproxy.tail()
            takeoff = px4_custom_mode("TAKEOFF")
            wait_heartbeat(link, mavproxy, lambda m: m.custom_mode == takeoff, "TAKEOFF")
            wait_relative_alt(link, mavproxy, 8.0, timeout_s=60)
            loiter = px4_custom_mode("LOITER")
            wait_heartbeat(link, mavproxy, lambda m: m.custom_mode == loiter, "LOITER", 20)

            mark = mavproxy.send(f"guided {home[0] + 0.0003:.7f} {home[1]:.7f} 10")
            assert command_ack(mavproxy, "DO_REPOSITION", mark) == "ACCEPTED", mavproxy.tail()
            wait_position(
                link,
                mavproxy,
                lambda lat, lon, _: distance_m(*home, lat, lon) > 25.0,
                "flew 25 m from home",
                60,
            )

            switch_until_disarmed(link, mavproxy, "RTL", "disarmed after the return", 150)
            landed = wait_position(link, mavproxy, lambda *_: True, "sent GLOBAL_POSITION_INT", 10)
            off_m = distance_m(*home, landed.lat * 1e-7, landed.lon * 1e-7)
            assert off_m < 2.0, f"landed {off_m:.1f} m from the take-off point"
            assert abs(landed.relative_alt / 1000.0) < 0.5, str(landed)
        finally:
            land_and_disarm(mavproxy, link)
    finally:
        set_param(mavproxy, "MIS_TAKEOFF_ALT", 2.5)


def test_documented_land_lands_and_disarms(mavproxy, link):
    """``long DO_SET_MODE 1 4 2`` (Takeoff, to 2.5 m) then ``long DO_SET_MODE 1 4 6`` (Land):
    HEARTBEAT shows LAND, the vehicle descends, reports ON_GROUND and disarms."""
    arm(mavproxy, link)
    try:
        assert set_mode(mavproxy, "TAKEOFF") == "ACCEPTED", mavproxy.tail()
        wait_relative_alt(link, mavproxy, 2.0, timeout_s=40)
        loiter = px4_custom_mode("LOITER")
        wait_heartbeat(link, mavproxy, lambda m: m.custom_mode == loiter, "LOITER", 20)

        switch_until_disarmed(link, mavproxy, "LAND", "disarmed after landing", 60)
        ext = link.wait_for(lambda m: m.get_type() == "EXTENDED_SYS_STATE", 10)
        assert ext is not None and ext.landed_state == mavlink2.MAV_LANDED_STATE_ON_GROUND
    finally:
        land_and_disarm(mavproxy, link)


def test_wp_load_uploads_two_waypoints(mavproxy, link, tmp_path):
    """``wp load`` of a two-waypoint QGC WPL 110 file: 2 items sent, MISSION_ACK ACCEPTED, and the
    vehicle's mission reads back as those 2 waypoints.

    The file has no home line: MAVProxy sends a WPL file verbatim (an ArduPilot-style file's
    seq 0 home line would become PX4's first waypoint).
    """
    wps = [(HOME_LAT + 0.00018, HOME_LON, 10.0), (HOME_LAT + 0.00018, HOME_LON + 0.00027, 12.0)]
    path = tmp_path / "mission.txt"
    relative = mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT
    waypoint = mavlink2.MAV_CMD_NAV_WAYPOINT
    path.write_text(
        qgc_wpl(
            [
                (seq, int(seq == 0), relative, waypoint, 0, 2, 0, 0, lat, lon, alt, 1)
                for seq, (lat, lon, alt) in enumerate(wps)
            ]
        )
    )
    upload(mavproxy, "wp", path, 2, "waypoints", "TYPE_MISSION")
    items = download_items(link, mavlink2.MAV_MISSION_TYPE_MISSION)
    assert len(items) == 2, [str(i) for i in items]
    for item, (lat, lon, alt) in zip(items, wps, strict=True):
        assert item.command == mavlink2.MAV_CMD_NAV_WAYPOINT
        # PX4 answers MISSION_ITEM_INT with the *_INT twin of the uploaded frame.
        assert item.frame in (relative, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT)
        assert same_position(item, lat, lon), str(item)
        assert item.z == pytest.approx(alt)
        assert item.param2 == pytest.approx(2.0)


def test_fence_load_is_acked_and_reads_back(mavproxy, link, tmp_path):
    """``fence load`` of MAVProxy's plain "lat lon" fence file: return point + 4-vertex inclusion
    polygon (5 items, mission_type 1) ACKed and read back; no "fence breach" while inside."""
    d_lat, d_lon = 0.0009, 0.00134  # about 100 m each way
    corners = [
        (HOME_LAT + d_lat, HOME_LON - d_lon),
        (HOME_LAT + d_lat, HOME_LON + d_lon),
        (HOME_LAT - d_lat, HOME_LON + d_lon),
        (HOME_LAT - d_lat, HOME_LON - d_lon),
    ]
    # First line: the return point; last line closes the polygon (MAVProxy drops it).
    points = [(HOME_LAT, HOME_LON), *corners, corners[0]]
    path = tmp_path / "fence.txt"
    path.write_text("".join(f"{lat:.7f} {lon:.7f}\n" for lat, lon in points))
    mark = mavproxy.mark()
    upload(mavproxy, "fence", path, 5, "fence items", "TYPE_FENCE")
    items = download_items(link, mavlink2.MAV_MISSION_TYPE_FENCE)
    assert [i.command for i in items] == [
        mavlink2.MAV_CMD_NAV_FENCE_RETURN_POINT,
        *[mavlink2.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION] * 4,
    ], [str(i) for i in items]
    assert [i.param1 for i in items[1:]] == [4] * 4  # vertex count of the polygon
    for item, (lat, lon) in zip(items, points[:-1], strict=True):
        assert same_position(item, lat, lon), str(item)
    for _ in range(3):  # MAVProxy has seen SYS_STATUS with the fence loaded
        assert link.wait_for(lambda m: m.get_type() == "SYS_STATUS", 10) is not None
    if "fence breach" in mavproxy.output(mark):
        mavproxy.fail("said 'fence breach' on the ground inside the fence")


def test_rally_load_is_acked_and_reads_back(mavproxy, link, tmp_path):
    """``rally load`` of a QGC WPL 110 file of two NAV_RALLY_POINTs (mission_type 2): ACKed and
    read back.

    Not MAVProxy's legacy "RALLY lat lon alt ..." format: its loader stores alt * 1e3 in z.
    """
    points = [(HOME_LAT + 0.00045, HOME_LON, 30.0), (HOME_LAT, HOME_LON + 0.00067, 35.0)]
    relative = mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT
    path = tmp_path / "rally.txt"
    path.write_text(
        qgc_wpl(
            [
                (seq, 0, relative, mavlink2.MAV_CMD_NAV_RALLY_POINT, 0, 0, 0, 0, lat, lon, alt, 0)
                for seq, (lat, lon, alt) in enumerate(points)
            ]
        )
    )
    upload(mavproxy, "rally", path, 2, "rally items", "TYPE_RALLY")
    items = download_items(link, mavlink2.MAV_MISSION_TYPE_RALLY)
    assert [i.command for i in items] == [mavlink2.MAV_CMD_NAV_RALLY_POINT] * 2, [
        str(i) for i in items
    ]
    for item, (lat, lon, alt) in zip(items, points, strict=True):
        assert same_position(item, lat, lon), str(item)
        assert item.z == pytest.approx(alt)


def test_ftp_list_and_get(mavproxy, swarm, tmp_path):
    """``module load ftp``; ``ftp list`` shows the vehicle's root and ``/log``; ``ftp get`` of a
    file placed in ``<run dir>/vehicle1/fs`` arrives byte for byte (a burst download)."""
    content = bytes(range(256)) * 40 + b"tail"
    (swarm.out / "vehicle1" / "fs" / "log" / "notes.bin").write_bytes(content)
    mark = mavproxy.send("module load ftp")
    mavproxy.wait_for(r"Loaded module ftp", mark, ACK_WAIT_S)

    mark = mavproxy.send("ftp list /")
    mavproxy.wait_for(r"Total size", mark, ACK_WAIT_S)
    assert re.search(r"^ D log$", mavproxy.output(mark), re.MULTILINE), mavproxy.tail()

    mark = mavproxy.send("ftp list /log")
    mavproxy.wait_for(r"Total size", mark, ACK_WAIT_S)
    assert re.search(rf"^   notes\.bin\t{len(content)}$", mavproxy.output(mark), re.MULTILINE), (
        mavproxy.tail()
    )

    local = tmp_path / "notes.bin"
    mark = mavproxy.send(f"ftp get /log/notes.bin {local}")
    mavproxy.wait_for(rf"Wrote {len(content)} bytes to", mark, ACK_WAIT_S)
    assert local.read_bytes() == content
