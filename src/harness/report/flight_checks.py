"""Assertion helpers over a :class:`~harness.report.flight_log.FlightLog`, for tests of flights.

Each check is a pure function returning a :class:`CheckResult` (``ok``, the measured ``value`` with
its ``unit``, and a ``message`` a person understands: which vehicle, when, how far); each has an
``assert_*`` form raising :class:`AssertionError` with that message. Vehicles are given by their
0-based index (truth.csv's vehicle column); messages name them ``vehicleN`` (N = index + 1, the
sysid and the run directory's file names). Times are simulation seconds.

    log = FlightLog.load(run_dir)
    assert_waypoints_reached(log, 0, [(0, 0, 10), (50, 0, 10)], tolerance_m=2.0)
    assert_min_separation(log, at_least_m=3.0, airborne_only=True)
    assert_landed_and_disarmed(log)
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import ArrayLike
from shapely.geometry import Polygon

from harness.report.flight_log import ON_GROUND, FlightLog, StatusText, VehicleLog

FAILSAFE_TEXTS: dict[str, str] = {
    "failsafe_action": "Failsafe activated: switching to",
    "offboard_lost": "Offboard signal lost: switching to",
    "datalink_lost": "Connection to ground station lost",
    "battery_low": "Low battery level, return advised",
    "battery_critical": "Critical battery level, land now",
    "battery_emergency": "Emergency battery level, land immediately",
    "gps_lost": "No global position: GPS lost",
    "geofence": "Geofence violation",
}
"""The failsafe STATUSTEXTs the autopilot emulator sends (autopilot_emu/failsafe.py and the
commander's offboard-loss failsafe), by name: a text is a failsafe text when it starts with one of
these. Recoveries ("GCS connection regained", "Geofence OK", ...) are not failsafes, nor is a
data-link loss announced while the vehicle is disarmed: PX4 announces it, but NAV_DLL_ACT acts in
the air only (a companion that ends after landing leaves its vehicle without a ground station)."""


@dataclass(frozen=True)
class CheckResult:
    """Outcome of one check: whether it holds, the number it measured, and why."""

    ok: bool
    value: float
    """The measured quantity (closest approach, max tilt, ...), in ``unit``."""
    unit: str
    message: str

    def __bool__(self) -> bool:
        return self.ok


def _raise_unless(result: CheckResult) -> CheckResult:
    if not result.ok:
        raise AssertionError(result.message)
    return result


def _require_samples(vehicle: VehicleLog) -> None:
    if len(vehicle.track) == 0:
        raise ValueError(f"{vehicle.name} has no truth samples")


# -- waypoints ---------------------------------------------------------------------------------


def waypoints_reached(
    log: FlightLog,
    vehicle: int,
    waypoints_enu_m: ArrayLike,
    tolerance_m: float,
    in_order: bool = True,
) -> CheckResult:
    """The true track passes within ``tolerance_m`` of each waypoint (world ENU, m).

    Waypoints of two coordinates (east, north) are checked horizontally. With ``in_order`` each
    waypoint must be reached at or after the time the previous one was. ``value`` is how many
    waypoints were reached (counting up to the first miss when in order).
    """
    v = log.vehicle(vehicle)
    _require_samples(v)
    wps = np.atleast_2d(np.asarray(waypoints_enu_m, dtype=float))
    if wps.shape[1] not in (2, 3):
        raise ValueError(f"waypoints_enu_m must be (K, 2) or (K, 3), got shape {wps.shape}")
    dims = wps.shape[1]
    pos, t = v.track.enu_m[:, :dims], v.track.time_s
    start, reached, notes = 0, 0, []
    for k, wp in enumerate(wps):
        dist = np.linalg.norm(pos[start:] - wp, axis=1)
        hit = np.flatnonzero(dist <= tolerance_m)
        if hit.size:
            reached += 1
            if in_order:
                start += int(hit[0])
            continue
        closest = int(np.argmin(dist))
        where = f" after t = {t[start]:.1f} s" if in_order and start else ""
        notes.append(
            f"waypoint {k} {_fmt(wp)} missed: closest approach{where} {dist[closest]:.2f} m "
            f"at t = {t[start + closest]:.1f} s (tolerance {tolerance_m:g} m)"
        )
        if in_order:
            break
    ok = reached == len(wps)
    message = (
        f"{v.name} reached all {len(wps)} waypoints within {tolerance_m:g} m"
        if ok
        else f"{v.name} reached {reached} of {len(wps)} waypoints; " + "; ".join(notes)
    )
    return CheckResult(ok, float(reached), "waypoints", message)


def assert_waypoints_reached(
    log: FlightLog,
    vehicle: int,
    waypoints_enu_m: ArrayLike,
    tolerance_m: float,
    in_order: bool = True,
) -> CheckResult:
    """:func:`waypoints_reached`, raising AssertionError when it fails."""
    return _raise_unless(waypoints_reached(log, vehicle, waypoints_enu_m, tolerance_m, in_order))


# -- separation --------------------------------------------------------------------------------


@dataclass(frozen=True)
class ClosestApproach:
    """The smallest true distance between two vehicles at the same instant."""

    distance_m: float
    """inf when no two vehicles were sampled (airborne) at the same time."""
    time_s: float
    first: int
    """0-based index of one vehicle of the pair (-1 if none)."""
    second: int


def closest_approach(log: FlightLog, airborne_only: bool = False) -> ClosestApproach:
    """Smallest 3-D distance between any two vehicles over their common truth samples.

    The recorder samples all vehicles at the same instants; samples are matched on time. With
    ``airborne_only`` a pair counts only while both are in the air (landed_state IN_AIR/LANDING).
    """
    grid = np.unique(np.concatenate([v.track.time_s for v in log.vehicles] or [np.zeros(0)]))
    n = len(log.vehicles)
    pos = np.full((n, len(grid), 3), np.nan)
    for v in log.vehicles:
        tr = v.track
        at = np.searchsorted(grid, tr.time_s)
        keep = tr.airborne if airborne_only else np.ones(len(tr), bool)
        pos[v.index, at[keep]] = tr.enu_m[keep]
    best = ClosestApproach(float("inf"), float("nan"), -1, -1)
    for i in range(n - 1):
        dist = np.linalg.norm(pos[i + 1 :] - pos[i], axis=2)  # (n - i - 1, T)
        if np.all(np.isnan(dist)):
            continue
        j, k = np.unravel_index(np.nanargmin(dist), dist.shape)
        if dist[j, k] < best.distance_m:
            best = ClosestApproach(float(dist[j, k]), float(grid[k]), i, i + 1 + int(j))
    return best


def min_separation(log: FlightLog, at_least_m: float, airborne_only: bool = False) -> CheckResult:
    """No two vehicles came closer than ``at_least_m`` (true positions, same instants)."""
    c = closest_approach(log, airborne_only)
    scope = " while both airborne" if airborne_only else ""
    if c.first < 0:
        return CheckResult(
            True, c.distance_m, "m", f"no two vehicles sampled at the same time{scope}"
        )
    pair = f"vehicle{c.first + 1} and vehicle{c.second + 1}"
    ok = c.distance_m >= at_least_m
    verdict = "at least" if ok else "below the required"
    return CheckResult(
        ok,
        c.distance_m,
        "m",
        f"closest approach{scope}: {pair} {c.distance_m:.2f} m apart at t = {c.time_s:.1f} s "
        f"({verdict} {at_least_m:g} m)",
    )


def assert_min_separation(
    log: FlightLog, at_least_m: float, airborne_only: bool = False
) -> CheckResult:
    """:func:`min_separation`, raising AssertionError when it fails."""
    return _raise_unless(min_separation(log, at_least_m, airborne_only))


# -- attitude, altitude ------------------------------------------------------------------------


def max_tilt(log: FlightLog, at_most_deg: float, vehicle: int | None = None) -> CheckResult:
    """The true tilt (angle of the body z axis from vertical) never exceeded ``at_most_deg``."""
    worst = (-np.inf, "", 0.0)
    for v in log.selected(vehicle):
        if len(v.track) == 0:
            continue
        tilt = v.track["tilt_deg"]
        k = int(np.nanargmax(tilt)) if np.any(np.isfinite(tilt)) else 0
        if tilt[k] > worst[0]:
            worst = (float(tilt[k]), v.name, float(v.track.time_s[k]))
    value, name, t = worst
    if not name:
        return CheckResult(True, 0.0, "deg", "no tilt samples")
    ok = value <= at_most_deg
    limit = "within" if ok else "over"
    return CheckResult(
        ok,
        value,
        "deg",
        f"max tilt {value:.1f} deg ({name} at t = {t:.1f} s), {limit} "
        f"the {at_most_deg:g} deg limit",
    )


def assert_max_tilt(log: FlightLog, at_most_deg: float, vehicle: int | None = None) -> CheckResult:
    """:func:`max_tilt`, raising AssertionError when it fails."""
    return _raise_unless(max_tilt(log, at_most_deg, vehicle))


def reached_altitude(
    log: FlightLog,
    vehicle: int,
    altitude_m: float,
    tolerance_m: float = 0.5,
    relative_to_start: bool = False,
) -> CheckResult:
    """The vehicle's true height reached ``altitude_m`` (minus ``tolerance_m``).

    Height is world up (m above the ground or sea datum), or above its first sample with
    ``relative_to_start`` (e.g. a takeoff from a helideck). ``value`` is the highest height.
    """
    v = log.vehicle(vehicle)
    _require_samples(v)
    up = v.track["up_m"] - (v.track["up_m"][0] if relative_to_start else 0.0)
    top = float(np.nanmax(up))
    above = " above its start" if relative_to_start else ""
    reached = np.flatnonzero(up >= altitude_m - tolerance_m)
    if reached.size:
        t = v.track.time_s[reached[0]]
        return CheckResult(
            True,
            top,
            "m",
            f"{v.name} reached {altitude_m:g} m{above} (-{tolerance_m:g} m) at t = {t:.1f} s; "
            f"highest {top:.2f} m",
        )
    k = int(np.nanargmax(up))
    return CheckResult(
        False,
        top,
        "m",
        f"{v.name} never reached {altitude_m:g} m{above} (tolerance {tolerance_m:g} m): highest "
        f"{top:.2f} m at t = {v.track.time_s[k]:.1f} s, {altitude_m - top:.2f} m short",
    )


def assert_reached_altitude(
    log: FlightLog,
    vehicle: int,
    altitude_m: float,
    tolerance_m: float = 0.5,
    relative_to_start: bool = False,
) -> CheckResult:
    """:func:`reached_altitude`, raising AssertionError when it fails."""
    return _raise_unless(reached_altitude(log, vehicle, altitude_m, tolerance_m, relative_to_start))


# -- end state ---------------------------------------------------------------------------------


def landed_and_disarmed(
    log: FlightLog,
    vehicle: int | None = None,
    max_vertical_speed_m_s: float = 0.3,
    crashed: Collection[int] = (),
) -> CheckResult:
    """At its last truth sample each vehicle is on the ground, disarmed and not moving vertically.

    On the ground = the autopilot's landed_state ON_GROUND; disarmed = the armed column; and the
    true vertical speed within ``max_vertical_speed_m_s``. ``value`` counts vehicles that are not.
    ``crashed``: vehicles a fault terminated (0-based); they must only be disarmed (a crash is no
    landing, and one late in the run may still be falling at its end).
    """
    problems = []
    for v in log.selected(vehicle):
        if len(v.track) == 0:
            problems.append(f"{v.name} has no truth samples")
            continue
        c = v.track.columns
        t = float(c["time_s"][-1])
        issues = []
        if c["armed"][-1] > 0.5:
            issues.append("still armed")
        if v.index not in crashed:
            if c["landed_state"][-1] != ON_GROUND:
                issues.insert(0, f"landed_state {c['landed_state'][-1]:g} (not ON_GROUND)")
            vz = float(c["v_up_m_s"][-1])
            if not abs(vz) <= max_vertical_speed_m_s:
                issues.append(f"vertical speed {vz:+.2f} m/s")
        if issues:
            problems.append(
                f"{v.name} at the end (t = {t:.1f} s, {c['up_m'][-1]:.2f} m up): "
                + ", ".join(issues)
            )
    if problems:
        return CheckResult(False, float(len(problems)), "vehicles", "; ".join(problems))
    who = f"all {len(log.vehicles)} vehicles" if vehicle is None else log.vehicle(vehicle).name
    lost = sorted(log.vehicle(i).name for i in crashed if vehicle in (None, i))
    but = f" ({', '.join(lost)} crashed: judged on disarming only)" if lost else ""
    return CheckResult(True, 0.0, "vehicles", f"{who} landed and disarmed at the end{but}")


def assert_landed_and_disarmed(
    log: FlightLog,
    vehicle: int | None = None,
    max_vertical_speed_m_s: float = 0.3,
    crashed: Collection[int] = (),
) -> CheckResult:
    """:func:`landed_and_disarmed`, raising AssertionError when it fails."""
    return _raise_unless(landed_and_disarmed(log, vehicle, max_vertical_speed_m_s, crashed))


# -- failsafes ---------------------------------------------------------------------------------


def failsafe_kind(text: str) -> str | None:
    """The :data:`FAILSAFE_TEXTS` name ``text`` matches, or None for any other text."""
    for name, prefix in FAILSAFE_TEXTS.items():
        if text.startswith(prefix):
            return name
    return None


def failsafe_texts(
    log: FlightLog,
    vehicle: int | None = None,
    allow: tuple[str, ...] = (),
    excused_from_s: Mapping[int, float] | None = None,
) -> list[tuple[VehicleLog, StatusText]]:
    """Every failsafe STATUSTEXT (except the kinds in ``allow``), in each vehicle's time order.

    ``excused_from_s``: texts a vehicle (0-based) sent from that simulated time on are left out
    (a fault injected then took the vehicle: what follows is the fault's, not the flight's).
    """
    excused = excused_from_s or {}
    unknown = set(allow) - set(FAILSAFE_TEXTS)
    if unknown:
        raise ValueError(
            f"allow: unknown failsafe kind(s) {sorted(unknown)}; known: {list(FAILSAFE_TEXTS)}"
        )
    out = []
    for v in log.selected(vehicle):
        for s in v.status_texts:
            kind = failsafe_kind(s.text)
            if kind is None or kind in allow:
                continue
            if kind == "datalink_lost" and _armed_at(v, s.time_s) is False:
                continue
            if s.time_s >= excused.get(v.index, math.inf):
                continue
            out.append((v, s))
    return out


def _armed_at(v: VehicleLog, time_s: float) -> bool | None:
    """The armed state the vehicle's HEARTBEATs last showed at ``time_s`` (None: none yet)."""
    armed = None
    for change in v.state_changes:
        if change.time_s > time_s:
            break
        armed = change.armed
    return armed


def no_failsafe(
    log: FlightLog,
    vehicle: int | None = None,
    allow: tuple[str, ...] = (),
    excused_from_s: Mapping[int, float] | None = None,
) -> CheckResult:
    """No vehicle announced a failsafe.

    ``allow``: kinds of :data:`FAILSAFE_TEXTS` tolerated; ``excused_from_s``: as
    :func:`failsafe_texts`.
    """
    found = failsafe_texts(log, vehicle, allow, excused_from_s)
    if not found:
        return CheckResult(True, 0.0, "texts", "no failsafe announced")
    listed = "; ".join(f'{v.name} at t = {s.time_s:.1f} s: "{s.text}"' for v, s in found[:5])
    more = f" (and {len(found) - 5} more)" if len(found) > 5 else ""
    return CheckResult(
        False, float(len(found)), "texts", f"{len(found)} failsafe text(s): {listed}{more}"
    )


def assert_no_failsafe(
    log: FlightLog, vehicle: int | None = None, allow: tuple[str, ...] = ()
) -> CheckResult:
    """:func:`no_failsafe`, raising AssertionError when it fails."""
    return _raise_unless(no_failsafe(log, vehicle, allow))


# -- geometry ----------------------------------------------------------------------------------


def stayed_inside(
    log: FlightLog, polygon: Polygon, vehicle: int | None = None, margin_m: float = 0.0
) -> CheckResult:
    """Every true horizontal position stayed inside ``polygon`` (world ENU, m) or on its edge.

    ``margin_m`` > 0 tolerates excursions up to that distance. ``value`` is the farthest any
    vehicle got outside, m (0 if none did).
    """
    worst = (0.0, "", 0.0)
    for v in log.selected(vehicle):
        if len(v.track) == 0:
            continue
        e, n = v.track["east_m"], v.track["north_m"]
        outside = np.flatnonzero(~shapely.intersects_xy(polygon, e, n))
        if outside.size == 0:
            continue
        dist = shapely.distance(polygon, shapely.points(e[outside], n[outside]))
        k = int(np.argmax(dist))
        if dist[k] > worst[0]:
            worst = (float(dist[k]), v.name, float(v.track.time_s[outside[k]]))
    value, name, t = worst
    if not name:
        return CheckResult(True, 0.0, "m", "every vehicle stayed inside the polygon")
    ok = value <= margin_m
    return CheckResult(
        ok,
        value,
        "m",
        f"{name} went {value:.2f} m outside the polygon at t = {t:.1f} s (margin {margin_m:g} m)",
    )


def assert_stayed_inside(
    log: FlightLog, polygon: Polygon, vehicle: int | None = None, margin_m: float = 0.0
) -> CheckResult:
    """:func:`stayed_inside`, raising AssertionError when it fails."""
    return _raise_unless(stayed_inside(log, polygon, vehicle, margin_m))


def _fmt(point: np.ndarray) -> str:
    return "(" + ", ".join(f"{x:g}" for x in point) + ")"
