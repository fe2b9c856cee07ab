"""The coverage role's plan: its parameters, the strip it flies and the time it may take.

What the coverage companion decides before and while it flies, shared by its two adapters: the
MAVSDK program (``companion.scripts.coverage``) and the swarm-scale program
(``companion.swarm.coverage``). Pure: a built world, the vehicle's home and the run's time in;
the plan, budgets and return altitude out.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import networkx as nx
import numpy as np
import shapely
from shapely.geometry import box

from companion.planning.coverage import (
    PARTITIONS,
    CoverageSpec,
    Router,
    VehiclePlan,
    plan_vehicle,
    reachable_area,
)
from companion.role_params import params_from_mapping
from companion.scenario_env import ScenarioEnv


@dataclass(frozen=True)
class CoverageParams:
    """The role's arguments (``SWARMSITL_PARAMS``), SI units."""

    altitude_m: float = 30.0
    """Flight height above the launch point, m."""
    speed_m_s: float = 10.0
    """Speed along the lanes, m/s."""
    overlap: float = 0.2
    """Fraction of the footprint width neighbouring lanes share."""
    hfov_deg: float = 114.59
    """Camera horizontal field of view, degrees (the Typhoon H480's)."""
    camera_pitch_deg: float = -90.0
    """Camera elevation above the body's forward axis, degrees (-90: down)."""
    area_enu_m: tuple[float, float, float, float] | None = None
    """Rectangle (x_min, y_min, x_max, y_max) to cover, world ENU m; None: the world's boundary,
    cut to the square around the launch point the fleet can sweep in the run's time
    (``coverage.reachable_area``), or with no world a 200 m square around the launch point."""
    sweep_deg: float | None = None
    """Lane direction, degrees counter-clockwise from east; None: along the area's longer side."""
    margin_m: float = 10.0
    """Horizontal distance kept from solids that reach the flight height, no-fly zones and the
    world's edge, m."""
    partition: str = "strips"
    """How the vehicles of the role share the area (``coverage.PARTITIONS``): "strips" of
    neighbouring lanes, or seed 004's "mco", "kmeans" or "boustrophedon" regions of a lattice
    (``coverage_partition``)."""
    climb_m_s: float = 1.5
    """Climb rate the take-off is budgeted with, m/s (PX4's MPC_TKO_SPEED)."""
    descent_m_s: float = 1.0
    """Mean descent rate the landing is budgeted with, m/s (MPC_Z_V_AUTO_DN, MPC_LAND_SPEED)."""
    mean_speed_fraction: float = 0.7
    """Share of ``speed_m_s`` the vehicle averages along its path, with the accelerations and
    turns (measured: about 0.6 to 0.8 on 100 to 200 m lanes), for the time budget; in (0, 1]."""
    reserve_s: float = 10.0
    """Extra simulated seconds kept free before the run's end."""
    merge_radius_m: float = 10.0
    """Detections closer than this are one spill, m."""
    dark_max: int = 28
    """Brightest channel of an oil pixel, 0..255."""
    altitude_step_m: float = 4.0
    """Vehicle k of the role (``ROLE_INDEX``) flies ``altitude_m + k * altitude_step_m`` above
    its launch point, so that vehicles crossing each other's way to and from their strips pass
    at different heights; the lanes are spaced for ``altitude_m``, the lowest footprint."""

    def own(self, role_index: int) -> CoverageParams:
        """These parameters with the flight height of vehicle ``role_index`` of the role."""
        return dataclasses.replace(
            self, altitude_m=self.altitude_m + role_index * self.altitude_step_m
        )

    def __post_init__(self) -> None:
        positive = ("altitude_m", "speed_m_s", "climb_m_s", "descent_m_s")
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"PARAMS {name} must be a positive number, got {value!r}")
        step = self.altitude_step_m
        if not (isinstance(step, (int, float)) and math.isfinite(step) and step >= 0):
            raise ValueError(f"PARAMS altitude_step_m must be a number >= 0, got {step!r}")
        if self.partition not in PARTITIONS:
            raise ValueError(
                f"PARAMS partition must be one of {list(PARTITIONS)}, got {self.partition!r}"
            )
        if not 0.0 < self.mean_speed_fraction <= 1.0:
            raise ValueError(
                f"PARAMS mean_speed_fraction must be in (0, 1], got {self.mean_speed_fraction!r}"
            )
        if self.area_enu_m is not None:
            area = tuple(float(v) for v in self.area_enu_m)
            if len(area) != 4 or not (area[0] < area[2] and area[1] < area[3]):
                raise ValueError(
                    f"PARAMS area_enu_m must be [x_min, y_min, x_max, y_max], got {self.area_enu_m}"
                )
            object.__setattr__(self, "area_enu_m", area)

    @property
    def mean_speed_m_s(self) -> float:
        """The speed the time budget assumes, m/s."""
        return self.speed_m_s * self.mean_speed_fraction

    @classmethod
    def from_mapping(cls, params: Mapping[str, object] | None) -> CoverageParams:
        """From the PARAMS JSON object; an unknown key is an error naming it."""
        return params_from_mapping(cls, params)


def _obstacles(world: Any, flight_z_m: float, clearance_m: float = 5.0) -> list:
    """Footprints of the solids reaching within ``clearance_m`` of the flight height, no-fly."""
    if world is None:
        return []
    from worlds.maps import obstacle_polygons

    out = list(world.no_fly)
    for z in np.arange(flight_z_m - clearance_m, flight_z_m + clearance_m + 0.5, 1.0):
        out.extend(obstacle_polygons(world, float(z), include_no_fly=False))
    return out


def climb_and_landing_s(
    params: CoverageParams, return_altitude_m: float | None = None
) -> tuple[float, float]:
    """Simulated seconds budgeted for the take-off, and for the return's climb, descent, landing.

    ``return_altitude_m``: the return-to-launch altitude above home (default: ``altitude_m``);
    a higher one adds the climb to it and its longer descent. 10 s cover the return's
    accelerations and the land detector.
    """
    rtl = params.altitude_m if return_altitude_m is None else return_altitude_m
    climb_back = max(rtl - params.altitude_m, 0.0) / params.climb_m_s
    return (
        params.altitude_m / params.climb_m_s + 5.0,
        climb_back + rtl / params.descent_m_s + 10.0,
    )


def return_altitude_m(
    world: Any,
    home_enu_m: np.ndarray,
    waypoints_enu_m: np.ndarray,
    altitude_m: float,
    clearance_m: float = 5.0,
) -> float:
    """Return-to-launch altitude above home that clears every solid on the way back, m.

    The return flies straight from wherever the vehicle is to home: any solid under the hull
    of the path and home (grown by ``clearance_m``) must be ``clearance_m`` below it. Moving
    solids count over their whole range of motion.
    """
    if world is None or len(waypoints_enu_m) == 0:
        return altitude_m
    points = np.vstack([np.asarray(home_enu_m)[:2], np.asarray(waypoints_enu_m)[:, :2]])
    region = shapely.MultiPoint(points).convex_hull.buffer(clearance_m)
    tops = []
    for solid in world.solids:
        if solid.motion is None:
            footprint, top = solid.footprint_at(0.0), solid.z_range_at(0.0)[1]
        else:
            footprint = box(*solid.motion.bounds_xy_m).buffer(max(solid.size_m[:2]) / 2.0)
            top = solid.z_range_at(0.0)[1] + abs(solid.motion.vertical_amplitude_m) * 2.0
        if footprint.intersects(region):
            tops.append(top)
    needed = max(tops, default=-math.inf) + clearance_m - float(home_enu_m[2])
    return max(altitude_m, needed)


def launch_surface_up_m(world: Any, home_enu_m: np.ndarray) -> float:
    """Height (ENU up, m) of the surface the vehicle took off from.

    GNSS altitude is metres off (a standalone receiver's epv is ~3 m, and PX4's EKF origin takes
    its altitude from the first fixes), so a footprint's camera height must not come from the
    absolute altitude: it is this surface plus the height above home, which the barometer
    measures to decimetres. The surface is the world's launch area under home (a helideck's
    top), else the ground: the plane at the origin's altitude (0 m) the footprints are projected
    on, with or without a world.
    """
    area = launch_area_under(world, home_enu_m)
    return float(area.center_enu_m[2]) if area is not None else 0.0


def launch_area_under(world: Any, home_enu_m: np.ndarray) -> Any:
    """The world's launch area home is on (within its radius plus 5 m), or None."""
    home = np.asarray(home_enu_m, dtype=float)
    for area in world.launch_areas if world is not None else ():
        centre = np.asarray(area.center_enu_m, dtype=float)
        if np.hypot(*(centre[:2] - home[:2])) <= area.radius_m + 5.0:
            return area
    return None


def reference_point(world: Any, home_enu_m: np.ndarray) -> np.ndarray:
    """The point the vehicles of one launch area split the area from: that area's centre.

    Vehicles on the same helideck have homes a few metres apart (and their GPS altitudes
    differ): the split must not depend on them, or the strips would overlap. A vehicle whose
    home is on none of the world's launch areas (within its radius plus 5 m) uses its home.
    """
    area = launch_area_under(world, home_enu_m)
    if area is None:
        return np.asarray(home_enu_m, dtype=float)
    return np.asarray(area.center_enu_m, dtype=float)


def plan(
    env: ScenarioEnv,
    params: CoverageParams,
    world: Any,
    home_enu_m: np.ndarray,
    budget_s: float | None,
) -> VehiclePlan:
    """This vehicle's coverage path in world ENU (z = flight height above the sea/ground).

    The area and its split depend only on what every vehicle of the role shares (world, launch
    area, params, the run's duration), so the K strips fit together; the order of the lanes,
    the cut to ``budget_s`` (what is left of this vehicle's time) and the legs from and to the
    start use the vehicle's own home.
    """
    ref = reference_point(world, home_enu_m)
    flight_z = float(ref[2]) + params.altitude_m
    spec = CoverageSpec(
        altitude_m=flight_z,
        hfov_deg=params.hfov_deg,
        overlap=params.overlap,
        sweep_deg=params.sweep_deg,
        margin_m=params.margin_m,
        partition=params.partition,
    )
    if params.area_enu_m is not None:
        area = box(*params.area_enu_m)
    elif world is not None:
        # The world's edge is a line not to cross, as an obstacle is: the lanes keep margin_m
        # inside it (a vehicle's GNSS error alone is ~1.3 m per axis; a lane's end at the very
        # edge put the truth 0.7 m outside the offshore world).
        inside = world.boundary.buffer(-params.margin_m)
        area = inside if not inside.is_empty else world.boundary
        if env.duration_s is not None:
            overhead = sum(climb_and_landing_s(params)) + params.reserve_s
            reach = params.mean_speed_m_s * max(env.duration_s - overhead, 1.0)
            area = reachable_area(area, ref[:2], env.role_count, spec, reach)
    else:
        area = shapely.Point(ref[:2]).buffer(100.0, cap_style="square")
    vehicle_plan = plan_vehicle(
        area,
        _obstacles(world, flight_z),
        spec,
        env.role_count,
        env.role_index,
        home_enu_m[:2],
        params.mean_speed_m_s,
        budget_s,
    )
    pad = launch_pad(world, home_enu_m)
    if pad is None or len(vehicle_plan.waypoints_enu_m) == 0:
        return vehicle_plan
    corners = approach_route(
        vehicle_plan.free_area, pad, vehicle_plan.waypoints_enu_m[-1, :2], home_enu_m[:2]
    )
    if corners is None:
        return vehicle_plan
    route = np.column_stack((corners, np.full(len(corners), flight_z))).reshape(-1, 3)
    return dataclasses.replace(vehicle_plan, return_route_enu_m=route)


APPROACH_MARGIN_M = 3.0
"""How far outside the launch pad's usable radius the way home stays until its final leg, m."""


def launch_pad(world: Any, home_enu_m: np.ndarray) -> tuple[np.ndarray, float] | None:
    """Centre (x, y) and radius of the launch area home is on, or None."""
    area = launch_area_under(world, home_enu_m)
    if area is None:
        return None
    return np.asarray(area.center_enu_m, dtype=float)[:2], float(area.radius_m)


def approach_route(
    free_area: Any, pad: tuple[np.ndarray, float], from_xy: np.ndarray, home_xy: np.ndarray
) -> np.ndarray | None:
    """Corners of the way home that keep off the launch pad until a straight radial final leg.

    Vehicles of one pad land side by side, each descending over its own home while the others
    may still be flying home at their own heights: a way home straight across the pad passes
    over a neighbour's home, where it may be descending through that height (seen: 1.3 m apart
    in the offshore demo). Staying outside the pad (its radius plus APPROACH_MARGIN_M) until
    the point radially outside one's own home, then flying straight in, passes over no other
    home of a pad whose homes surround its centre. None when the way cannot be planned so (the
    vehicle starts inside the pad's disc, home is the centre, the entry is not free).
    """
    centre, radius = pad
    out = np.asarray(home_xy, dtype=float) - centre
    if np.hypot(*out) < 1e-6:
        return None
    keep_off = radius + APPROACH_MARGIN_M
    entry = centre + out / np.hypot(*out) * (keep_off + 1.0)
    disc = shapely.Point(*centre).buffer(keep_off, quad_segs=4)
    start = np.asarray(from_xy, dtype=float)
    allowed = free_area.difference(disc) if free_area is not None else None
    if allowed is None or allowed.is_empty or disc.contains(shapely.Point(*start)):
        return None
    if not allowed.buffer(1e-6).covers(shapely.Point(*entry)):
        return None
    try:
        corners = Router(allowed).path(start, entry)
    except (ValueError, nx.NetworkXException):  # no way round: keep the direct way home
        return None
    return np.asarray([*corners, entry], dtype=float).reshape(-1, 2)


def world_spills(world: Any) -> list[Any]:
    """The world's oil spills (none without a world)."""
    if world is None:
        return []
    from worlds import OilSpill

    return list(world.targets_of(OilSpill))


def finish_time_s(remaining_m: float, params: CoverageParams, land_s: float) -> float:
    """Simulated seconds to fly the rest of the mission, settle and land, with half the reserve.

    When the run's end comes sooner, the vehicle turns home at once (both adapters use this).
    """
    return remaining_m / params.mean_speed_m_s + land_s + params.reserve_s / 2
