"""RunSession: one run's simulation, clock, processes and signals, opened and closed as one."""

from __future__ import annotations

import os
import signal
import sys

import pytest

from harness.run.session import RunSession
from harness.run.sim_clock import read_time_s
from harness.sim.simulation import Simulation, SimulationConfig

pytestmark = pytest.mark.sockets
PY = sys.executable
CHECK_S = 0.01
"""A paced run looks at its stop condition and its end every 10 simulated ms."""


def _sim(tmp_path) -> Simulation:
    return Simulation(SimulationConfig(mavlink=False, record_hz=5.0, out_dir=tmp_path, seed=1))


def test_a_paced_session_keeps_one_timeline_and_publishes_the_clock(tmp_path):
    sim = _sim(tmp_path)
    with RunSession(sim, tmp_path, speed=50.0) as session:
        session.advance(0.2, lambda: False)
        assert sim.time_s == pytest.approx(0.2, abs=CHECK_S)
        session.advance(0.1, lambda: False)
        assert sim.time_s == pytest.approx(0.3, abs=2 * CHECK_S)
        assert read_time_s(session.clock.path) == pytest.approx(sim.time_s, abs=0.05)
        assert session.environment()["SWARMSITL_SPEED"] == "50"
    assert (tmp_path / "truth.csv").exists()  # closing the session closed the simulation


def test_a_lockstep_session_without_participants_runs_its_duration(tmp_path):
    sim = _sim(tmp_path)
    with RunSession(sim, tmp_path, speed=None) as session:
        assert session.lockstep and session.acks is not None
        session.advance(0.5, lambda: False)
        assert sim.time_s == pytest.approx(0.5)


@pytest.mark.process
def test_processes_stop_and_signals_only_set_the_flag_until_the_end(tmp_path):
    before = signal.getsignal(signal.SIGTERM)
    sim = _sim(tmp_path)
    tell = "import os; print(os.environ['SWARMSITL_CLOCK_FILE'])"
    with RunSession(sim, tmp_path, speed=10.0) as session:
        teller = session.start_process("teller", [PY, "-c", tell], tmp_path / "teller.log")
        sleeper = session.start_process(
            "sleeper", [PY, "-c", "import signal; signal.pause()"], tmp_path / "sleeper.log"
        )
        os.kill(os.getpid(), signal.SIGTERM)  # would end pytest without the session's handler
        assert session.stopped
        session.advance(10.0, lambda: session.stopped)
        assert sim.time_s < 0.1  # stopped at the first check
        with pytest.raises(ValueError, match="already runs"):
            session.start_process("sleeper", [PY, "-c", ""], tmp_path / "again.log")
        assert teller.wait(30) == 0
    assert sleeper.returncode == -signal.SIGTERM  # stopped by the session
    assert signal.getsignal(signal.SIGTERM) == before
    assert (tmp_path / "teller.log").read_text().strip() == str(session.clock.path)


def test_a_bad_speed_is_refused_and_closes_nothing_it_was_not_given(tmp_path):
    sim = _sim(tmp_path)
    try:
        with pytest.raises(ValueError, match="speed must be > 0"):
            RunSession(sim, tmp_path, speed=0.0)
        sim.run_lockstep(0.01)  # still open: the caller owns it until a session took it
    finally:
        sim.close()
