"""The coverage companion without a vehicle: parameters, environment, planning, metrics."""

from __future__ import annotations

import argparse

import numpy as np
import pytest
import shapely

import worlds
from companion.perception.camera_model import CameraModel, rotation_flu_enu_from_euler
from companion.planning.coverage_role import (
    CoverageParams,
    climb_and_landing_s,
    launch_surface_up_m,
    plan,
    reference_point,
    return_altitude_m,
)
from companion.scenario_env import ScenarioEnv, ScenarioEnvError
from companion.scripts.coverage import PARAMS, Track, _metrics, scenario_env
from harness.run.ports import free_port_block
from worlds.examples import example_path

BASE = free_port_block(3)
"""Ports of the URLs below (nothing binds them), from the suite's allocator."""


@pytest.fixture(scope="module")
def offshore() -> worlds.World:
    return worlds.build(worlds.load_world(example_path("offshore")))


def _env(index: int, count: int, duration_s: float | None = 120.0) -> ScenarioEnv:
    return ScenarioEnv(
        mavlink_url=f"udpin://0.0.0.0:{BASE}",
        grpc_port=BASE + 2,
        vehicle=index + 1,
        vehicles=count,
        role="coverage",
        role_index=index,
        role_count=count,
        seed=0,
        out_dir=".",
        duration_s=duration_s,
    )


def test_the_program_declares_its_parameters_for_the_scenario_loader():
    assert PARAMS is CoverageParams


def test_params_reject_unknown_keys_and_bad_values_naming_them():
    """PARAMS is checked: an unknown key or a bad value is an error naming it."""
    assert CoverageParams.from_mapping(None) == CoverageParams()
    with pytest.raises(ValueError, match="altitud_m"):
        CoverageParams.from_mapping({"altitud_m": 20})
    with pytest.raises(ValueError, match="speed_m_s"):
        CoverageParams.from_mapping({"speed_m_s": 0})
    with pytest.raises(ValueError, match="area_enu_m"):
        CoverageParams.from_mapping({"area_enu_m": [10, 0, 0, 10]})


def test_options_override_the_environment():
    """Command-line options win over SWARMSITL_* variables; bad variables still name themselves."""
    names = ("url", "grpc_port", "vehicle", "role_index", "role_count", "out", "world", "origin")
    args = argparse.Namespace(**dict.fromkeys(names), video_uri=None, duration=60.0, params=None)
    args.role_index, args.role_count = 1, 3
    environ = {"SWARMSITL_MAVLINK_URL": f"udpin://0.0.0.0:{BASE + 1}", "SWARMSITL_VEHICLE": "2",
               "SWARMSITL_DURATION_S": "120", "SWARMSITL_PARAMS": '{"altitude_m": 12}'}  # fmt: skip
    env = scenario_env(args, environ)
    assert (env.mavlink_url, env.vehicle, env.role_index, env.role_count) == (
        f"udpin://0.0.0.0:{BASE + 1}", 2, 1, 3,
    )  # fmt: skip
    assert env.duration_s == 60.0 and env.params == {"altitude_m": 12}
    with pytest.raises(ScenarioEnvError, match="SWARMSITL_ORIGIN"):
        scenario_env(args, environ | {"SWARMSITL_ORIGIN": "47,8"})


def test_three_vehicles_from_the_helideck_get_disjoint_flyable_strips(offshore):
    """On the offshore world, from three spots of the helideck (GPS altitudes a little apart),
    each vehicle gets a non-empty path in its own strip near the rig that fits its budget and
    keeps clear of the derrick; the strips do not overlap."""
    helideck = np.array(offshore.launch_area("helideck").center_enu_m)
    homes = helideck + np.array([[-5.0, 0.0, 0.3], [0.0, 0.0, -0.2], [5.0, 0.0, 0.1]])
    budgets = (45.0, 43.0, 40.0)  # each connected at its own time
    params = CoverageParams()
    plans = [plan(_env(i, 3), params, offshore, homes[i], budgets[i]) for i in range(3)]
    derrick = next(s for s in offshore.solids if s.name == "rig_derrick").footprint_at(0.0)
    for p, home, budget in zip(plans, homes, budgets, strict=True):
        assert len(p.waypoints_enu_m) >= 2
        assert p.transit_m == pytest.approx(np.hypot(*(p.waypoints_enu_m[0, :2] - home[:2])))
        assert p.flight_time_s(params.mean_speed_m_s) <= budget + 1e-6
        np.testing.assert_allclose(p.waypoints_enu_m[:, 2], helideck[2] + params.altitude_m)
        track = shapely.LineString(p.waypoints_enu_m[:, :2])
        assert track.distance(derrick) >= params.margin_m - 1e-3
    strips = [p.part.polygon for p in plans]
    for i in range(3):
        for j in range(i + 1, 3):
            assert strips[i].intersection(strips[j]).area < 1e-6
    # Together they are one square around the helideck (no gaps between the strips).
    union = shapely.union_all(strips)
    assert union.area == pytest.approx(shapely.envelope(union).area, rel=0.02)


def test_metrics_count_the_spills_under_the_footprint_once_they_exist(offshore):
    """A footprint over a spill counts it only if taken after the spill appeared."""
    spill = max(offshore.spills_at(1e9), key=lambda s: s.appear_s)
    x, y = spill.polygon.centroid.coords[0]
    camera = CameraModel()
    footprint = camera.footprint((x, y, 40.0), rotation_flu_enu_from_euler(0, 0, 0))
    helideck = np.array(offshore.launch_area("helideck").center_enu_m)
    path = plan(_env(0, 1, None), CoverageParams(), offshore, helideck, None)

    def spills(t_s: float) -> int:
        track = Track(footprints=[(t_s, footprint)])
        return _metrics(offshore, path, track, None)["spills_in_footprint"][0]

    others = sum(1 for s in offshore.spills_at(spill.appear_s) if s.polygon.intersects(footprint))
    assert spills(spill.appear_s) == others >= 1
    assert spills(spill.appear_s - 1.0) == others - 1


def test_a_home_off_every_launch_area_plans_from_itself(offshore):
    """Homes on the helideck share its centre (deck height); a home on the sea keeps its own."""
    helideck = np.array(offshore.launch_area("helideck").center_enu_m)
    np.testing.assert_allclose(
        reference_point(offshore, helideck + np.array([3.0, -2.0, 0.4])), helideck
    )
    sea = np.array([200.0, -150.0, 0.1])
    np.testing.assert_allclose(reference_point(offshore, sea), sea)
    p = plan(_env(0, 1), CoverageParams(altitude_m=20.0), offshore, sea, 60.0)
    np.testing.assert_allclose(p.waypoints_enu_m[:, 2], 20.1)


def test_the_return_altitude_clears_the_solids_on_the_way_home(offshore):
    """Coming back over the rig's derrick (top 60 m, helideck at 32 m): RTL at least 33 m above
    home; a path on the open sea west of the helideck keeps the flight altitude."""
    helideck = np.array(offshore.launch_area("helideck").center_enu_m)
    east = np.array([[120.0, 48.0, 62.0], [150.0, 48.0, 62.0]])
    west = np.array([[-150.0, 48.0, 62.0], [-200.0, 48.0, 62.0]])
    assert return_altitude_m(offshore, helideck, east, 30.0) == pytest.approx(60.0 + 5.0 - 32.0)
    assert return_altitude_m(offshore, helideck, west, 30.0) == 30.0
    assert return_altitude_m(offshore, helideck, east, 40.0) == 40.0
    assert return_altitude_m(None, helideck, east, 30.0) == 30.0
    # The higher return costs time: its climb and its longer descent.
    params = CoverageParams()
    assert climb_and_landing_s(params, 33.0)[1] > climb_and_landing_s(params)[1] + 3.0


def test_the_camera_height_comes_from_the_launch_surface_not_gnss_altitude(offshore):
    """A home whose GNSS altitude is 8 m low (2.8 epv, seen in flight) still sits on the
    helideck's surface; one on the sea, or anywhere without a world, on the ground plane (0 m)."""
    helideck = np.array(offshore.launch_area("helideck").center_enu_m)
    low = helideck + np.array([2.0, 1.0, -8.0])
    assert launch_surface_up_m(offshore, low) == pytest.approx(helideck[2])
    assert launch_surface_up_m(offshore, np.array([200.0, -150.0, -7.9])) == 0.0
    assert launch_surface_up_m(None, low) == 0.0


def test_the_way_home_keeps_off_the_neighbours_homes_until_its_radial_final_leg(offshore):
    """Three homes round the helideck's centre (6 m apart): whatever side the strips end on,
    each vehicle's way home passes no closer than 4 m to another's home (where it may be
    descending), by keeping off the pad until the point radially outside its own home."""
    centre = np.array(offshore.launch_area("helideck").center_enu_m)
    angles = np.radians([90.0, 210.0, 330.0])
    homes = [centre + np.array([3.46 * np.cos(a), 3.46 * np.sin(a), 0.0]) for a in angles]
    for index, home in enumerate(homes):
        p = plan(_env(index, 3), CoverageParams(altitude_m=20.0), offshore, home, 90.0)
        way = np.vstack([p.waypoints_enu_m[-1:, :2], p.return_route_enu_m[:, :2], home[:2]])
        line = shapely.LineString(way)
        for other, neighbour in enumerate(homes):
            if other != index:
                assert line.distance(shapely.Point(*neighbour[:2])) > 4.0, (index, other)
        final = way[-1] - way[-2]  # the last leg comes straight in from outside
        outward = home[:2] - centre[:2]
        assert np.dot(final, outward) < 0 and np.hypot(*way[-2] - centre[:2]) > 11.0
