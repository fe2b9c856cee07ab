"""Spawn points on surfaces (WorldConfig.spawn_enu_m): truth, home, GPS, baro and mocap agree."""

from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import box as shapely_box

import worlds
from sitl.vehicles.multirotor import load_airframe
from sitl.world import World, WorldConfig

DECK_M = 30.0


def _deck_world() -> worlds.World:
    """A 20 m square platform whose top is DECK_M above the ground, centred on (10, 20)."""
    deck = worlds.Solid("deck", "box", (10.0, 20.0, DECK_M / 2.0), (20.0, 20.0, DECK_M))
    return worlds.World(
        kind="test",
        seed=0,
        size_m=(200.0, 200.0),
        boundary=shapely_box(-100.0, -100.0, 100.0, 100.0),
        surface=worlds.Surface("sea", (0.05, 0.22, 0.35, 1.0), "waves", 8.0, 0.3),
        solids=(deck,),
    )


def test_vehicles_rest_on_the_deck_and_every_sensor_says_so():
    spawn = ((8.0, 20.0, DECK_M), (12.0, 20.0, DECK_M), (-40.0, -40.0, 0.0))
    config = WorldConfig(
        n_vehicles=3, spawn_enu_m=spawn, scene=_deck_world(), mocap_hz=50.0, seed=4
    )
    rest_m = load_airframe("typhoon_h480").ground_clearance_m
    gps_alt, baro_alt, mocap_down = [], [], []
    with World(config) as world:
        homes = [world.home_geodetic(i) for i in range(3)]
        for _ in range(round(2.0 * config.physics_hz)):
            world.step()
            sensors, gps = world.poll_sensors()
            if gps is not None and gps[0].fix_type >= 3:
                gps_alt.append([m.alt * 1e-3 for m in gps])
            if sensors is not None and sensors[0].fields_updated & (1 << 11):
                baro_alt.append([m.pressure_alt for m in sensors])
            mocap_down.extend(s.position_ned_m[:, 2] for s in world.poll_mocap())
        truth = world.truth.position_enu_m
    expected_up = np.array([DECK_M, DECK_M, 0.0]) + rest_m
    np.testing.assert_allclose(truth[:, :2], np.array(spawn)[:, :2], atol=0.01)
    np.testing.assert_allclose(truth[:, 2], expected_up, atol=0.01)  # resting, not falling
    amsl = config.origin_alt_amsl_m + expected_up
    np.testing.assert_allclose([h[2] for h in homes], amsl, atol=1e-6)
    np.testing.assert_allclose(np.mean(gps_alt[-10:], axis=0), amsl, atol=6.0)
    np.testing.assert_allclose(np.mean(baro_alt[-25:], axis=0), amsl, atol=3.0)
    np.testing.assert_allclose(np.mean(mocap_down[-10:], axis=0), -expected_up, atol=0.01)
    # Same seed, same errors: the decks' receivers read 30 m above the ground one's.
    gps_alt = np.array(gps_alt)
    np.testing.assert_allclose(gps_alt[-1, :2] - gps_alt[-1, 2], DECK_M, atol=3.0)


def test_spawn_altitude_is_above_the_spawn_surface():
    config = WorldConfig(spawn_enu_m=((0.0, 0.0, 12.0),), spawn_altitude_m=3.0)
    with World(config) as world:
        assert world.truth.position_enu_m[0, 2] == pytest.approx(15.0)
        assert world.home_geodetic(0)[2] == pytest.approx(config.origin_alt_amsl_m + 15.0)


def test_without_spawn_points_the_layout_is_the_old_one():
    with World(WorldConfig(n_vehicles=3, spacing_m=4.0)) as world:
        np.testing.assert_allclose(world.truth.position_enu_m[:, :2], [[0, 0], [4, 0], [8, 0]])


@pytest.mark.parametrize(
    "spawn",
    [
        ((0.0, 0.0, 0.0),),  # one point for two vehicles
        ((0.0, 0.0), (1.0, 0.0)),  # not triples
        ((0.0, 0.0, 0.0), (float("nan"), 0.0, 0.0)),
        ((0.0, 0.0, 0.0), (float("inf"), 0.0, 0.0)),
        "ab",
    ],
)
def test_bad_spawn_points_name_the_field(spawn):
    with pytest.raises(ValueError, match="spawn_enu_m"):
        WorldConfig(n_vehicles=2, spawn_enu_m=spawn)
