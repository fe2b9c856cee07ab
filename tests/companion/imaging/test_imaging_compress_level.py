"""Seed 000's T_compress policy: bandwidth and energy bound the level; hysteresis stops flapping."""

from __future__ import annotations

import math

import pytest

from companion.imaging.compress_level import (
    LevelController,
    LevelPolicyParams,
    budget_bytes,
    choose_level,
    energy_per_image_j,
    expected_bytes,
)
from companion.imaging.link_budget import LTE_UPLINK, WIFI_EDGE_FOG, LinkBudget

BPP = {1: 0.1, 2: 0.25, 3: 0.5, 4: 1.0, 5: 2.0}
PIXELS = 320 * 240
NO_HOLD = LevelPolicyParams(min_hold_images=0, up_headroom=1.0)


def level_for(bandwidth_bytes_s, energy_j=math.inf, params=NO_HOLD, j_per_byte=1e-6):
    budget = budget_bytes(bandwidth_bytes_s, 1.0, j_per_byte, energy_j, 0.0, params)
    return choose_level(None, 0, budget, PIXELS, BPP, params)


def test_more_bandwidth_never_lowers_the_level():
    """The level is monotone in the bandwidth and reaches both ends of the range."""
    bandwidths = [10 ** (k / 4) for k in range(4 * 2, 4 * 6)]  # 100 B/s .. 1 MB/s
    levels = [level_for(b) for b in bandwidths]
    assert levels == sorted(levels)
    assert levels[0] == 1 and levels[-1] == 5


def test_the_chosen_level_fits_the_bandwidth_and_the_next_does_not():
    """At 5 kB/s with half of it for images, 2.5 kB per image: level 2 (2.6 kB) no longer fits."""
    params = LevelPolicyParams(min_hold_images=0, overhead_bytes=200)
    budget = budget_bytes(5000.0, 1.0, 0.0, math.inf, 0.0, params)
    assert budget == pytest.approx(2500.0)
    level = choose_level(None, 0, budget, PIXELS, BPP, params)
    assert expected_bytes(level, PIXELS, BPP, 200) <= budget
    assert level == 5 or expected_bytes(level + 1, PIXELS, BPP, 200) > budget
    assert level == 1  # 0.1 bpp x 76800 / 8 + 200 = 1160 B; level 2: 2600 B


def test_less_energy_lowers_the_level():
    """Same bandwidth; the energy per image shrinking drives the level down to the lowest."""
    energies = [10.0, 0.1, 0.02, 0.005, 0.001]  # J per image, 1e-6 J/B: 1e7 .. 1e3 bytes
    levels = [level_for(1e9, e) for e in energies]
    assert levels == sorted(levels, reverse=True)
    assert levels[0] == 5 and levels[-1] == 1


def test_the_encode_energy_comes_out_of_the_energy_budget():
    """An expensive encode leaves fewer joules for the radio: a lower level."""
    params = NO_HOLD
    cheap = budget_bytes(1e9, 1.0, 1e-6, 0.02, 0.0, params)
    costly = budget_bytes(1e9, 1.0, 1e-6, 0.02, 0.015, params)
    assert costly == pytest.approx(cheap / 4)
    assert choose_level(None, 0, costly, PIXELS, BPP, params) < choose_level(
        None, 0, cheap, PIXELS, BPP, params
    )


def test_energy_per_image_spreads_what_is_left_over_the_images_left():
    assert energy_per_image_j(None, 10.0, 1.0) == math.inf
    assert energy_per_image_j(100.0, 50.0, 5.0) == pytest.approx(10.0)
    assert energy_per_image_j(100.0, 0.0, 5.0) == pytest.approx(100.0)  # the last image
    assert energy_per_image_j(-3.0, 50.0, 5.0) == 0.0  # overspent: nothing left


def test_lte_costs_a_thousand_times_wifi_per_byte():
    """J/byte from seed 000 Table I powers and the link presets' rates."""
    assert WIFI_EDGE_FOG.j_per_byte == pytest.approx(1.0 / 65e6)
    assert LTE_UPLINK.j_per_byte == pytest.approx(100.0 / 6.25e6)
    assert LTE_UPLINK.j_per_byte / WIFI_EDGE_FOG.j_per_byte > 1000
    with pytest.raises(ValueError, match="rate_bytes_s"):
        LinkBudget(0.0, 1.0)


def test_hysteresis_holds_the_level_in_the_dead_band():
    """A budget wobbling around a level boundary changes the level once, not at every image."""
    controller = LevelController(BPP, LevelPolicyParams(up_headroom=0.8, min_hold_images=2))
    boundary = expected_bytes(4, PIXELS, BPP, 200)  # level 4 just fits at this budget
    levels = []
    for k in range(40):
        wobble = 1.0 + (0.1 if k % 2 else -0.1)  # +-10 %: inside the 20 % headroom
        bandwidth = 2 * boundary * wobble  # link_share 0.5, period 1 s
        levels.append(controller.next_level(PIXELS, bandwidth, 1.0, 0.0))
    assert controller.changes <= 1
    assert set(levels[2:]) == {3}


def test_without_hysteresis_the_same_budget_flaps():
    """The control for the test above: no headroom, no hold, and the level follows every wobble."""
    controller = LevelController(BPP, NO_HOLD)
    boundary = expected_bytes(4, PIXELS, BPP, 200)
    for k in range(40):
        bandwidth = 2 * boundary * (1.0 + (0.1 if k % 2 else -0.1))
        controller.next_level(PIXELS, bandwidth, 1.0, 0.0)
    assert controller.changes >= 30


def test_a_level_that_no_longer_fits_is_left_at_once_and_regained_after_the_hold():
    params = LevelPolicyParams(up_headroom=0.8, min_hold_images=3)
    controller = LevelController(BPP, params)
    assert controller.next_level(PIXELS, 1e9, 1.0, 0.0) == 5
    assert controller.next_level(PIXELS, 1000.0, 1.0, 0.0) == 1  # collapse: down at once
    ups = [controller.next_level(PIXELS, 1e9, 1.0, 0.0) for _ in range(4)]
    assert ups == [1, 1, 5, 5]  # held for 3 images at level 1, then up


def test_a_relayed_image_is_never_recompressed_above_its_level():
    controller = LevelController(BPP, NO_HOLD)
    assert controller.next_level(PIXELS, 1e9, 1.0, 0.0, cap=3) == 3
    assert controller.next_level(PIXELS, 1000.0, 1.0, 0.0, cap=3) == 1


def test_bad_parameters_name_the_field():
    with pytest.raises(ValueError, match="link_share"):
        LevelPolicyParams(link_share=0.0)
    with pytest.raises(ValueError, match="up_headroom"):
        LevelPolicyParams(up_headroom=1.5)
    with pytest.raises(ValueError, match="image_period_s"):
        budget_bytes(1.0, 0.0, 0.0, math.inf, 0.0, NO_HOLD)
    with pytest.raises(ValueError, match="pixels"):
        choose_level(None, 0, 1e6, 0, BPP, NO_HOLD)
    with pytest.raises(ValueError, match="bits_per_pixel"):
        LevelController({})


def test_images_larger_than_forecast_teach_the_controller_to_pick_lower():
    """Scenes that compress to twice the codec's mean bits: the level drops once seen."""
    controller = LevelController(BPP, NO_HOLD)
    budget_bandwidth = 2 * expected_bytes(4, PIXELS, BPP, 200)  # level 4 fits as forecast
    assert controller.next_level(PIXELS, budget_bandwidth, 1.0, 0.0) == 4
    for _ in range(10):
        level = controller.next_level(PIXELS, budget_bandwidth, 1.0, 0.0)
        controller.observe(level, PIXELS, int(2 * BPP[level] * PIXELS / 8))
    assert controller.size_ratio == pytest.approx(2.0, rel=0.05)
    assert controller.level == 3  # level 4 at twice its forecast no longer fits
    with pytest.raises(ValueError, match="size_learning_rate"):
        LevelPolicyParams(size_learning_rate=2.0)
