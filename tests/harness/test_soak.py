"""Soak: ten vehicles hold position for several simulated minutes (slow; `pytest -m slow`)."""

import numpy as np
import pytest

from harness.run.ports import free_port_block
from harness.sim.simulation import PortPlan, Simulation, SimulationConfig

pytestmark = pytest.mark.sockets


@pytest.mark.slow
def test_ten_vehicles_hold_position_for_five_minutes(tmp_path):
    """Estimator drift, integrator wind-up or slow instabilities would show up as position error."""
    base = free_port_block(20)  # 10 sdk ports, then 10 listen ports
    ports = PortPlan(sdk_base=base, listen_base=base + 10, gcs_port=0)
    cfg = SimulationConfig(n_vehicles=10, ports=ports, out_dir=tmp_path, record_hz=2.0, seed=11)
    with Simulation(cfg) as sim:
        start = sim.world.truth.position_enu_m.copy()
        sim.run_lockstep(3.0)
        for i in range(10):
            v = sim.fleet.vehicle(i)
            assert v.arm(False) == 0
            assert v.takeoff(None) == 0
        sim.run_lockstep(15.0)
        held = sim.world.truth.position_enu_m.copy()
        errors = []
        for _ in range(30):
            sim.run_lockstep(10.0)
            pos = sim.world.truth.position_enu_m
            assert np.isfinite(pos).all()
            errors.append(np.linalg.norm(pos - held, axis=1))
        errors = np.array(errors)
        assert all(c.armed and c.in_air for c in sim.fleet.commanders)
        # GPS error wanders (0.5 m horizontal, 1 m vertical, 60 s correlation): the vehicles
        # follow their estimate, so allow that, but nothing that grows without bound.
        assert errors.max() < 3.0, errors.max(axis=0)
        assert abs((held - start)[:, 2].mean() - 2.5) < 0.5
    for i in range(10):
        assert (tmp_path / f"vehicle{i + 1}.tlog").stat().st_size > 100_000
