"""harness.sim.world_setup: a world's launch area, wind, mocap and parameters for a run."""

from __future__ import annotations

import math

import numpy as np
import pytest

import worlds
from harness.sim.simulation import Simulation, SimulationConfig
from harness.sim.world_setup import (
    GPS_DENIED_MOCAP_HZ,
    WorldSetup,
    wind_config,
    world_config,
    world_setup,
)
from sitl.physics.wind import WindField
from worlds.examples import example_path


def _world(kind: str) -> worlds.World:
    return worlds.build(worlds.load_world(example_path(kind)))


@pytest.fixture(scope="module")
def offshore() -> worlds.World:
    return _world("offshore")


def test_offshore_vehicles_start_on_the_helideck_in_the_sea_wind(offshore):
    setup = world_setup(offshore, 3, spacing_m=3.0)
    deck = offshore.launch_area("helideck")
    assert isinstance(setup, WorldSetup) and setup.launch_area == "helideck"
    assert setup.scene is offshore
    assert world_config(3, setup).spawn_enu_m == setup.spawn_enu_m
    assert len(setup.spawn_enu_m) == 3
    for x, y, z in setup.spawn_enu_m:
        assert math.dist((x, y), deck.center_enu_m[:2]) <= deck.radius_m
        assert z == deck.center_enu_m[2]
    assert not setup.bridge and setup.mocap_hz == 0.0 and setup.params == {}
    assert setup.gps_outages is None and world_config(3, setup).mocap_hz == 0.0
    np.testing.assert_allclose(setup.wind.steady_enu_m_s, offshore.wind.velocity_enu_m_s)


def test_the_gust_spread_becomes_turbulence_of_that_spread_at_20_ft():
    """400 vehicles 20 ft up in the converted wind: the horizontal wind's standard deviation
    about its mean is the world's gust_std_m_s, on each horizontal axis."""
    hint = worlds.Wind(speed_m_s=6.0, from_direction_deg=250.0, gust_std_m_s=1.5)
    config = wind_config(hint)
    assert config.gust_peak_m_s == 0.0
    n = 400
    field = WindField(config, n, 1.0 / config.update_hz, np.random.default_rng(3))
    position = np.tile([0.0, 0.0, 6.096], (n, 1))
    samples = []
    for k in range(1000):  # 10 s
        field.update(position, np.zeros((n, 3)))
        if k % 100 == 99:
            samples.append(field.velocity_enu_m_s[:, :2] - config.steady_enu_m_s[:2])
    std = np.concatenate(samples).std(axis=0)
    np.testing.assert_allclose(std, [1.5, 1.5], rtol=0.06)


def test_calm_or_missing_wind_is_calm_air():
    assert wind_config(None) is None
    assert wind_config(worlds.Wind(0.0, 90.0, 0.0)) is None
    steady = wind_config(worlds.Wind(4.0, 90.0, 0.0))
    assert steady.turbulence_w20_m_s == 0.0
    np.testing.assert_allclose(steady.steady_enu_m_s, [-4.0, 0.0, 0.0], atol=1e-12)


def test_a_gps_denied_world_gets_mocap_no_gnss_and_external_vision():
    indoor = _world("indoor")
    setup = world_setup(indoor, 3, spacing_m=1.2)
    assert setup.bridge and setup.mocap_hz == GPS_DENIED_MOCAP_HZ
    world = world_config(3, setup)
    assert world.mocap_hz == GPS_DENIED_MOCAP_HZ and world.scene is indoor
    assert world_config(3, setup, mocap_hz=100.0).mocap_hz == 100.0  # up --mocap 100
    outages = world.gps_outages
    assert outages.scripted(0.0, np.arange(3)).all()
    assert outages.scripted(1.0e6, np.arange(3)).all()
    assert setup.params["EKF2_EV_CTRL"] == 9.0
    assert setup.launch_area == "safe_point"
    assert setup.wind is None


def test_a_task_map_starts_each_agent_at_its_own_start():
    taskmap = _world("taskmap")
    setup = world_setup(taskmap, 3)
    starts = [taskmap.launch_area(f"agent_start_{k}").center_enu_m for k in range(3)]
    assert setup.spawn_enu_m == tuple(starts)
    named = world_setup(taskmap, 1, launch_area="agent_start_2")
    assert named.spawn_enu_m == (starts[2],)


def test_bad_launch_areas_are_named(offshore):
    with pytest.raises(ValueError, match=r"no launch area 'pier'; there are \['helideck'\]"):
        world_setup(offshore, 1, launch_area="pier")
    with pytest.raises(ValueError, match=r"'helideck' \(radius 8\.8 m\) cannot hold 40"):
        world_setup(offshore, 40)


def test_params_are_applied_over_the_airframe_and_unknown_ones_refused():
    # MC_ROLLRATE_P is set by typhoon_h480's airframe (0.08): the run's value wins.
    config = SimulationConfig(
        n_vehicles=2,
        mavlink=False,
        record_hz=0,
        params={"MC_ROLLRATE_P": 0.1, "MIS_TAKEOFF_ALT": 4},
    )
    with Simulation(config) as sim:
        for store in sim.fleet.params:
            assert store.get("MC_ROLLRATE_P") == pytest.approx(0.1)
            assert store.get("MIS_TAKEOFF_ALT") == pytest.approx(4.0)
    with pytest.raises(ValueError, match="EKF2_NOPE"):
        SimulationConfig(params={"EKF2_NOPE": 1.0})
    with pytest.raises(ValueError, match="EKF2_EV_CTRL"):
        SimulationConfig(params={"EKF2_EV_CTRL": 99})


@pytest.fixture(scope="module")
def deck_flight(offshore):
    """Arm, take off and land from the offshore helideck in the world's wind, in lockstep."""
    setup = world_setup(offshore, 1)
    config = SimulationConfig(
        mavlink=False,
        record_hz=0,
        seed=1,
        wind=setup.wind,
        world=world_config(1, setup),
        params=setup.params,
    )
    out = {}
    with Simulation(config) as sim:
        vehicle = sim.fleet.vehicle(0)
        out["start"] = sim.world.truth.position_enu_m[0].copy()
        out["home_geodetic"] = sim.world.home_geodetic(0)
        sim.run_lockstep(3.0)
        assert vehicle.arm(False) == 0 and vehicle.takeoff(None) == 0
        sim.run_lockstep(10.0)
        out["airborne"] = sim.world.truth.position_enu_m[0].copy()
        out["home"] = vehicle.telemetry().home
        assert vehicle.land() == 0
        sim.run_lockstep(40.0, until=lambda s: not s.fleet.commanders[0].armed)
        out["final"] = sim.world.truth.position_enu_m[0].copy()
        out["armed"] = sim.fleet.commanders[0].armed
        out["texts"] = [t for _, t in vehicle.pop_status_texts()]
    # The same seed spawned on the ground: its GNSS and baro errors are the deck run's.
    ground = SimulationConfig(mavlink=False, record_hz=0, seed=1)
    with Simulation(ground) as sim:
        sim.run_lockstep(13.0)
        out["ground_home"] = sim.fleet.vehicle(0).telemetry().home
    return out


def test_home_on_the_deck_is_the_decks_height_above_sea_level(offshore, deck_flight):
    deck_z = offshore.launch_area("helideck").center_enu_m[2]
    assert deck_flight["home_geodetic"][2] == pytest.approx(488.0 + deck_z, abs=0.5)
    home, ground = deck_flight["home"], deck_flight["ground_home"]
    assert home.alt_amsl_m - ground.alt_amsl_m == pytest.approx(deck_z, abs=1.0)
    assert abs(home.alt_amsl_m - deck_flight["home_geodetic"][2]) < 5.0  # GNSS/baro error


def test_takeoff_from_the_deck_climbs_above_it_and_lands_back_on_it(deck_flight):
    start, airborne, final = deck_flight["start"], deck_flight["airborne"], deck_flight["final"]
    assert airborne[2] - start[2] == pytest.approx(2.5, abs=0.5)  # MIS_TAKEOFF_ALT above the deck
    assert not deck_flight["armed"]
    assert "Landing detected" in deck_flight["texts"]
    assert "Disarmed by landing" in deck_flight["texts"]
    assert abs(final[2] - start[2]) < 0.05  # on the deck, 32 m above the sea
    assert np.hypot(*(final[:2] - start[:2])) < 2.0


def test_a_gps_denied_world_flies_on_its_motion_capture():
    """The indoor world's setup in lockstep, each mocap pose handed to the fleet as the bridge's
    VISION_POSITION_ESTIMATE would be: no GNSS fix ever, yet the vehicle arms in the yard, takes
    off and holds over its spawn point."""
    indoor = _world("indoor")
    setup = world_setup(indoor, 1)
    config = SimulationConfig(
        mavlink=False,
        record_hz=0,
        seed=2,
        mocap_port=0,  # no datagrams: the poses are handed over below
        world=world_config(1, setup),
        params=setup.params,
    )
    with Simulation(config) as sim:
        fleet = sim.fleet

        def run(seconds: float) -> None:
            for _ in range(round(seconds * config.physics_hz)):
                sim.step()
                for sample in sim.world.poll_mocap():
                    w, x, y, z = sample.quaternion_wxyz[0]
                    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
                    fleet.handle_vision(
                        0,
                        fleet.time_usec,
                        sample.position_ned_m[0],
                        np.full(3, sample.position_sigma_m**2),
                        yaw,
                        sample.attitude_sigma_rad**2,
                    )

        start = sim.world.truth.position_enu_m[0].copy()
        run(3.0)
        vehicle = fleet.vehicle(0)
        assert not fleet.estimator.global_position_ok[0]
        assert vehicle.arm(False) == 0 and vehicle.takeoff(None) == 0
        run(12.0)
        truth = sim.world.truth.position_enu_m[0]
    assert truth[2] - start[2] == pytest.approx(2.5, abs=0.5)
    assert np.hypot(*(truth[:2] - start[:2])) < 0.5
