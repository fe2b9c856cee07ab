"""Power model: LiPo pack, rotor electrical power, loads, voltage-limited thrust (sitl.power)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from sitl_test_helpers import actuator_message, hover_trim, make_world, run

from sitl.power.battery import (
    LipoPack,
    LipoParams,
    cell_ocv_v,
    endurance_s,
    endurance_to_reserve_s,
)
from sitl.power.loads import LOAD_PRESETS, PayloadLoads
from sitl.vehicles import multirotor
from sitl.world import WorldConfig

PACK = LipoParams(
    cells=4, capacity_mah=5400.0, cell_internal_resistance_ohm=0.0032, cutoff_cell_v=3.0
)


def test_ocv_curve_is_chen_2006_and_monotonic():
    """Cell OCV: 2.654 V empty, ~3.80 V half, 4.103 V full (Chen and Rincon-Mora 2006), rising."""
    soc = np.linspace(0.0, 1.0, 201)
    v = cell_ocv_v(soc)
    assert v[0] == pytest.approx(-1.031 + 3.685, abs=1e-9)
    assert v[-1] == pytest.approx(3.685 + 0.2156 - 0.1178 + 0.3201, abs=1e-6)
    assert cell_ocv_v(0.5) == pytest.approx(3.803, abs=1e-3)
    assert np.all(np.diff(v) > 0.0)
    assert PACK.ocv_v(0.5) == pytest.approx(4 * cell_ocv_v(0.5))


def test_sag_under_load_delivers_the_power_and_counts_charge():
    """Under a load P: terminal V = OCV - R I, V I = P; charge falls by I dt."""
    pack = LipoPack(PACK, 3, soc=0.8)
    power = np.array([0.0, 300.0, 600.0])
    pack.draw(power, 1.0)
    i, v = pack.current_a, pack.voltage_v
    ocv = PACK.ocv_v(pack.soc)
    assert v == pytest.approx(ocv - i * 4 * 0.0032, abs=1e-9)
    ocv0 = PACK.ocv_v(0.8)  # the current is solved at the start of the step
    assert (ocv0 - i * 4 * 0.0032) * i == pytest.approx(power, abs=1e-9)
    assert i[0] == 0.0 and v[0] == pytest.approx(ocv[0])
    assert v[2] < v[1] < v[0]  # sags more under more load
    assert 0.8 - pack.soc == pytest.approx(i * 1.0 / (5400 * 3.6), rel=1e-9)


def test_power_beyond_the_pack_maximum_saturates():
    """Above V_oc^2 / 4R the current stays at V_oc / 2R (the maximum-power point)."""
    ocv = float(PACK.ocv_v(1.0))
    r = PACK.resistance_ohm
    i = PACK.current_a(np.array([1.0]), np.array([10 * ocv**2 / (4 * r)]))
    assert i[0] == pytest.approx(ocv / (2 * r))


def test_endurance_integrates_to_the_cutoff_voltage():
    """Constant power: time to cutoff close to usable energy / power, longer at less power."""
    t300 = endurance_s(PACK, 300.0)
    t150 = endurance_s(PACK, 150.0)
    # Energy between full and the cutoff SoC, minus the I^2 R loss: bounds from the OCV curve.
    soc = np.linspace(0.0, 1.0, 2001)
    energy_j = float(np.sum(PACK.ocv_v(soc)) * (soc[1] - soc[0])) * PACK.capacity_c
    assert 0.85 * energy_j / 300.0 < t300 < energy_j / 300.0
    assert t150 > 2.0 * t300  # less I^2 R loss at lower power
    assert endurance_s(PACK, 0.0) == math.inf


def test_endurance_to_a_reserve_counts_the_charge_the_load_draws():
    """Without internal resistance a constant power P draws I = P / V_oc(s), so a full pack
    reaches the reserve r after Q / P * integral_r^1 V_oc(s) ds; V_oc is Chen and Rincon-Mora's
    (2006) curve written out here, integrated on a fine grid. Achieved 5.8e-7."""
    pack = LipoParams(
        cells=4, capacity_mah=5400.0, cell_internal_resistance_ohm=1e-6, cutoff_cell_v=2.5
    )
    soc = np.linspace(0.15, 1.0, 200_001)
    ocv = 4 * (
        -1.031 * np.exp(-35 * soc) + 3.685 + 0.2156 * soc - 0.1178 * soc**2 + 0.3201 * soc**3
    )
    expected_s = 5400 * 3.6 / 200.0 * float(np.trapezoid(ocv, soc))
    assert endurance_to_reserve_s(pack, 200.0, 0.15, dt_s=0.1) == pytest.approx(
        expected_s, rel=9e-7
    )
    assert endurance_to_reserve_s(PACK, 200.0, 0.15) < endurance_s(PACK, 200.0)
    assert endurance_to_reserve_s(PACK, 0.0, 0.15) == math.inf


def isa_density_kg_m3(alt_m: float) -> float:
    """ICAO standard atmosphere (Doc 7488), troposphere: rho = p / (R T), written out here."""
    temperature_k = 288.15 - 0.0065 * alt_m
    pressure_pa = 101325.0 * (temperature_k / 288.15) ** (9.80665 / (287.05287 * 0.0065))
    return pressure_pa / (287.05287 * temperature_k)


def _rotor_power_w(origin_alt_m: float, command: float) -> float:
    """Electrical power of the rotors alone: total at ``command`` minus total with them stopped."""
    world = make_world(spawn_altitude_m=10.0, origin_alt_amsl_m=origin_alt_m)
    run(world, 0.5, [actuator_message([command] * 6)])
    total = float(world.truth.electrical_power_w[0])
    run(world, 0.5, [actuator_message([0.0] * 6)])  # rotors down: the loads alone
    loads = float(world.truth.electrical_power_w[0])
    world.close()
    return total - loads


def test_rotor_power_follows_momentum_theory_in_thrust_and_air_density():
    """Momentum theory, P = T^1.5 / (FM eta sqrt(2 rho A)) (Leishman 2006, eq. 2.15), fixes how
    the power scales whatever FM and eta are: as thrust^1.5, i.e. rotor speed^3 (T ~ w^2 on the
    bench supply, w = command x max speed), and as rho^-0.5 with the ICAO atmosphere's density
    at the world's altitude (computed here). Achieved: exact in thrust, 6.6e-9 in density."""
    hover = multirotor.load_airframe("typhoon_h480").hover_command
    sea = _rotor_power_w(0.0, hover)
    assert _rotor_power_w(0.0, 0.8 * hover) / sea == pytest.approx(0.8**3, rel=1e-12)
    high = _rotor_power_w(3000.0, hover)
    expected = math.sqrt(isa_density_kg_m3(0.0) / isa_density_kg_m3(3000.0))
    assert high / sea == pytest.approx(expected, rel=1e-8)


def test_available_thrust_falls_with_the_pack_voltage():
    """Full command: rotor speed = 1500 rad/s x V / 16.2 V, so a drained pack lifts less."""
    speeds = {}
    for soc in (1.0, 0.15):
        world = make_world(spawn_altitude_m=50.0, bench_supply=False, battery_soc=soc)
        run(world, 0.5, [actuator_message([1.0] * 6)])
        truth = world.truth
        v = truth.battery_voltage_v[0]
        assert truth.rotor_speed_rad_s[0] == pytest.approx(np.full(6, 1500.0 * v / 16.2), rel=0.01)
        speeds[soc] = truth.rotor_speed_rad_s[0, 0]
        world.close()
    k_f = 8.54858e-06
    thrust_full, thrust_low = (6 * k_f * speeds[s] ** 2 for s in (1.0, 0.15))
    assert thrust_low < 0.9 * thrust_full


def test_low_voltage_cutoff_stops_the_motors_and_the_vehicle_falls():
    """A nearly empty pack under hover load sags below 3.0 V per cell: motors stop, it falls."""
    world = make_world(spawn_altitude_m=300.0, bench_supply=False, battery_soc=0.03)
    # The hover trim (the centre of mass is 5 mm behind the rotors' centre) scaled up 15 %, so
    # the vehicle stays level while the pack sags.
    command = [actuator_message((1.15 * hover_trim(world.airframe)).tolist())]
    assert world.truth.battery_voltage_v[0] > 12.0  # above cutoff at rest
    while not world.power.pack.cut_off[0]:
        run(world, 0.1, command)
        assert world.time_s < 120.0
    assert world.time_s > 1.0  # it flew on the pack until the sag crossed the cutoff
    run(world, 0.1, command)
    assert world.truth.battery_voltage_v[0] > 12.0  # unloaded, the voltage recovers
    run(world, 0.9, command)
    truth = world.truth
    assert np.all(truth.rotor_speed_rad_s[0] < 1.0)
    assert truth.velocity_enu_m_s[0, 2] < -8.0  # about 1 s of free fall
    world.close()


def test_payload_loads_per_vehicle_add_their_power():
    """The seed-000 companion (27 W computer + 1 W radio) adds 28 W at the same rotor speeds."""
    loads = (PayloadLoads(), PayloadLoads.preset("seed000_companion"))
    world = make_world(n_vehicles=2, spawn_altitude_m=10.0, loads=loads)
    run(world, 0.3, [actuator_message([0.5] * 6)] * 2)
    p = world.truth.electrical_power_w
    assert p[1] - p[0] == pytest.approx(28.0)
    assert PayloadLoads.preset("seed000_fog").total_w == pytest.approx(3.0 + 28.0 + 100.0)
    assert set(LOAD_PRESETS) == {"avionics", "seed000_companion", "seed000_fog"}
    with pytest.raises(ValueError, match="available"):
        PayloadLoads.preset("nope")
    with pytest.raises(ValueError, match="loads needs"):
        WorldConfig(n_vehicles=3, loads=(PayloadLoads(), PayloadLoads()))
    world.close()


def test_battery_status_reports_the_pack_at_its_rate():
    """BATTERY_STATUS at 50 Hz: pack voltage in cell 0 (mV), current in cA, rest unknown."""
    world = make_world(bench_supply=False, spawn_altitude_m=10.0)
    u = world.airframe.hover_command
    got = []
    for _ in range(50):
        world.step([actuator_message([u] * 6)])
        msgs = world.poll_battery()
        if msgs is not None:
            got.append((world.time_s, msgs[0]))
        assert world.poll_battery() is None
    times = [t for t, _ in got]
    assert times == pytest.approx([0.002] + [0.02 * k for k in range(1, 6)])  # first poll, 50 Hz
    msg = got[-1][1]
    truth = world.truth
    assert msg.voltages[0] == round(truth.battery_voltage_v[0] * 1000)
    assert msg.voltages[1:] == [65535] * 9
    assert msg.current_battery == round(truth.battery_current_a[0] * 100)
    assert 20.0 < truth.battery_current_a[0] < 40.0  # ~380 W at ~15.5 V
    assert msg.current_consumed == -1 and msg.battery_remaining == -1
    world.close()


def test_a_pack_too_weak_for_the_motors_is_refused():
    """The voltage feedback is stable (gain < 1) for the Typhoon; a 20x weaker pack is refused."""
    import dataclasses

    from sitl.power.propulsion import PowerSpec
    from sitl.power.system import FleetPower

    world = make_world(bench_supply=False)
    spec = world.power.spec
    assert 0.2 < world.power.loop_gain < 0.7
    weak = PowerSpec(
        spec.propulsion, dataclasses.replace(spec.battery, cell_internal_resistance_ohm=0.064)
    )
    with pytest.raises(ValueError, match="too weak"):
        FleetPower(weak, 8.54858e-06, 1500.0, 6, 1.17, [PayloadLoads()])
    world.close()


def test_world_config_with_loads_stays_hashable():
    cfg = WorldConfig(n_vehicles=2, loads=(PayloadLoads(), PayloadLoads.of({"camera": 5.0})))
    assert hash(cfg) == hash(
        WorldConfig(n_vehicles=2, loads=(PayloadLoads(), PayloadLoads.of({"camera": 5.0})))
    )
    with pytest.raises(ValueError, match="camera"):
        PayloadLoads.of({"camera": -1.0})


def test_a_smaller_pack_loses_charge_in_proportion_to_its_capacity():
    """Per-vehicle capacities: the same current takes charge in inverse proportion to capacity."""
    pack = LipoPack(PACK, 3, capacity_mah=[5400.0, 2700.0, 10800.0])
    for _ in range(300):
        pack.draw(np.full(3, 150.0), 1.0)
    used = 1.0 - pack.soc
    # the charge drawn (coulomb) is nearly the same for each (a little more from the one that sags
    # most): the fraction used goes as 1 / capacity
    charge_c = used * np.array([5400.0, 2700.0, 10800.0]) * 3.6
    assert charge_c == pytest.approx(np.full(3, charge_c[0]), rel=0.03)
    assert used[1] / used[0] == pytest.approx(2.0, rel=0.03)
    assert used[2] / used[0] == pytest.approx(0.5, rel=0.03)
    # and matches the params' own capacity when none is given
    default = LipoPack(PACK, 1)
    for _ in range(300):
        default.draw(np.full(1, 150.0), 1.0)
    assert default.soc[0] == pytest.approx(pack.soc[0], abs=1e-12)
    with pytest.raises(ValueError, match="capacity_mah"):
        LipoPack(PACK, 2, capacity_mah=[5400.0])
    with pytest.raises(ValueError, match="capacity_mah"):
        LipoPack(PACK, 1, capacity_mah=[0.0])


def test_world_packs_take_the_configured_capacities():
    """WorldConfig.battery_capacity_mah reaches each vehicle's pack; None keeps the airframe's."""
    world = make_world(
        n_vehicles=3,
        airframe=("typhoon_h480", "x500", "typhoon_h480"),
        battery_capacity_mah=(2000.0, None, None),
        bench_supply=False,
    )
    assert world.power_of(0).pack.capacity_mah.tolist() == [2000.0, 5400.0]  # vehicles 0, 2
    assert world.power_of(1).pack.capacity_mah.tolist() == [5000.0]  # the x500's own pack
    with pytest.raises(ValueError, match="battery_capacity_mah"):
        WorldConfig(n_vehicles=2, battery_capacity_mah=(1000.0,))
