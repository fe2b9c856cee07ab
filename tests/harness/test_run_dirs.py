"""Run directories and the paths a run hands on are absolute, whatever the caller's directory."""

from __future__ import annotations

from pathlib import Path

import pytest

from harness.net.plan import NetPlan, NetRun
from harness.run.launch import default_run_dir, run_dir_of
from harness.run.ports import free_ports
from harness.run.sim_clock import ClockFile
from harness.scenarios.spec import load_scenario
from harness.sim.simulation import SimulationConfig

pytestmark = pytest.mark.sockets

HOP = Path(__file__).parent / "scenarios" / "hop.yaml"


def test_a_relative_out_becomes_absolute_under_the_callers_directory(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert run_dir_of(Path("runs/city")) == tmp_path / "runs" / "city"
    assert run_dir_of(None).parent == tmp_path / "runs"
    assert default_run_dir().is_absolute()


def test_what_companions_are_handed_is_absolute(tmp_path, monkeypatch):
    """The clock file, the simulation's run directory, the net file and a scenario's base folder
    (companions start in the scenario's folder, not the caller's)."""
    monkeypatch.chdir(tmp_path)
    clock = ClockFile(Path("run/clock"))
    try:
        assert clock.path == tmp_path / "run" / "clock"
    finally:
        clock.close()
    config = SimulationConfig(out_dir=Path("run"), mavlink=False)
    assert config.out_dir == tmp_path / "run"
    ports = free_ports()
    net = NetRun(NetPlan(("edge", "fog"), node_base=ports.net, proxy_base=ports.net_proxy), 1,
                 Path("run"))  # fmt: skip
    try:
        assert net.net_path == tmp_path / "run" / "net.yaml"
        assert net.env("edge1")["SWARMSITL_NET"] == str(tmp_path / "run" / "net.yaml")
    finally:
        net.router.close()
    monkeypatch.chdir(HOP.parent.parent)
    scenario = load_scenario(Path("scenarios") / "hop.yaml")
    assert scenario.base_dir == HOP.parent
