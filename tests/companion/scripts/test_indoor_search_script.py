"""The indoor search companion's pure parts: parameters, frames, the setpoint trajectory, split."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from companion.scripts.indoor_search import (
    PARAMS,
    LocalFrame,
    SearchParams,
    Trajectory,
    launch_reference,
    yaw_deg_ned,
)
from worlds.model import LaunchArea, Surface, World
from worlds.shapes import centred_rectangle


def test_the_program_declares_its_parameters_for_the_scenario_loader() -> None:
    assert PARAMS is SearchParams


def test_params_from_mapping_and_errors_naming_the_key() -> None:
    p = SearchParams.from_mapping({"altitude_m": 2.0, "altitude_step_m": 1.0})
    assert p.height_m(0) == 2.0 and p.height_m(2) == 4.0
    with pytest.raises(ValueError, match=r"unknown key.*altitud"):
        SearchParams.from_mapping({"altitud": 2.0})
    with pytest.raises(ValueError, match="speed_m_s"):
        SearchParams(speed_m_s=-1.0)
    with pytest.raises(ValueError, match="setpoint_hz"):
        SearchParams(setpoint_hz=5.0)  # PX4 needs a steady stream; we keep >= 10 Hz
    with pytest.raises(ValueError, match="corner_speed_m_s"):
        SearchParams(speed_m_s=1.0, corner_speed_m_s=2.0)
    with pytest.raises(ValueError, match="min_detections"):
        SearchParams(min_detections=0)


def test_local_frame_maps_world_enu_to_local_ned_and_back() -> None:
    frame = LocalFrame(origin_en_m=(10.0, -5.0), floor_down_m=0.12)
    ned = frame.to_ned(np.array([12.0, -1.0]), 1.5)
    np.testing.assert_allclose(ned, [4.0, 2.0, 0.12 - 1.5])
    np.testing.assert_allclose(frame.to_enu(ned), [12.0, -1.0, 1.5])


def test_yaw_of_directions() -> None:
    assert yaw_deg_ned(np.array([0.0, 1.0])) == pytest.approx(0.0)  # north
    assert yaw_deg_ned(np.array([1.0, 0.0])) == pytest.approx(90.0)  # east
    assert yaw_deg_ned(np.array([0.0, -1.0])) == pytest.approx(180.0)
    assert yaw_deg_ned(np.array([-1.0, 0.0])) == pytest.approx(-90.0)


def test_trajectory_slows_at_corners_and_stops_at_the_end() -> None:
    params = SearchParams(speed_m_s=2.0, corner_speed_m_s=0.5, accel_m_s2=1.0)
    traj = Trajectory(np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]]), params)
    assert traj.length_m == pytest.approx(20.0)
    xy, u = traj.point(15.0)
    np.testing.assert_allclose(xy, [10.0, 5.0])
    np.testing.assert_allclose(u, [0.0, 1.0])
    np.testing.assert_allclose(traj.point(-3.0)[0], [0.0, 0.0])  # clipped to the ends
    np.testing.assert_allclose(traj.point(99.0)[0], [10.0, 10.0])
    assert traj.speed(5.0) == pytest.approx(2.0)  # cruise mid-leg
    assert traj.speed(10.0) == pytest.approx(0.5)  # at the corner
    assert traj.speed(9.9) < 1.0  # braking into it
    assert traj.speed(20.0) == 0.0  # stopped at the end
    # flying it takes longer than cruising it, and the remaining time falls along the path
    assert traj.time_s() > traj.length_m / params.speed_m_s
    times = [traj.time_s(s) for s in np.linspace(0.0, 20.0, 9)]
    assert all(a > b for a, b in itertools.pairwise(times)) and times[-1] == 0.0


def test_trajectory_of_one_point_hovers() -> None:
    traj = Trajectory(np.array([[1.0, 2.0], [1.0, 2.0]]), SearchParams())
    assert traj.length_m == 0.0 and traj.speed(0.0) == 0.0 and traj.time_s() == 0.0
    np.testing.assert_allclose(traj.point(0.0)[0], [1.0, 2.0])


def test_launch_reference_is_the_area_centre_shared_by_every_vehicle() -> None:
    world = World(
        kind="indoor",
        seed=0,
        size_m=(40.0, 40.0),
        boundary=centred_rectangle(40.0, 40.0),
        surface=Surface("floor", (0.5, 0.5, 0.5, 1.0), "concrete", 1.0, 0.1),
        launch_areas=(LaunchArea("safe_point", (5.0, -15.0, 0.0), 2.0),),
    )
    a, da = launch_reference(world, np.array([5.0, -15.0]))
    b, db = launch_reference(world, np.array([7.0, -15.0]))
    np.testing.assert_allclose(a, [5.0, -15.0])
    np.testing.assert_allclose(b, a)
    assert da == 0.0 and db == pytest.approx(2.0)
    far, d = launch_reference(world, np.array([0.0, 10.0]))
    assert math.isinf(d)
    np.testing.assert_allclose(far, [0.0, 10.0])


@pytest.mark.parametrize("budget_s", [30.0, 62.0, 90.0, 400.0])
def test_fitting_route_holds_its_flight_and_turns_in_the_budget(budget_s: float) -> None:
    import worlds
    from companion.planning.indoor_route import IndoorPlanner, RouteSpec
    from companion.scripts.indoor_search import fitting_route
    from worlds.examples import example_path

    world = worlds.build(worlds.load_world(example_path("indoor")))
    params = SearchParams()
    planner = IndoorPlanner(world, RouteSpec(params.altitude_m, params.margin_m))
    start = (26.95, -23.0)
    rooms = planner.split(start, 2)[0]
    route = fitting_route(planner, start, rooms, budget_s, params)
    assert set(route.rooms) <= set(rooms)
    flight_s = route.length_m / (params.speed_m_s * params.mean_speed_fraction)
    assert flight_s + len(route.rooms) * params.spin_s <= budget_s
    if budget_s == 400.0:
        assert route.rooms == rooms
    if budget_s == 62.0:  # the room next to the yard, not the first of the full tour
        assert len(route.rooms) == 1
