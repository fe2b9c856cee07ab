"""RTL: the destination is the nearest of home and the rally points; the phases follow in order."""

import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu import geodesy
from autopilot_emu.mission.items import MissionItem
from autopilot_emu.modes.nav_types import Home, NavInput
from autopilot_emu.modes.rtl import Rtl, RtlPhase, destination

ORIGIN = np.array([47.397742, 8.545594, 488.0])


def rally(lat, lon):
    return MissionItem(mavlink2.MAV_CMD_NAV_RALLY_POINT, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                       (0.0, 0.0, 0.0, 0.0), round(lat * 1e7), round(lon * 1e7), 0.0)  # fmt: skip


@pytest.mark.parametrize("seed", range(5))
def test_destination_is_the_nearest_of_home_and_the_rally_points(seed):
    rng = np.random.default_rng(seed)
    home = Home(np.array([*rng.uniform(-50, 50, 2), 0.0]), 488.0)
    here = np.array([*rng.uniform(-200, 200, 2), -20.0])
    points = [rally(*(ORIGIN[:2] + rng.uniform(-2e-3, 2e-3, 2))) for _ in range(4)]
    best, index = destination(here, home, points, ORIGIN)
    candidates = [home.position_ned_m[:2]] + [
        geodesy.geodetic_to_ned(np.array([p.lat_deg, p.lon_deg, 0.0]), ORIGIN)[:2] for p in points
    ]
    dists = [math.dist(c, here[:2]) for c in candidates]
    nearest = int(np.argmin(dists))
    assert (index is None) == (nearest == 0) and (index is None or index == nearest - 1)
    assert best == pytest.approx(candidates[nearest], abs=1e-6)
    assert destination(here, home, points, None)[1] is None  # no origin: home


def test_phases_climb_return_then_land_at_the_destination():
    texts = []
    rtl = Rtl(lambda s, t: texts.append(t))
    home = Home(np.zeros(3), 488.0)
    nav = NavInput(0.0, np.array([30.0, 40.0, -5.0]), np.zeros(3), 0.0, True, 0.5, 488.0)
    target, text = rtl.start(nav, home, 20.0, [], ORIGIN)
    assert target == pytest.approx([30.0, 40.0, -20.0]) and rtl.phase == RtlPhase.CLIMB
    assert text == "RTL: return to home at 20 m"
    assert rtl.step(nav, target, 2.0) is target  # not up yet
    nav.position_ned_m = np.array([30.0, 40.0, -19.8])
    target = rtl.step(nav, target, 2.0)
    assert target == pytest.approx([0.0, 0.0, -20.0]) and rtl.phase == RtlPhase.RETURN
    nav.position_ned_m = np.array([0.5, 0.0, -20.0])
    target = rtl.step(nav, target, 2.0)
    assert rtl.landing and target[:2] == pytest.approx([0.0, 0.0]) and math.isnan(target[2])
    assert texts == ["RTL: returning", "RTL: landing"]
