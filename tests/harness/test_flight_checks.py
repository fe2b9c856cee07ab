"""The flight checks pass on a good flight and fail, saying where and how far, on a bad one."""

import math

import numpy as np
import pytest
from shapely.geometry import Polygon
from synthetic_run import IN_AIR, two_vehicle_run

from autopilot_emu.commander_params import CommanderParams
from autopilot_emu.failsafe import FailsafeInput, FailsafeMonitor
from autopilot_emu.params import ParamStore
from harness.report.flight_checks import (
    FAILSAFE_TEXTS,
    assert_landed_and_disarmed,
    assert_max_tilt,
    assert_min_separation,
    assert_no_failsafe,
    assert_reached_altitude,
    assert_stayed_inside,
    assert_waypoints_reached,
    closest_approach,
    failsafe_kind,
    landed_and_disarmed,
    max_tilt,
    min_separation,
    no_failsafe,
    reached_altitude,
    stayed_inside,
    waypoints_reached,
)
from harness.report.flight_log import FlightLog, StateChange

# Vehicle 0 flies (0,0) -> up 10 m -> (20,0) -> (20,20) -> lands; vehicle 1 the same 6 m east.
ROUTE = [(0.0, 0.0, 10.0), (20.0, 0.0, 10.0), (20.0, 20.0, 10.0), (20.0, 20.0, 0.0)]


@pytest.fixture
def log(tmp_path):
    two_vehicle_run(tmp_path / "run")
    return FlightLog.load(tmp_path / "run")


def make_log(tmp_path, **kw):
    two_vehicle_run(tmp_path / "bad", **kw)
    return FlightLog.load(tmp_path / "bad")


# -- waypoints -----------------------------------------------------------------------------------


def test_waypoints_of_the_route_are_reached_in_order(log):
    r = assert_waypoints_reached(log, 0, ROUTE, tolerance_m=0.5)
    assert r.ok and r.value == 4
    assert "vehicle1 reached all 4" in r.message


def test_a_waypoint_off_the_route_is_missed_with_the_closest_approach(log):
    off = [ROUTE[0], (23.0, 0.0, 10.0), ROUTE[2]]  # 3 m beyond the east leg's end at (20, 0)
    r = waypoints_reached(log, 0, off, tolerance_m=2.0)
    assert not r.ok and r.value == 1
    assert "waypoint 1 (23, 0, 10) missed" in r.message
    assert "3.00 m" in r.message
    with pytest.raises(AssertionError, match="vehicle1 reached 1 of 3"):
        assert_waypoints_reached(log, 0, off, tolerance_m=2.0)
    assert waypoints_reached(log, 0, off, tolerance_m=3.1).ok


def test_order_matters_unless_told_otherwise(log):
    backwards = ROUTE[::-1][1:]  # (20,20,10), (20,0,10), (0,0,10): flown the other way round
    assert not waypoints_reached(log, 0, backwards, tolerance_m=0.5).ok
    assert waypoints_reached(log, 0, backwards, tolerance_m=0.5, in_order=False).ok


def test_two_coordinate_waypoints_are_horizontal(log):
    assert waypoints_reached(log, 1, [(6.0, 0.0), (26.0, 20.0)], tolerance_m=0.1).ok
    assert not waypoints_reached(log, 1, [(0.0, 0.0)], tolerance_m=0.1).ok  # vehicle 0's pad
    with pytest.raises(ValueError, match="shape"):
        waypoints_reached(log, 0, [(1.0, 2.0, 3.0, 4.0)], tolerance_m=1.0)


# -- separation ----------------------------------------------------------------------------------


def test_separation_of_parallel_flights_is_their_spacing(log):
    r = assert_min_separation(log, at_least_m=5.0)
    assert r.value == pytest.approx(6.0, abs=1e-3)
    with pytest.raises(AssertionError, match=r"vehicle1 and vehicle2 6\.00 m apart"):
        assert_min_separation(log, at_least_m=8.0)


def test_a_crossing_is_found_with_its_time(tmp_path):
    log = make_log(tmp_path, spacing_m=6.0)
    # Vehicle 2 waits 1 m north of vehicle 1's east leg, which passes (10, 0) at t = 20 s.
    tr = log.vehicles[1].track
    t = tr.time_s
    tr.columns["east_m"][:] = np.where(np.abs(t - 20.0) < 2.0, 10.0, tr["east_m"])
    tr.columns["north_m"][:] = np.where(np.abs(t - 20.0) < 2.0, 1.0, tr["north_m"])
    c = closest_approach(log)
    assert (c.first, c.second) == (0, 1)
    assert c.distance_m == pytest.approx(1.0, abs=0.05)
    assert c.time_s == pytest.approx(20.0, abs=0.05)
    r = min_separation(log, at_least_m=3.0)
    assert not r.ok and "t = 20.0 s" in r.message


def test_airborne_only_ignores_vehicles_on_their_pads(tmp_path):
    log = make_log(tmp_path, spacing_m=1.0)  # pads 1 m apart, 1 m apart in flight too
    assert closest_approach(log).distance_m == pytest.approx(1.0, abs=1e-3)
    # Vehicle 2 stays on its pad: no airborne pair at all.
    tr = log.vehicles[1].track
    tr.columns["landed_state"][:] = 1.0
    tr.columns["up_m"][:] = 0.0
    r = min_separation(log, at_least_m=2.0, airborne_only=True)
    assert r.ok and math.isinf(r.value)
    assert not min_separation(log, at_least_m=2.0).ok


# -- tilt, altitude ------------------------------------------------------------------------------


def test_max_tilt_names_the_vehicle_and_time(tmp_path):
    log = make_log(tmp_path)
    tr = log.vehicles[1].track
    k = int(np.searchsorted(tr.time_s, 30.0))
    tr.columns["tilt_deg"][k] = 41.0
    assert max_tilt(log, at_most_deg=35.0, vehicle=0).ok
    r = max_tilt(log, at_most_deg=35.0)
    assert not r.ok and r.value == 41.0
    with pytest.raises(AssertionError, match=r"41\.0 deg \(vehicle2 at t = 30\.0 s\)"):
        assert_max_tilt(log, at_most_deg=35.0)


def test_reached_altitude(log):
    r = assert_reached_altitude(log, 0, 10.0, tolerance_m=0.1)
    assert r.value == pytest.approx(10.0)
    assert "at t = 14.9 s" in r.message  # climbing 1 m/s from 5 s: 9.9 m at 14.9 s
    r = reached_altitude(log, 0, 12.0, tolerance_m=0.5)
    assert not r.ok and "2.00 m short" in r.message
    with pytest.raises(AssertionError, match="never reached 12"):
        assert_reached_altitude(log, 0, 12.0)


def test_reached_altitude_relative_to_a_raised_start(tmp_path):
    log = make_log(tmp_path)
    tr = log.vehicles[0].track
    tr.columns["up_m"][:] += 20.0  # took off from a 20 m helideck
    assert reached_altitude(log, 0, 30.0, tolerance_m=0.1).ok
    assert reached_altitude(log, 0, 10.0, tolerance_m=0.1, relative_to_start=True).ok
    assert not reached_altitude(log, 0, 15.0, relative_to_start=True).ok


# -- end state -----------------------------------------------------------------------------------


def test_landed_and_disarmed_at_the_end(log):
    r = assert_landed_and_disarmed(log)
    assert r.message == "all 2 vehicles landed and disarmed at the end"


def test_still_flying_at_the_end_fails_with_the_reasons(tmp_path):
    log = make_log(tmp_path)
    tr = log.vehicles[1].track
    tr.columns["landed_state"][-1] = IN_AIR
    tr.columns["armed"][-1] = 1.0
    tr.columns["v_up_m_s"][-1] = -0.8
    assert landed_and_disarmed(log, vehicle=0).ok
    r = landed_and_disarmed(log)
    assert not r.ok and r.value == 1
    for part in ("vehicle2 at the end (t = 50.0 s", "not ON_GROUND", "still armed", "-0.80 m/s"):
        assert part in r.message
    with pytest.raises(AssertionError, match="vehicle2"):
        assert_landed_and_disarmed(log, vehicle=1)


def test_sinking_on_the_ground_is_not_landed(tmp_path):
    """landed_state and armed alone are not enough: truth must be at rest vertically."""
    log = make_log(tmp_path)
    log.vehicles[0].track.columns["v_up_m_s"][-1] = 0.5
    assert not landed_and_disarmed(log).ok
    assert landed_and_disarmed(log, max_vertical_speed_m_s=0.6).ok


def test_a_crashed_vehicle_needs_only_to_be_disarmed(tmp_path):
    """A fault's crash is no landing: still falling at the end is fine, still armed is not."""
    log = make_log(tmp_path)
    tr = log.vehicles[1].track
    tr.columns["landed_state"][-1] = IN_AIR
    tr.columns["v_up_m_s"][-1] = -9.0
    assert not landed_and_disarmed(log).ok
    r = landed_and_disarmed(log, crashed=(1,))
    assert r.ok and r.message.endswith("(vehicle2 crashed: judged on disarming only)")
    assert not landed_and_disarmed(log, crashed=(0,)).ok  # the other one is judged as ever
    tr.columns["armed"][-1] = 1.0
    r = landed_and_disarmed(log, crashed=(1,))
    assert not r.ok and "still armed" in r.message and "ON_GROUND" not in r.message


# -- failsafes -----------------------------------------------------------------------------------


def test_failsafe_texts_fail_the_check_with_vehicle_and_time(tmp_path):
    texts = [
        (0, 3.0, 6, "Armed by external command"),
        (1, 21.5, 2, "Failsafe activated: switching to Return"),
        (1, 21.5, 4, "Low battery level, return advised"),
    ]
    log = make_log(tmp_path, texts=texts)
    r = no_failsafe(log)
    assert not r.ok and r.value == 2
    assert 'vehicle2 at t = 21.5 s: "Failsafe activated: switching to Return"' in r.message
    assert no_failsafe(log, vehicle=0).ok
    assert no_failsafe(log, allow=("failsafe_action", "battery_low")).ok
    with pytest.raises(AssertionError, match="2 failsafe text"):
        assert_no_failsafe(log)
    with pytest.raises(ValueError, match="battery_lo"):
        no_failsafe(log, allow=("battery_lo",))


def test_a_datalink_loss_counts_in_the_air_not_after_disarming(tmp_path):
    """PX4 announces a lost ground station on the ground too, but acts on it in the air only."""
    texts = [
        (0, 12.0, 2, "Connection to ground station lost"),
        (1, 30.0, 2, "Connection to ground station lost"),
    ]
    log = make_log(tmp_path, texts=texts)
    for v in log.vehicles:
        v.state_changes[:] = [
            StateChange(1.0, False, "AUTO_LOITER"),
            StateChange(5.0, True, "AUTO_LOITER"),
            StateChange(25.0, False, "AUTO_LOITER"),
        ]
    r = no_failsafe(log)
    assert not r.ok and r.value == 1 and "vehicle1 at t = 12.0 s" in r.message
    log.vehicles[0].state_changes.clear()  # armed state unknown: counted
    assert no_failsafe(log).value == 1


def test_failsafes_after_a_fault_took_the_vehicle_are_excused(tmp_path):
    """What a vehicle announces from its injected fault on is the fault's; before, the flight's."""
    texts = [
        (1, 10.0, 4, "Low battery level, return advised"),
        (1, 30.0, 2, "Failsafe activated: switching to Land"),
    ]
    log = make_log(tmp_path, texts=texts)
    assert no_failsafe(log).value == 2
    r = no_failsafe(log, excused_from_s={1: 30.0})
    assert not r.ok and r.value == 1 and "t = 10.0 s" in r.message
    assert no_failsafe(log, excused_from_s={1: 5.0}).ok
    assert no_failsafe(log, excused_from_s={0: 5.0}).value == 2  # another vehicle's fault


def test_a_quiet_flight_has_no_failsafe(log):
    assert assert_no_failsafe(log).value == 0


def test_the_table_knows_every_failsafe_text_the_emulator_sends():
    """Drive the emulator's FailsafeMonitor through every condition: each warning or critical
    text it announces is in FAILSAFE_TEXTS, each recovery text is not."""
    store = ParamStore({"NAV_DLL_ACT": 2, "COM_LOW_BAT_ACT": 3, "GF_ACTION": 3})
    m = FailsafeMonitor(CommanderParams.from_params(store))

    def tick(t, battery=0.9, position_ok=True, fence=False, gcs=0.0):
        m.update(FailsafeInput(t, True, True, False, battery, position_ok, fence, gcs))

    tick(1.0)
    tick(60.0)  # data link lost (COM_DL_LOSS_T 10 s)
    tick(61.0, gcs=61.0)  # regained
    for t, level in ((62.0, 0.14), (63.0, 0.06), (64.0, 0.02)):  # low, critical, emergency
        tick(t, battery=level, gcs=t)
    tick(65.0, battery=0.02, position_ok=False, gcs=65.0)
    tick(66.0, battery=0.02, gcs=66.0)
    tick(67.0, battery=0.02, fence=True, gcs=67.0)
    tick(68.0, battery=0.02, gcs=68.0)
    kinds = set()
    for severity, text in m.texts:
        kind = failsafe_kind(text)
        assert (kind is not None) == (severity <= 4), (severity, text)
        kinds.add(kind)
    assert kinds - {None} == set(FAILSAFE_TEXTS) - {"offboard_lost"}


# -- geometry ------------------------------------------------------------------------------------


def test_stayed_inside_a_box_around_the_route(log):
    box = Polygon([(-1, -1), (27, -1), (27, 21), (-1, 21)])
    assert assert_stayed_inside(log, box).value == 0.0
    tight = Polygon([(-1, -1), (24, -1), (24, 21), (-1, 21)])  # vehicle 2 flies to east 26 m
    r = stayed_inside(log, tight)
    assert not r.ok and r.value == pytest.approx(2.0, abs=1e-6)
    assert "vehicle2 went 2.00 m outside" in r.message
    assert stayed_inside(log, tight, vehicle=0).ok
    assert stayed_inside(log, tight, margin_m=2.5).ok
    with pytest.raises(AssertionError, match="outside the polygon at t = 25"):
        assert_stayed_inside(log, tight)


def test_a_hole_in_the_polygon_is_outside(log):
    outer = [(-10, -10), (40, -10), (40, 40), (-10, 40)]
    hole = [(8, -3), (12, -3), (12, 3), (8, 3)]  # vehicle 1's east leg crosses it
    r = stayed_inside(log, Polygon(outer, [hole]), vehicle=0)
    assert not r.ok and r.value == pytest.approx(2.0, abs=1e-3)  # (10, 0): 2 m from the edges
