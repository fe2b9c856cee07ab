"""Mission execution against a point-mass vehicle that flies each leg at a bounded speed.

The vehicle is simple kinematics, not the emulator's controllers: each tick it moves towards
the leg's target by at most speed * dt horizontally and climb * dt vertically, lands by
descending at 1 m/s once over the landing point, and stops on RTL. Ground is NED z = 0 (home,
ALT0 AMSL). Times are simulated, ticks at 50 Hz like the commander.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pytest
from mission_helpers import ALT0, GLOBAL, MISSION, RELATIVE, item, offset, to_ned, waypoint
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mission.executor import Leg, LegKind, MissionExecutor, StepInput, Tolerances
from autopilot_emu.mission.items import MissionState

M = mavlink2
DT = 0.02
ACC_RAD, ALT_RAD = 2.0, 0.8
CRUISE, CLIMB = 5.0, 2.0


def do_jump(target, repeat):
    return item(M.MAV_CMD_DO_JUMP, params=(target, repeat, 0.0, 0.0), frame=MISSION)


def change_speed(speed):
    return item(M.MAV_CMD_DO_CHANGE_SPEED, params=(1.0, speed, -1.0, 0.0), frame=MISSION)


def ned(north, east, alt_rel):
    return np.array([north, east, -alt_rel])


@dataclass
class Flight:
    """A point mass flying the executor's legs."""

    executor: MissionExecutor
    pos: np.ndarray
    takeoff_alt_m: float = 2.5
    t: float = 0.0
    yaw: float = 0.0
    speed: float = CRUISE
    reached: list[tuple[float, int]] = field(default_factory=list)
    """(time, seq) of every MISSION_ITEM_REACHED."""
    track: list[tuple[float, np.ndarray, Leg]] = field(default_factory=list)
    """(time, position when stepped, leg) per tick."""

    @property
    def landed(self) -> bool:
        return self.pos[2] >= 0.0

    def tick(self) -> Leg:
        ex = self.executor
        leg = ex.step(
            StepInput(
                time_s=self.t,
                position_ned_m=self.pos.copy(),
                yaw_rad=self.yaw,
                landed=self.landed,
                home_alt_amsl_m=ALT0,
                tolerances=Tolerances(ACC_RAD, ALT_RAD, self.takeoff_alt_m),
                to_ned=to_ned,
            )
        )
        self.reached += [(self.t, seq) for seq in ex.reached]
        ex.reached.clear()
        if ex.speed_m_s is not None:
            self.speed = CRUISE if math.isnan(ex.speed_m_s) else ex.speed_m_s
            ex.speed_m_s = None
        self.track.append((self.t, self.pos.copy(), leg))
        if math.isfinite(leg.yaw_rad):
            self.yaw = leg.yaw_rad
        self._move(leg)
        self.t += DT
        return leg

    def _move(self, leg: Leg) -> None:
        if leg.kind == LegKind.RTL:
            return
        target = np.where(np.isfinite(leg.target_ned_m), leg.target_ned_m, self.pos)
        d = target[:2] - self.pos[:2]
        dist = float(np.hypot(*d))
        if dist > 0:
            self.pos[:2] += d * min(1.0, self.speed * DT / dist)
        if leg.kind == LegKind.LAND and dist < 0.1:
            self.pos[2] = min(0.0, self.pos[2] + 1.0 * DT)
        elif leg.kind == LegKind.FLY:
            self.pos[2] += float(np.clip(target[2] - self.pos[2], -CLIMB * DT, CLIMB * DT))
            self.pos[2] = min(self.pos[2], 0.0)

    def run(self, until, max_s: float = 120.0) -> None:
        """Tick until ``until(self)`` holds; fail after max_s simulated seconds."""
        end = self.t + max_s
        while not until(self):
            assert self.t < end, "condition not reached in time"
            self.tick()

    @property
    def seqs(self) -> list[int]:
        return [seq for _, seq in self.reached]


def fly(items, start=(0.0, 0.0, 10.0), **kw) -> Flight:
    """A mission loaded and activated with the vehicle at start (north, east, height)."""
    ex = MissionExecutor()
    ex.load(tuple(items), valid=True)
    pos = ned(*start)
    ex.activate(landed=pos[2] >= 0.0)
    return Flight(ex, pos, **kw)


def complete(f: Flight) -> bool:
    return f.executor.state == MissionState.COMPLETE


def test_load_states():
    ex = MissionExecutor()
    ex.load((waypoint(10.0, 0.0),), valid=True)
    assert ex.state == MissionState.NOT_STARTED and ex.valid
    ex.load((waypoint(10.0, 0.0),), valid=False)
    assert ex.state == MissionState.NO_MISSION and not ex.valid
    ex.load((), valid=True)
    assert ex.state == MissionState.NO_MISSION


def test_items_are_reached_in_order_at_their_positions():
    """Each waypoint is reported once, when the vehicle is within the acceptance radius."""
    corners = [(30.0, 0.0), (30.0, 30.0), (0.0, 30.0)]
    f = fly([waypoint(n, e) for n, e in corners])
    f.run(complete)
    assert f.seqs == [0, 1, 2]
    for (t, _), (north, east) in zip(f.reached, corners, strict=True):
        pos = next(p for tt, p, _ in f.track if tt == t)
        assert np.hypot(pos[0] - north, pos[1] - east) <= ACC_RAD + 1e-9
        assert abs(pos[2] + 10.0) <= ALT_RAD
    assert "Mission finished, loitering" in f.executor.texts
    assert f.executor.current == 2  # MISSION_CURRENT stays on the last item


def test_waypoint_acceptance_radius_param2_overrides_nav_acc_rad():
    f = fly([waypoint(30.0, 0.0, params=(0.0, 8.0, 0.0, math.nan)), waypoint(30.0, 30.0)])
    f.run(lambda f: f.reached)
    pos = f.track[-1][1]
    assert 30.0 - pos[0] == pytest.approx(8.0, abs=CRUISE * DT + 0.01)  # degE7: 1 cm


def test_hold_time_is_waited_in_simulated_time_at_the_waypoint():
    """param1 = 3 s: reached 3 s after arriving in the acceptance radius, staying there."""
    f = fly([waypoint(20.0, 0.0, params=(3.0, 0.0, 0.0, math.nan)), waypoint(20.0, 20.0)])
    f.run(lambda f: f.reached)
    arrival = next(
        t for t, p, _ in f.track if np.hypot(p[0] - 20.0, p[1]) <= ACC_RAD and abs(p[2] + 10) < 0.8
    )
    assert f.reached[0][1] == 0
    assert f.reached[0][0] - arrival == pytest.approx(3.0, abs=1.5 * DT)
    held = [p for t, p, _ in f.track if t >= arrival]
    assert all(np.hypot(p[0] - 20.0, p[1]) <= ACC_RAD for p in held)
    assert np.allclose(held[-1], ned(20.0, 0.0, 10.0), atol=0.01)  # stopped on the waypoint


def test_pass_through_waypoint_does_not_stop():
    """Hold 0: the next leg starts at the acceptance radius, the vehicle never slows down."""
    f = fly([waypoint(30.0, 0.0), waypoint(30.0, 30.0)])
    f.run(lambda f: len(f.reached) == 1)
    f.run(lambda f: np.hypot(f.pos[0] - 30.0, f.pos[1] - 30.0) < 10.0)
    positions = np.array([p for _, p, _ in f.track])
    steps = np.linalg.norm(np.diff(positions, axis=0), axis=1)
    assert steps == pytest.approx(CRUISE * DT)  # full speed on every tick
    closest = np.min(np.hypot(positions[:, 0] - 30.0, positions[:, 1]))
    assert closest > 0.75 * ACC_RAD  # turned at the radius, never over the waypoint


def test_nav_delay_holds_in_place_for_its_time():
    delay = item(M.MAV_CMD_NAV_DELAY, params=(4.0, -1.0, -1.0, -1.0), frame=MISSION)
    f = fly([waypoint(20.0, 0.0), delay, waypoint(20.0, 20.0)])
    f.run(lambda f: 1 in f.seqs)
    (t0, _), (t1, _) = f.reached
    assert t1 - t0 == pytest.approx(4.0, abs=1.5 * DT)
    during = np.array([p for t, p, _ in f.track if t0 < t <= t1])
    assert np.hypot(during[:, 0] - 20.0, during[:, 1]).max() <= ACC_RAD  # holds at item 0


def test_do_jump_repeats_exactly_n_times():
    """DO_JUMP to item 0 with repeat 2: the loop is flown three times, then the jump completes."""
    plan = [waypoint(20.0, 0.0), waypoint(20.0, 20.0), do_jump(0, 2), waypoint(0.0, 20.0)]
    f = fly(plan)
    f.run(complete, max_s=300)
    assert f.seqs == [0, 1, 0, 1, 0, 1, 2, 3]


def test_do_jump_repeat_zero_never_jumps():
    f = fly([waypoint(20.0, 0.0), do_jump(0, 0), waypoint(0.0, 20.0)])
    f.run(complete)
    assert f.seqs == [0, 1, 2]


def test_do_jump_minus_one_repeats_until_stopped():
    plan = [waypoint(20.0, 0.0), waypoint(20.0, 20.0), do_jump(0, -1), waypoint(0.0, 20.0)]
    f = fly(plan)
    f.run(lambda f: f.seqs.count(1) == 8, max_s=600)
    assert f.executor.state == MissionState.ACTIVE
    assert f.seqs == [0, 1] * 8
    assert 2 not in f.seqs and 3 not in f.seqs


def test_do_jump_counters_restart_with_the_mission():
    """A finished mission activated again flies its jumps again."""
    f = fly([waypoint(20.0, 0.0), waypoint(20.0, 20.0), do_jump(0, 1)])
    f.run(complete, max_s=300)
    assert f.seqs == [0, 1, 0, 1, 2]
    f.executor.activate(landed=False)
    assert f.executor.current == 0
    f.run(complete, max_s=300)
    assert f.seqs == [0, 1, 0, 1, 2] * 2


def test_do_change_speed_sets_the_speed_of_the_following_legs():
    """param2 = 2 m/s: the 40 m leg takes about 20 s instead of 8 s; -1 restores the default."""
    f = fly([change_speed(2.0), waypoint(40.0, 0.0), change_speed(-1.0), waypoint(0.0, 0.0)])
    f.tick()
    assert f.reached[0][1] == 0
    assert f.speed == 2.0
    f.run(lambda f: 1 in f.seqs)
    assert f.reached[-1][0] == pytest.approx((40.0 - ACC_RAD) / 2.0, abs=0.1)
    f.run(complete)
    assert f.speed == CRUISE
    assert f.seqs == [0, 1, 2, 3]


def test_change_speed_stores_nan_for_default():
    ex = MissionExecutor()
    ex.load((change_speed(-1.0),), valid=True)
    ex.activate(landed=False)
    ex.step(StepInput(0.0, ned(0, 0, 10), 0.0, False, ALT0, Tolerances(2, 0.8, 2.5), to_ned))
    assert ex.speed_m_s is not None and math.isnan(ex.speed_m_s)


def test_nav_rtl_item_hands_over_to_rtl_and_completes():
    f = fly([waypoint(20.0, 0.0), item(M.MAV_CMD_NAV_RETURN_TO_LAUNCH, frame=MISSION)])
    f.run(lambda f: f.track and f.track[-1][2].kind == LegKind.RTL)
    assert f.seqs == [0, 1]
    assert f.reached[1][0] == f.track[-1][0]  # reported when RTL starts
    assert f.executor.state == MissionState.COMPLETE
    assert "Mission finished, returning to launch" in f.executor.texts


def test_nav_land_flies_to_the_point_lands_and_completes_when_landed():
    land = item(M.MAV_CMD_NAV_LAND, 20.0, 10.0, math.nan, frame=RELATIVE)
    f = fly([waypoint(20.0, 0.0), land])
    f.run(lambda f: 0 in f.seqs)
    f.tick()
    assert f.executor.landing
    f.run(lambda f: f.landed)
    assert f.executor.state == MissionState.ACTIVE  # the landing is seen on the next tick
    assert np.hypot(f.pos[0] - 20.0, f.pos[1] - 10.0) < 0.1
    assert {leg.kind for t, _, leg in f.track if t > f.reached[0][0]} == {LegKind.LAND}
    f.tick()
    assert f.seqs == [0, 1]
    assert f.executor.state == MissionState.COMPLETE
    assert "Mission finished, landed" in f.executor.texts


@pytest.mark.parametrize(("takeoff_alt", "first_alt"), [(2.5, 15.0), (6.0, 3.0)])
def test_mission_started_on_the_ground_climbs_vertically_first(takeoff_alt, first_alt):
    """Climb over the start to max(MIS_TAKEOFF_ALT, first item's height), then fly the item."""
    f = fly([waypoint(30.0, 0.0, first_alt)], start=(0.0, 0.0, 0.0), takeoff_alt_m=takeoff_alt)
    f.run(complete)
    climb = max(takeoff_alt, first_alt)
    moved = next(i for i, (_, p, _) in enumerate(f.track) if np.hypot(p[0], p[1]) > 0)
    top = -f.track[moved][1][2]
    assert climb - ALT_RAD <= top <= climb
    assert min(p[2] for _, p, _ in f.track) == pytest.approx(-climb, abs=ALT_RAD)
    assert f.seqs == [0]
    assert -f.pos[2] == pytest.approx(first_alt, abs=ALT_RAD)


def test_first_item_altitude_amsl_sets_the_takeoff_height():
    f = fly([waypoint(30.0, 0.0, ALT0 + 12.0, frame=GLOBAL)], start=(0.0, 0.0, 0.0))
    f.run(lambda f: np.hypot(f.pos[0], f.pos[1]) > 0)
    assert -f.pos[2] == pytest.approx(12.0, abs=ALT_RAD)


def test_pause_and_activate_resume_at_the_same_item():
    f = fly([waypoint(20.0, 0.0), waypoint(20.0, 20.0), waypoint(0.0, 20.0)])
    f.run(lambda f: f.seqs == [0])
    f.run(lambda f: np.hypot(f.pos[0] - 20.0, f.pos[1] - 10.0) < 1.0)  # half way to item 1
    f.executor.pause()
    assert f.executor.state == MissionState.PAUSED
    for _ in range(10):
        leg = f.tick()
    assert f.seqs == [0]
    f.executor.activate(landed=False)
    assert (f.executor.current, f.executor.state) == (1, MissionState.ACTIVE)
    f.run(complete)
    assert f.seqs == [0, 1, 2]
    assert leg.kind == LegKind.FLY


def test_activate_after_complete_restarts_at_item_zero():
    f = fly([waypoint(20.0, 0.0), waypoint(20.0, 20.0)])
    f.run(complete)
    f.executor.activate(landed=False)
    assert (f.executor.current, f.executor.state) == (0, MissionState.ACTIVE)
    f.run(complete)
    assert f.seqs == [0, 1, 0, 1]


def test_activate_on_the_ground_after_pause_restarts_at_item_zero():
    f = fly([waypoint(20.0, 0.0), waypoint(20.0, 20.0)])
    f.run(lambda f: f.seqs == [0])
    f.executor.pause()
    f.executor.activate(landed=True)
    assert f.executor.current == 0


def test_no_autocontinue_stops_and_pauses_until_activated():
    f = fly([waypoint(20.0, 0.0, autocontinue=False), waypoint(20.0, 20.0)])
    f.run(lambda f: f.reached)
    assert f.executor.state == MissionState.PAUSED
    assert f.executor.current == 1
    stop = f.pos.copy()
    for _ in range(100):
        f.tick()
    assert f.seqs == [0]
    assert np.hypot(f.pos[0] - 20.0, f.pos[1]) < 0.1 and np.hypot(*(f.pos - stop)[:2]) < ACC_RAD
    f.executor.activate(landed=False)
    f.run(complete)
    assert f.seqs == [0, 1]


def test_set_current_bounds_and_effect():
    f = fly([waypoint(20.0, 0.0), waypoint(20.0, 20.0), waypoint(0.0, 20.0)])
    ex = f.executor
    assert not ex.set_current(-1)
    assert not ex.set_current(3)
    assert ex.current == 0
    assert ex.set_current(2)
    f.run(complete)
    assert f.seqs == [2]
    assert ex.set_current(1)
    assert ex.state == MissionState.PAUSED  # a finished mission becomes resumable


def test_roi_points_the_heading_at_the_roi_until_roi_none():
    roi_lat, roi_lon = offset(0.0, 50.0)
    roi = item(M.MAV_CMD_DO_SET_ROI_LOCATION, 0.0, 50.0, ALT0, frame=GLOBAL)
    plan = [
        roi,
        waypoint(40.0, 0.0),
        item(M.MAV_CMD_DO_SET_ROI_NONE, frame=MISSION),
        waypoint(40.0, 40.0),
    ]
    f = fly(plan)
    f.run(lambda f: 1 in f.seqs)
    first_leg = [(p, leg) for t, p, leg in f.track if t < f.reached[1][0]]
    assert len(first_leg) > 100
    roi_ned = to_ned(roi_lat, roi_lon, ALT0)
    for p, leg in first_leg:
        expected = math.atan2(roi_ned[1] - p[1], roi_ned[0] - p[0])
        assert leg.yaw_rad == pytest.approx(expected, abs=1e-3)
    f.run(lambda f: f.pos[1] > 20.0)
    _, p, leg = f.track[-1]
    travel = math.atan2(40.0 - p[1], 40.0 - p[0])
    assert leg.yaw_rad == pytest.approx(travel, abs=1e-3)  # ROI cleared: face the next waypoint


def test_heading_faces_travel_or_item_yaw():
    f = fly([waypoint(0.0, -30.0), waypoint(30.0, -30.0, params=(0.0, 0.0, 0.0, 45.0))])
    f.run(lambda f: f.t > 1.0)
    assert f.track[-1][2].yaw_rad == pytest.approx(-math.pi / 2, abs=1e-3)  # west
    f.run(lambda f: f.seqs == [0])
    f.tick()
    assert f.track[-1][2].yaw_rad == pytest.approx(math.radians(45.0))


def test_camera_items_are_sent_on_to_the_camera_once_and_the_mission_goes_on():
    """As PX4's navigator: IMAGE_START_CAPTURE (single shots numbered 1, 2, ...), a series and
    IMAGE_STOP_CAPTURE each become one command for compid 100 (param1 names another camera),
    in mission order, when the item starts; the mission does not wait for the camera."""
    start = mavlink2.MAV_CMD_IMAGE_START_CAPTURE
    stop = mavlink2.MAV_CMD_IMAGE_STOP_CAPTURE
    items = [
        waypoint(10, 0),
        item(start, params=(0, 0, 1, 0), frame=MISSION),
        waypoint(20, 0),
        item(start, params=(0, 0, 1, 0), frame=MISSION),
        item(start, params=(101, 2.0, 0, 0), frame=MISSION),
        item(stop, params=(0, 0, 0, 0), frame=MISSION),
        waypoint(30, 0),
    ]
    f = fly(items)
    commands = []

    def collect(fl: Flight) -> bool:
        commands.extend((round(fl.t, 3), c) for c in fl.executor.component_commands)
        fl.executor.component_commands.clear()
        return complete(fl)

    f.run(collect)
    assert f.seqs == list(range(7))
    sent = [
        (c.command, c.target_component, c.params[1], c.params[2], c.params[3]) for _, c in commands
    ]
    assert sent == [
        (start, 100, 0.0, 1.0, 1.0),
        (start, 100, 0.0, 1.0, 2.0),
        (start, 101, 2.0, 0.0, 0.0),
        (stop, 100, 0.0, 0.0, 0.0),
    ]
    reached_at = dict((seq, t) for t, seq in f.reached)
    assert commands[0][0] == pytest.approx(reached_at[1], abs=2 * DT)  # sent as item 1 starts
