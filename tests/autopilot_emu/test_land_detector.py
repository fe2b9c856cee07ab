"""Land detector: lift-off and touch-down from the estimate and the thrust command."""

import numpy as np

from autopilot_emu.land_detector import LANDED_AFTER_S, LandDetector
from autopilot_emu.modes import LandedState
from autopilot_emu.modes.nav_types import Home, NavInput


def nav(t, z=0.0, vz=0.0, thrust=0.0, hover=0.5):
    return NavInput(t, np.array([0.0, 0.0, z]), np.array([0.0, 0.0, vz]), 0.0, True, thrust, 488.0,
                    hover_thrust=hover)  # fmt: skip


HOME = Home(np.zeros(3), 488.0)


def test_touch_down_needs_the_landed_conditions_for_the_whole_interval():
    """Still and on low thrust for less than LANDED_AFTER_S: still flying; a bump restarts it."""
    texts = []
    det = LandDetector(lambda s, t: texts.append(t))
    state, t, dt = LandedState.IN_AIR, 0.0, 0.02
    while t < 0.8 * LANDED_AFTER_S:
        state = det.update(nav(t, thrust=0.1), state, True, False, HOME)
        t += dt
    assert state == LandedState.IN_AIR
    state = det.update(nav(t, vz=1.0, thrust=0.1), state, True, False, HOME)  # a bounce
    start = t = t + dt
    while state == LandedState.IN_AIR:
        state = det.update(nav(t, thrust=0.1), state, True, False, HOME)
        t += dt
    assert t - dt - start >= LANDED_AFTER_S - 1e-9
    assert state == LandedState.ON_GROUND and texts == ["Landing detected"]
    assert det.ground_since_s == t - dt


def test_hovering_on_the_hover_thrust_is_not_landed():
    det = LandDetector(lambda s, t: None)
    state = LandedState.IN_AIR
    for k in range(500):
        state = det.update(nav(k * 0.02, z=-5.0, thrust=0.5), state, True, False, HOME)
    assert state == LandedState.IN_AIR


def test_a_take_off_is_in_the_air_above_half_a_metre_or_climbing():
    det = LandDetector(lambda s, t: None)
    taking_off = LandedState.TAKEOFF
    assert det.update(nav(0.0, z=-0.4), taking_off, True, False, HOME) == taking_off
    assert det.update(nav(0.0, z=-0.6), taking_off, True, False, HOME) == LandedState.IN_AIR
    assert det.update(nav(0.0, vz=-0.6), taking_off, True, False, HOME) == LandedState.IN_AIR
    assert det.update(nav(0.0, z=-5.0), taking_off, False, False, HOME) == LandedState.ON_GROUND
