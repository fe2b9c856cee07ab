"""A fleet's lazy telemetry snapshots (what the MAVLink links read) against its full snapshots."""

from __future__ import annotations

import dataclasses
import math

import pytest

from autopilot_emu.mavlink.vehicle_port import TelemetrySnapshot
from harness.sim.simulation import Simulation, SimulationConfig

FIELDS = [f.name for f in dataclasses.fields(TelemetrySnapshot)]


def _same(a: object, b: object) -> bool:
    """Equal, with NaN equal to NaN, through tuples, dicts and nested snapshots."""
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    if isinstance(a, tuple | list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if dataclasses.is_dataclass(a):
        return type(a) is type(b) and all(
            _same(getattr(a, f.name), getattr(b, f.name)) for f in dataclasses.fields(a)
        )
    return type(a) is type(b) and a == b


@pytest.fixture(scope="module")
def sim():
    """Two vehicles: one taking off, one left on the ground (setpoints only on the first)."""
    with Simulation(SimulationConfig(n_vehicles=2, mavlink=False, record_hz=0, seed=3)) as s:
        s.run_lockstep(3.0)
        v = s.fleet.vehicle(0)
        assert v.arm(False) == 0
        assert v.takeoff(None) == 0
        yield s


@pytest.mark.parametrize("order", ["declared", "reversed"])
def test_lazy_snapshot_reads_what_the_full_snapshot_reads(sim, order):
    """Whatever group of fields is read first, every field equals the full snapshot's."""
    names = FIELDS if order == "declared" else FIELDS[::-1]
    checked = 0
    for _ in range(6):
        sim.run_lockstep(0.7)
        for i in range(2):
            full = sim.fleet.telemetry.snapshot(i)
            lazy = sim.fleet.telemetry.lazy_snapshot(i)
            assert type(full) is TelemetrySnapshot
            assert isinstance(lazy, TelemetrySnapshot)
            for name in names:
                assert _same(getattr(lazy, name), getattr(full, name)), name
            checked += 1
    full = sim.fleet.telemetry.snapshot(0)
    assert full.setpoint is not None and full.home is not None and full.imu is not None
    assert sim.fleet.telemetry.snapshot(1).setpoint is None
    assert checked == 12


def test_lazy_snapshot_fields_are_read_once(sim):
    """A field read twice is the same object: its group is filled once, then read as a slot."""
    lazy = sim.fleet.telemetry.lazy_snapshot(0)
    assert lazy.estimator is lazy.estimator
    assert lazy.home is lazy.home
    with pytest.raises(AttributeError):
        lazy.no_such_field  # noqa: B018
