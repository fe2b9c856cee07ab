"""Failsafe conditions and PX4's actions for them (commander/failsafe/failsafe.cpp)."""

import math

import pytest

from autopilot_emu.commander_params import CommanderParams
from autopilot_emu.failsafe import Action, BatteryLevel, FailsafeInput, FailsafeMonitor
from autopilot_emu.params import ParamStore


def inp(
    t=0.0,
    armed=True,
    in_air=True,
    landing=False,
    battery=math.nan,
    position_ok=True,
    fence=False,
    gcs=None,
):
    return FailsafeInput(t, armed, in_air, landing, battery, position_ok, fence, gcs)


def monitor(**params):
    return FailsafeMonitor(CommanderParams.from_params(ParamStore(params)))


def texts(m):
    out = [text for _, text in m.texts]
    m.texts.clear()
    return out


def activated(m):
    return [t for _, t in m.texts if t.startswith("Failsafe activated")]


# -- data link -------------------------------------------------------------------------------


def test_nothing_happens_before_a_gcs_was_ever_heard():
    m = monitor(NAV_DLL_ACT=2)
    for t in range(0, 100, 5):
        assert m.update(inp(float(t))) == Action.NONE
    assert m.texts == [] and not m.datalink_lost


def test_data_link_lost_only_after_com_dl_loss_t():
    """COM_DL_LOSS_T = 7 s after the last GCS heartbeat at t = 3 s: lost after t = 10 s."""
    m = monitor(NAV_DLL_ACT=2, COM_DL_LOSS_T=7)
    t = 3.0
    while t <= 10.0:
        assert m.update(inp(t, gcs=3.0)) == Action.NONE, t
        t = round(t + 0.02, 2)
    assert not m.datalink_lost and m.texts == []
    assert m.update(inp(t, gcs=3.0)) == Action.RTL
    assert m.datalink_lost
    assert "Connection to ground station lost" in texts(m)


@pytest.mark.parametrize(
    ("dll_act", "action"),
    [
        (0, Action.NONE),
        (1, Action.HOLD),
        (2, Action.RTL),
        (3, Action.LAND),
        (4, Action.NONE),  # not a valid NAV_DLL_ACT in PX4
        (5, Action.TERMINATE),
        (6, Action.DISARM),
    ],
)
def test_data_link_loss_action_follows_nav_dll_act(dll_act, action):
    m = monitor(NAV_DLL_ACT=dll_act)
    assert m.update(inp(20.0, gcs=0.0)) == action
    assert "Connection to ground station lost" in [t for _, t in m.texts]


@pytest.mark.parametrize(
    ("armed", "in_air", "landing"),
    [(False, False, False), (True, False, False), (True, True, True)],
)
def test_data_link_loss_only_acts_armed_in_air_and_not_landing(armed, in_air, landing):
    m = monitor(NAV_DLL_ACT=2)
    assert m.update(inp(20.0, armed, in_air, landing, gcs=0.0)) == Action.NONE
    assert texts(m) == ["Connection to ground station lost"]  # still announced


def test_data_link_loss_acts_once_then_regained_is_announced():
    m = monitor(NAV_DLL_ACT=3)
    assert m.update(inp(20.0, gcs=0.0)) == Action.LAND
    texts(m)
    for t in (20.02, 25.0, 60.0):
        assert m.update(inp(t, gcs=0.0)) == Action.NONE
    assert texts(m) == []
    assert m.update(inp(61.0, gcs=61.0)) == Action.NONE
    assert texts(m) == ["GCS connection regained"]
    assert not m.datalink_lost
    assert m.update(inp(80.0, gcs=61.0)) == Action.LAND  # a second loss acts again


# -- battery ---------------------------------------------------------------------------------

LEVELS = [(0.12, BatteryLevel.LOW), (0.06, BatteryLevel.CRITICAL), (0.03, BatteryLevel.EMERGENCY)]
"""State of charge in each band of the defaults (BAT_LOW_THR 0.15, CRIT 0.07, EMERGEN 0.05)."""
BATTERY_TEXTS = [
    "Low battery level, return advised",
    "Critical battery level, land now",
    "Emergency battery level, land immediately",
]


@pytest.mark.parametrize(
    ("low_bat_act", "actions"),
    [
        (0, (Action.WARN, Action.WARN, Action.WARN)),
        (1, (Action.WARN, Action.RTL, Action.RTL)),
        (2, (Action.WARN, Action.LAND, Action.LAND)),
        (3, (Action.WARN, Action.RTL, Action.LAND)),
    ],
)
def test_battery_levels_and_com_low_bat_act(low_bat_act, actions):
    """Each level is announced when entered and acts per COM_LOW_BAT_ACT (PX4 v1.14 table)."""
    m = monitor(COM_LOW_BAT_ACT=low_bat_act)
    assert m.update(inp(0.0, battery=0.5)) == Action.NONE
    assert texts(m) == []
    for i, ((charge, level), action, text) in enumerate(
        zip(LEVELS, actions, BATTERY_TEXTS, strict=True)
    ):
        assert m.update(inp(1.0 + i, battery=charge)) == action
        assert m.battery_level == level
        said = texts(m)
        assert said[0] == text
        if action > Action.WARN:
            name = {Action.RTL: "Return", Action.LAND: "Land"}[action]
            assert said[1:] == [f"Failsafe activated: switching to {name}"]
        else:
            assert said[1:] == []


def test_battery_level_acts_once_while_it_stays():
    m = monitor(COM_LOW_BAT_ACT=2)
    assert m.update(inp(0.0, battery=0.06)) == Action.LAND
    texts(m)
    for t, charge in [(1.0, 0.06), (2.0, 0.065), (3.0, 0.069), (4.0, 0.10)]:
        assert m.update(inp(t, battery=charge)) == Action.NONE  # even back in the low band
    assert texts(m) == []
    assert m.update(inp(5.0, battery=0.04)) == Action.LAND  # worse: acts again
    assert texts(m)[0] == BATTERY_TEXTS[2]


def test_battery_jumping_straight_to_emergency_announces_that_level():
    m = monitor(COM_LOW_BAT_ACT=3)
    assert m.update(inp(0.0, battery=0.01)) == Action.LAND
    assert texts(m)[0] == BATTERY_TEXTS[2]


def test_battery_unknown_or_on_ground_does_not_act():
    m = monitor(COM_LOW_BAT_ACT=2)
    assert m.update(inp(0.0, battery=math.nan)) == Action.NONE
    assert m.update(inp(1.0, armed=True, in_air=False, battery=0.06)) == Action.NONE
    assert texts(m) == [BATTERY_TEXTS[1]]


def test_new_battery_resets_the_level():
    m = monitor(COM_LOW_BAT_ACT=2)
    m.update(inp(0.0, battery=0.06))
    assert m.update(inp(1.0, battery=1.0)) == Action.NONE
    assert m.battery_level == BatteryLevel.OK
    assert m.update(inp(2.0, battery=0.06)) == Action.LAND


# -- position --------------------------------------------------------------------------------


def test_position_loss_lands_only_in_air():
    m = monitor()
    assert m.update(inp(0.0, in_air=False, position_ok=False)) == Action.NONE
    assert texts(m) == []
    assert m.update(inp(1.0, position_ok=False)) == Action.LAND
    assert texts(m) == ["No global position: GPS lost", "Failsafe activated: switching to Land"]
    assert m.update(inp(2.0, position_ok=False)) == Action.NONE
    assert m.update(inp(3.0, position_ok=True)) == Action.NONE
    assert texts(m) == ["Global position regained"]


def test_landing_without_position_does_not_claim_it_was_regained():
    """Lost in the air, then landed (or disarmed) still without GPS: no "regained" text."""
    m = monitor()
    assert m.update(inp(0.0, position_ok=False)) == Action.LAND
    texts(m)
    assert m.update(inp(5.0, in_air=False, position_ok=False)) == Action.NONE
    assert m.update(inp(6.0, armed=False, in_air=False, position_ok=False)) == Action.NONE
    assert texts(m) == []


# -- geofence --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("gf_action", "action"),
    [
        (0, Action.NONE),
        (1, Action.WARN),
        (2, Action.HOLD),
        (3, Action.RTL),
        (4, Action.TERMINATE),
        (5, Action.LAND),
    ],
)
def test_geofence_breach_action_follows_gf_action(gf_action, action):
    m = monitor(GF_ACTION=gf_action)
    assert m.update(inp(0.0, fence=True)) == action
    assert next(t for _, t in m.texts) == "Geofence violation"
    assert bool(activated(m)) == (action > Action.WARN)


def test_geofence_breach_on_the_ground_is_only_announced_and_ok_is_announced():
    m = monitor(GF_ACTION=3)
    assert m.update(inp(0.0, armed=False, in_air=False, fence=True)) == Action.NONE
    assert m.update(inp(1.0, fence=True)) == Action.NONE  # still the same breach
    assert m.update(inp(2.0, fence=False)) == Action.NONE
    assert texts(m) == ["Geofence violation", "Geofence OK"]
    assert m.update(inp(3.0, fence=True)) == Action.RTL


# -- combination -----------------------------------------------------------------------------


def test_most_severe_action_wins_when_two_conditions_start_together():
    """Data link (Hold) and critical battery (Land) in one tick: Land, announced once."""
    m = monitor(NAV_DLL_ACT=1, COM_LOW_BAT_ACT=2)
    assert m.update(inp(20.0, battery=0.06, gcs=0.0)) == Action.LAND
    said = texts(m)
    assert "Connection to ground station lost" in said and BATTERY_TEXTS[1] in said
    assert [t for t in said if t.startswith("Failsafe")] == [
        "Failsafe activated: switching to Land"
    ]


def test_geofence_terminate_beats_battery_return():
    m = monitor(GF_ACTION=4, COM_LOW_BAT_ACT=1)
    assert m.update(inp(0.0, battery=0.06, fence=True)) == Action.TERMINATE
    assert activated(m) == ["Failsafe activated: switching to Terminate"]


def test_warning_actions_do_not_announce_a_failsafe():
    m = monitor(GF_ACTION=1, COM_LOW_BAT_ACT=0)
    assert m.update(inp(0.0, battery=0.06, fence=True)) == Action.WARN
    assert activated(m) == []
    assert len(m.texts) == 2
