"""Faults act inside the simulation's step, in simulated time, through the autopilot's own paths.

Two hexacopters take off through the commander API (no sockets, no companions); then vehicle 1
crashes (flight termination) and vehicle 2 is told to land, each at the first physics step at
or after its time. The crashed one falls to the ground under PyBullet and stays there, its
HEARTBEAT saying MAV_STATE_FLIGHT_TERMINATION; the other lands and disarms itself. A radio fault
without messaging nodes is applied (nothing to drop); a fault due after the run is reported
not applied.
"""

from __future__ import annotations

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink2

from harness.scenarios.fault_injection import FaultInjector
from harness.scenarios.faults import Fault
from harness.sim.simulation import Simulation, SimulationConfig

CRASH_S = 12.3
LAND_S = 12.0


@pytest.fixture(scope="module")
def flight():
    cfg = SimulationConfig(n_vehicles=2, mavlink=False, record_hz=0, seed=5)
    with Simulation(cfg) as sim:
        faults = [
            Fault(1, ("land",), LAND_S, 0),
            Fault(0, ("radio",), LAND_S, 2),
            Fault(0, ("crash",), CRASH_S, 1),
            Fault(1, ("crash",), 99.0, 3),  # after the run's end
        ]
        injector = FaultInjector(faults, sim, {})
        ground = sim.world.truth.position_enu_m[:, 2].copy()  # on their pads
        sim.run_lockstep(3.0)
        for i in range(2):
            v = sim.fleet.vehicle(i)
            assert v.arm(False) == 0 and v.takeoff(None) == 0
        sim.run_lockstep(LAND_S - 1.0 - sim.time_s)
        up = [sim.world.truth.position_enu_m[:, 2].copy()]
        telemetry = []
        while sim.time_s < 30.0 - 1e-9:
            sim.run_lockstep(0.5)
            up.append(sim.world.truth.position_enu_m[:, 2].copy())
            telemetry.append([sim.fleet.vehicle(i).telemetry() for i in range(2)])
        yield {
            "injector": injector,
            "ground": ground,
            "up": np.array(up),
            "telemetry": telemetry,
            "sim": sim,
        }


def test_each_fault_acts_at_the_first_step_at_or_after_its_time(flight):
    records = flight["injector"].records()
    assert [(r["vehicle"], r["kind"], r["applied"]) for r in records] == [
        ("vehicle2", "land", True),
        ("vehicle1", "radio", True),  # no messaging nodes: applied, nothing to drop
        ("vehicle1", "crash", True),
        ("vehicle2", "crash", False),
    ]
    dt = 1.0 / flight["sim"].config.physics_hz
    for r in records[:3]:
        assert r["due_s"] <= r["time_s"] < r["due_s"] + dt + 1e-9, r
    assert records[3]["time_s"] is None and records[3]["due_s"] == 99.0
    assert flight["injector"].kinds_of() == {0: "radio+crash", 1: "land"}
    assert flight["injector"].lost() == {1: records[0]["time_s"], 0: records[2]["time_s"]}
    assert flight["injector"].lost("crash") == {0: records[2]["time_s"]}


def test_a_crashed_vehicle_falls_to_the_ground_and_stays_terminated(flight):
    up, ground = flight["up"][:, 0], flight["ground"][0]
    assert up[0] > ground + 2.0  # flying before the crash
    assert np.all(np.isfinite(flight["up"]))
    # a free fall from ~2.5 m takes < 1 s: on the ground (the body's centre a little above it)
    # from 2 s after the crash to the end, and not moving
    after = np.arange(len(up)) * 0.5 + (LAND_S - 1.0) >= CRASH_S + 2.0
    assert np.all(np.abs(up[after] - ground) < 0.5), up[after] - ground
    assert np.ptp(up[after]) < 0.05
    last = flight["telemetry"][-1][0]
    assert not last.armed
    assert last.system_status == mavlink2.MAV_STATE_FLIGHT_TERMINATION


def test_a_vehicle_told_to_land_lands_and_disarms(flight):
    up, ground = flight["up"][:, 1], flight["ground"][1]
    t = np.arange(len(up)) * 0.5 + (LAND_S - 1.0)
    # it descends at the autopilot's landing speed (not a fall): above ground 1 s after the
    # command, on it at the end
    assert up[np.searchsorted(t, LAND_S + 1.0)] > ground + 1.0
    assert abs(up[-1] - ground) < 0.5
    last = flight["telemetry"][-1][1]
    assert not last.armed and last.landed_state == mavlink2.MAV_LANDED_STATE_ON_GROUND
    assert last.system_status == mavlink2.MAV_STATE_STANDBY


class StubRouter:
    def __init__(self) -> None:
        self.silenced: list[tuple[str, bool, bool]] = []

    def silence(self, node_id: str, *, tx: bool, rx: bool) -> None:
        self.silenced.append((node_id, tx, rx))


class StubSim:
    """What FaultInjector uses of a Simulation: ``at``, ``router``, ``fleet``."""

    def __init__(self) -> None:
        self.router = StubRouter()
        self.fleet = object()
        self.due: list[tuple[float, object]] = []

    def at(self, time_s, action) -> None:
        self.due.append((time_s, action))


def test_radio_faults_silence_the_vehicles_node_one_way_or_both():
    """radio_tx mutes, radio_rx deafens, radio both; a vehicle without a node has nothing."""
    sim = StubSim()
    faults = [
        Fault(0, ("radio_tx",), 1.0, 0),
        Fault(1, ("radio_rx",), 2.0, 1),
        Fault(2, ("radio",), 3.0, 2),
        Fault(3, ("radio",), 4.0, 3),  # no node
    ]
    injector = FaultInjector(faults, sim, {0: "edge1", 1: "edge2", 2: "fog1"})
    for time_s, action in sim.due:
        action(time_s + 0.001)
    assert sim.router.silenced == [
        ("edge1", True, False),
        ("edge2", False, True),
        ("fog1", True, True),
    ]
    assert [r["time_s"] for r in injector.records()] == [1.001, 2.001, 3.001, 4.001]
    assert all(r["applied"] for r in injector.records())
    assert injector.lost() == {}
