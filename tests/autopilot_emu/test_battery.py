"""PX4-style battery estimation from measured voltage and current (autopilot_emu.battery)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.battery import BatteryParams, FleetBattery
from autopilot_emu.fleet import AutopilotFleet, FleetConfig


def params(n=1, capacity=5400.0, r_internal=-1.0, cells=4.0):
    return BatteryParams(
        n_cells=np.full(n, cells),
        capacity_mah=np.full(n, capacity),
        v_empty=np.full(n, 3.6),
        v_charged=np.full(n, 4.05),
        r_internal=np.full(n, r_internal),
    )


def feed(bat, volts, amps, t0, seconds, hz=50.0):
    """Constant (or callable) voltage/current samples for ``seconds`` from ``t0``."""
    t = t0
    for k in range(round(seconds * hz)):
        t = t0 + (k + 1) / hz
        v = volts(t) if callable(volts) else volts
        i = amps(t) if callable(amps) else amps
        bat.update(np.atleast_1d(v), np.atleast_1d(i), t)
    return t


def test_coulomb_counting_integrates_the_measured_current():
    """10 A for 360 s is 1000 mAh."""
    bat = FleetBattery(1)
    bat.set_params(params())
    feed(bat, 16.0, 10.0, 0.0, 360.0)
    assert bat.consumed_mah[0] == pytest.approx(1000.0, rel=1e-3)


def test_unknown_current_is_not_counted_and_no_battery_is_unknown():
    bat = FleetBattery(2)
    bat.set_params(params(2))
    feed(bat, np.array([16.0, 0.0]), np.array([np.nan, 5.0]), 0.0, 10.0)
    assert bat.consumed_mah[0] == 0.0
    assert math.isnan(bat.current_a[0])
    assert math.isnan(bat.remaining[1]) and math.isnan(bat.voltage_v[1])  # below 2.1 V
    assert 0.0 <= bat.remaining[0] <= 1.0


def test_voltage_based_soc_with_known_resistance():
    """Without a capacity: SoC = (V/cell + R I - V_empty) / (V_charged - V_empty), filtered."""
    bat = FleetBattery(1)
    bat.set_params(params(capacity=-1.0, r_internal=0.01))
    cell = 3.6 + 0.25 * 0.45  # 25 % between empty and charged once the 0.2 V drop is added
    feed(bat, 4 * (cell - 0.01 * 20.0), 20.0, 0.0, 10.0)
    assert bat.remaining[0] == pytest.approx(0.25, abs=1e-3)
    assert bat.soc_voltage[0] == pytest.approx(0.25, abs=1e-3)


def test_fused_estimate_follows_the_charge_drawn_and_never_exceeds_it():
    """Full pack (by voltage) with a 1000 mAh capacity: 10 A for 180 s leaves ~50 %."""
    bat = FleetBattery(1)
    bat.set_params(params(capacity=1000.0, r_internal=0.0))
    feed(bat, 4 * 4.1, 0.0, 0.0, 3.0)  # connected, initialised, full by voltage
    assert bat.remaining[0] == pytest.approx(1.0)
    feed(bat, 4 * 4.1, 10.0, 3.0, 180.0)  # the voltage still says full
    assert bat.remaining[0] == pytest.approx(0.5, abs=0.01)
    assert bat.remaining[0] <= 1.0 - bat.consumed_mah[0] / 1000.0 + 1e-9


def test_low_voltage_pulls_the_fused_estimate_down():
    """Coulomb counting says nearly full but the voltage says 10 %: the estimate falls to it."""
    bat = FleetBattery(1)
    bat.set_params(params(capacity=5400.0, r_internal=0.0))
    cell = 3.6 + 0.1 * 0.45
    feed(bat, 4 * cell, 0.0, 0.0, 60.0)
    assert bat.remaining[0] == pytest.approx(0.1, abs=0.02)


def test_internal_resistance_is_identified_from_load_steps():
    """V = OCV - R_pack I with a 0.004 ohm/cell pack and current steps: the RLS finds R."""
    bat = FleetBattery(1)
    bat.set_params(params(capacity=5400.0, r_internal=-1.0))

    def amps(t):
        return 10.0 + 20.0 * (int(t * 2) % 2)  # 10 A / 30 A square wave, 1 Hz

    feed(bat, lambda t: 16.0 - 4 * 0.004 * amps(t), amps, 0.0, 20.0)
    assert bat.internal_resistance_ohm[0] == pytest.approx(0.004, rel=0.1)


def _battery_msg(volts, amps):
    cells = [65535] * 10
    cells[0] = round(volts * 1000)
    return mavlink2.MAVLink_battery_status_message(
        0, 0, 1, 32767, cells, round(amps * 100), -1, -1, -1, 0, 0, [0] * 4, 0, 0
    )


def test_fleet_reads_battery_status_and_reports_it():
    """BATTERY_STATUS in (pack voltage in cell 0, cA) -> estimate -> BAT1_CAPACITY applies."""
    fleet = AutopilotFleet(FleetConfig(n_vehicles=2))
    fleet.params[1].set("BAT1_CAPACITY", 100.0)
    for k in range(250):  # 5 s at 50 Hz
        fleet.time_usec = (k + 1) * 20_000
        fleet.handle_battery([_battery_msg(16.4, 20.0), _battery_msg(16.4, 20.0)])
    bat = fleet.battery
    assert bat.voltage_v == pytest.approx([16.4, 16.4])
    assert bat.current_a == pytest.approx([20.0, 20.0])
    assert bat.consumed_mah == pytest.approx([20.0 * 5 / 3.6] * 2, rel=0.01)
    # 100 mAh pack: 27.8 mAh drawn caps the estimate at 72 %; 5400 mAh: full.
    assert bat.remaining[1] == pytest.approx(1.0 - 27.78 / 100.0, abs=0.01)
    assert bat.remaining[0] > 0.98
    snap = fleet.vehicle(1).telemetry()
    assert snap.battery_voltage_v == pytest.approx(16.4)
    assert snap.battery_remaining_pct == 72
