"""Swarm engine: what ``sense`` returns, how collisions are counted, goto and priorities.

Geometry is checked against hand-computed distances (a box face, a box top, a drum's straight
motion, two spheres), never against the code's own helpers.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from harness.swarm.engine import SwarmEngine
from sitl.kinematic_fleet import KinematicFleet
from sitl.vehicles.kinematics import KinematicLimits
from worlds.model import Solid, SolidMotion
from worlds.solid_set import SolidSet

LIMITS = KinematicLimits(12.0, 3.0, 45.0, 3.0, 1.5, 4.0)
R = 0.25  # seed 001's 0.5 m drones
BOX = Solid("box", "box", (20.0, 0.0, 5.0), (4.0, 4.0, 10.0), yaw_deg=0.0)
"""x in [18, 22], y in [-2, 2], z in [0, 10]."""


def engine(starts, solids=(), step_hz: float = 20.0, priority=None) -> SwarmEngine:
    fleet = KinematicFleet(np.asarray(starts, dtype=float), LIMITS)
    n = fleet.n
    return SwarmEngine(
        fleet, [f"vehicle{i + 1}" for i in range(n)], step_hz, 1.0, 0, math.inf,
        np.full(n, np.nan), [], radius_m=np.full(n, R), solids=SolidSet(solids),
        priority=priority,
    )  # fmt: skip


def place(e: SwarmEngine, i: int, xyz) -> None:
    e.fleet.state.position_m[i] = xyz
    e.fleet.state.airborne[i] = True


def test_sense_sees_a_static_box_within_range_and_not_beyond():
    """The clearance is the distance to the face minus the vehicle's radius."""
    e = engine([[0, 0, 0]], [BOX])
    place(e, 0, (0.0, 0.5, 5.0))
    assert e.handles[0].sense(17.7) == []
    (s,) = e.handles[0].sense(17.8)
    assert (s.kind, s.name) == ("solid", "box")
    assert s.distance_m == pytest.approx(18.0 - R)
    assert s.position_enu_m == pytest.approx((18.0, 0.5, 5.0))
    assert s.velocity_enu_m_s == (0.0, 0.0, 0.0)


def test_a_yawed_box_and_the_space_above_its_top():
    """Yaw turns the footprint; above the top the clearance is the height above it."""
    yawed = Solid("b", "box", (0.0, 0.0, 5.0), (10.0, 2.0, 10.0), yaw_deg=90.0)
    e = engine([[0, 0, 0]], [yawed])
    place(e, 0, (0.0, 4.5, 5.0))  # inside once turned (its long side now along y)
    assert e.handles[0].sense(1.0)[0].position_enu_m == pytest.approx((0.0, 4.5, 5.0))
    assert e.handles[0].sense(1.0)[0].distance_m == pytest.approx(-R)
    place(e, 0, (4.5, 0.0, 5.0))  # outside once turned: 3.5 m east of the 1 m half-width
    assert e.handles[0].sense(5.0)[0].distance_m == pytest.approx(3.5 - R)
    place(e, 0, (0.0, 0.0, 13.0))
    (s,) = e.handles[0].sense(5.0)
    assert s.distance_m == pytest.approx(3.0 - R)
    assert s.position_enu_m == pytest.approx((0.0, 0.0, 10.0))
    assert e.handles[0].sense(2.5) == []


def test_sense_sees_a_moving_drum_where_it_is_at_time_t():
    """A drum moving east at 1 m/s is 10 m east after 10 s, with its velocity."""
    drum = Solid(
        "mover_0", "cylinder", (0.0, 0.0, 5.0), (2.0, 2.0, 2.0),
        motion=SolidMotion((1.0, 0.0), (-100.0, -100.0, 100.0, 100.0)),
    )  # fmt: skip
    e = engine([[0, 50, 0]], [drum])
    e.run(10.0, end_when_done=False)
    assert e.time_s == pytest.approx(10.0)
    place(e, 0, (14.0, 0.0, 5.0))
    (s,) = e.handles[0].sense(3.0)
    assert s.name == "mover_0"
    assert s.position_enu_m == pytest.approx((11.0, 0.0, 5.0))
    assert s.distance_m == pytest.approx(14.0 - 10.0 - 1.0 - R)
    assert s.velocity_enu_m_s == pytest.approx((1.0, 0.0, 0.0), abs=1e-6)


def test_sense_sees_airborne_vehicles_nearest_first_not_grounded_ones():
    e = engine([[0, 0, 0], [3, 0, 0], [0, 2, 0], [1, 0, 0]])
    for i, p in enumerate([(0, 0, 5), (3, 0, 5), (0, 2, 5)]):
        place(e, i, p)
    e.fleet.state.speed_m_s[1] = 2.0
    e.fleet.state.course_rad[1] = math.pi / 2
    found = e.handles[0].sense(3.0)
    assert [s.name for s in found] == ["vehicle3", "vehicle2"]  # vehicle4 is on the ground
    assert found[0].distance_m == pytest.approx(2.0 - 2 * R)
    assert found[1].velocity_enu_m_s == pytest.approx((0.0, 2.0, 0.0), abs=1e-9)
    assert [s.name for s in e.handles[0].sense(2.0 - 2 * R)] == ["vehicle3"]


def test_two_vehicles_flown_into_each_other_count_one_event_each():
    e = engine([[0, 0, 0], [10, 0, 0]])
    for h in e.handles:
        h.takeoff(5.0)
    e.run(5.0, end_when_done=False)
    assert e.collisions.total == 0
    e.handles[0].goto(np.array([10.0, 0.0, 5.0]), 3.0)
    e.handles[1].goto(np.array([0.0, 0.0, 5.0]), 3.0)
    e.run(15.0, end_when_done=False)
    c = e.collisions
    assert (c.total, c.vehicle_events, c.solid_events) == (1, 1, 0)
    assert c.per_vehicle.tolist() == [1, 1]
    (ev,) = c.events
    assert (ev["a"], ev["b"]) == ("vehicle1", "vehicle2") and 5.0 < ev["time_s"] < 15.0


def test_a_vehicle_through_a_box_collides_one_above_it_does_not():
    e = engine([[0, 0, 0], [0, 1, 0]], [BOX])
    e.handles[0].takeoff(5.0)
    e.handles[1].takeoff(10.0 + R + 0.5)  # its sphere clears the top by 0.5 m
    e.run(6.0, end_when_done=False)
    for h in e.handles:
        p = h.position_enu_m
        h.goto(np.array([40.0, p[1], p[2]]), 5.0)
    e.run(30.0, end_when_done=False)
    assert e.handles[0].position_enu_m[0] > 30.0 and e.handles[1].position_enu_m[0] > 30.0
    c = e.collisions
    assert (c.total, c.solid_events) == (1, 1)
    assert c.per_vehicle.tolist() == [1, 0]
    assert c.events[0]["b"] == "box"


def test_vehicles_on_the_ground_at_their_start_do_not_collide():
    """Overlapping starts and a start inside a solid's footprint: nothing while grounded."""
    e = engine([[0, 0, 0], [0.3, 0, 0], [20, 0, 0]], [BOX])
    e.run(5.0, end_when_done=False)
    assert e.collisions.total == 0


def test_goto_reaches_the_point_and_holds_there():
    e = engine([[0, 0, 0]])
    h = e.handles[0]
    h.takeoff(5.0)
    e.run(5.0, end_when_done=False)
    h.goto(np.array([30.0, 40.0, 8.0]), 5.0)
    e.run(25.0, end_when_done=False)
    assert h.position_enu_m == pytest.approx([30.0, 40.0, 8.0], abs=0.05)
    e.run(35.0, end_when_done=False)
    assert h.position_enu_m == pytest.approx([30.0, 40.0, 8.0], abs=0.05)
    assert e.fleet.state.speed_m_s[0] == pytest.approx(0.0, abs=1e-6)
    e.path_done = e.fleet.path_done()
    assert h.path_done


def test_set_velocity_through_the_handle_holds_it():
    e = engine([[0, 0, 0]])
    h = e.handles[0]
    h.takeoff(5.0)
    e.run(5.0, end_when_done=False)
    h.set_velocity(np.array([0.0, 4.0, 0.0]))
    e.run(15.0, end_when_done=False)
    v = e.fleet.state.velocity_m_s[0]
    assert v == pytest.approx([0.0, 4.0, 0.0], abs=1e-6)
    assert not e.fleet.path_done()[0]


def test_priorities_default_to_the_vehicle_number_and_follow_the_engine():
    assert [h.priority for h in engine([[0, 0, 0], [5, 0, 0]]).handles] == [1, 2]
    assert [h.priority for h in engine([[0, 0, 0], [5, 0, 0]], priority=[7, 3]).handles] == [7, 3]
