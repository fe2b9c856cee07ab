"""The lockstep gate: what each kind of participant allows, and how the gate waits."""

from __future__ import annotations

import math
import os
import signal
import struct
import subprocess
import sys
import time

import pytest

from autopilot_emu.mavlink.presence import PeerPresence
from harness.run.lockstep import (
    CAP_LOOK_WALL_S,
    KEEP_ALIVE_LOOK_WALL_S,
    ClockAcks,
    GatedLink,
    LockstepBounds,
    LockstepGate,
    Refusal,
    process_state,
    run_gated,
)
from harness.run.sim_clock import ClockFile

pytestmark = pytest.mark.process

BOUNDS = LockstepBounds()
WATCHDOG_WALL_S = 30.0


class FakeSim:
    """A simulation of ``dt_s`` steps whose links, when polled, run ``on_poll``."""

    def __init__(self, dt_s: float = 0.01, on_poll=lambda: None) -> None:
        self.time_s = 0.0
        self.dt_s = dt_s
        self.polls = 0
        self.on_poll = on_poll
        self.kept_alive: list[int] = []
        """The poll counts at which the links were asked to send their held HEARTBEATs."""

    def step(self) -> None:
        self.time_s = round(self.time_s + self.dt_s, 9)

    def poll_links(self) -> None:
        self.polls += 1
        self.on_poll()

    def keep_links_alive(self) -> None:
        self.kept_alive.append(self.polls)


def gate_with(links, wall):
    return LockstepGate(BOUNDS, links=lambda: links, wall_clock_s=lambda: wall[0])


def test_an_echo_lets_the_simulation_lead_it_by_the_bound_only():
    wall = [100.0]
    presence = PeerPresence()
    gate = gate_with([GatedLink(presence, 10.0)], wall)
    assert gate.limit_s(wall[0]) == math.inf  # never heard: not a participant
    presence.echoed(4.0, now_s=4.1, wall_s=100.0)
    assert gate.limit_s(wall[0]) == pytest.approx(4.0 + BOUNDS.lead_s)
    assert gate.allows(4.2, 4.1) and not gate.allows(4.3, 4.1)
    wall[0] += BOUNDS.silence_wall_s + 0.1  # its echoes stopped: it has gone
    assert gate.limit_s(wall[0]) == math.inf


def test_a_heartbeat_holds_the_simulation_within_a_share_of_the_link_loss_timeout():
    """MAVSDK beats once a wall second; the simulation never outruns COM_DL_LOSS_T / 2."""
    wall = [0.0]
    presence = PeerPresence()
    presence.heartbeat(20.0, 0.0)
    gate = gate_with([GatedLink(presence, 10.0)], wall)
    assert gate.limit_s(0.5) == pytest.approx(20.0 + BOUNDS.heartbeat_share * 10.0)


def test_a_shaped_link_caps_the_speed_instead_of_waiting_for_its_traffic():
    """A link model delivers traffic in simulated time: waiting for it could stall forever."""
    wall = [0.0]
    presence = PeerPresence()
    presence.heartbeat(0.0, 0.0)
    gate = gate_with([GatedLink(presence, 10.0, shaped=True)], wall)
    assert gate.limit_s(0.0) == math.inf
    assert gate.allows(0.0, 0.0)  # the cap starts counting here
    cap = BOUNDS.heartbeat_share * 10.0  # simulated s per wall s
    wall[0] = 0.05
    assert gate.allows(cap * 0.05, cap * 0.04)  # due at 0.04 wall s: it may go on
    assert not gate.allows(cap * 0.05 + 0.5, cap * 0.05 + 0.48)  # ahead of the pace: it waits


def test_max_speed_paces_the_simulation_without_counting_holds_or_bursting():
    """``--max-speed``: never more simulated s per wall s than asked; a simulation that fell
    behind its pace (a hold, a slow step) starts a new pace instead of catching up at once."""
    wall = [0.0]
    gate = LockstepGate(BOUNDS, wall_clock_s=lambda: wall[0], max_speed=2.0)
    assert gate.allows(0.02, 0.0)  # the pace starts here: the first block goes at once
    assert gate.refusal(0.04, 0.02) is Refusal.CAP  # 0.02 s is due at 0.01 wall s
    wall[0] = 0.01
    assert gate.allows(0.04, 0.02)
    wall[0] = 5.0  # far behind the pace: a new pace from here, no burst of 10 simulated s
    assert gate.allows(0.06, 0.04) and not gate.allows(0.08, 0.06)
    wall[0] = 5.01
    assert gate.allows(0.08, 0.06)

    wall[0] = 0.0
    sleeps: list[float] = []

    def sleep(wall_s: float) -> None:
        sleeps.append(wall_s)
        wall[0] += wall_s

    gate = LockstepGate(BOUNDS, wall_clock_s=lambda: wall[0], sleep=sleep, max_speed=2.0)
    sim = FakeSim(dt_s=0.01)
    run_gated(sim, gate, 1.0, lambda: False, block_s=0.02)
    assert sim.time_s == pytest.approx(1.0)
    assert wall[0] >= (1.0 - 0.02) / 2.0  # 2x at most (the first block goes at once)
    assert gate.holds == 0 and gate.held_wall_s == 0.0  # waits for the cap are not holds
    # It sleeps until the pace is due, in looks of CAP_LOOK_WALL_S, not of wait_wall_s.
    assert len(sleeps) <= (1.0 / 2.0) / CAP_LOOK_WALL_S + 1
    assert max(sleeps) == pytest.approx(CAP_LOOK_WALL_S)


def test_a_long_hold_has_the_links_send_their_heartbeats_and_counts_once():
    """A peer's wall-clock heartbeat watchdog (MAVSDK: 3 s) must not see a held vehicle go
    silent: while the gate holds, it asks the links every KEEP_ALIVE_LOOK_WALL_S to send the
    HEARTBEATs that are due (``Simulation.keep_links_alive``)."""
    wall = [0.0]
    presence = PeerPresence()
    presence.echoed(0.0, 0.0, 0.0)

    def sleep(wall_s: float) -> None:
        wall[0] += wall_s

    gate = LockstepGate(
        BOUNDS, links=lambda: [GatedLink(presence, 10.0)], wall_clock_s=lambda: wall[0],
        sleep=sleep,
    )  # fmt: skip
    sim = FakeSim()
    sim.time_s = BOUNDS.lead_s
    gate.hold(sim, sim.time_s + 0.02, lambda: wall[0] >= 2.0)
    assert len(sim.kept_alive) == pytest.approx(2.0 / KEEP_ALIVE_LOOK_WALL_S, abs=1)
    assert gate.holds == 1 and gate.held_wall_s == pytest.approx(2.0, abs=0.01)


def test_hold_answers_the_links_until_the_participant_catches_up():
    """The peer echoes only from the third poll of the links on: the simulation waits at its
    lead over the first echo, then runs on as the echoes follow it."""
    presence = PeerPresence()
    presence.echoed(0.0, 0.0, time.monotonic())
    sim = FakeSim()
    reached = []

    def echo_from_the_third_poll() -> None:
        reached.append(sim.time_s)
        if sim.polls >= 3:
            presence.echoed(sim.time_s, sim.time_s, time.monotonic())

    sim.on_poll = echo_from_the_third_poll
    gate = LockstepGate(BOUNDS, links=lambda: [GatedLink(presence, 10.0)])
    run_gated(sim, gate, 1.0, lambda: sim.polls > 100, block_s=0.1)
    assert reached[:3] == [pytest.approx(0.2)] * 3  # held at 0.2 s: 0.3 s > 0.0 + lead
    assert sim.time_s == pytest.approx(1.0) and gate.holds >= 1
    assert all(t <= e + BOUNDS.lead_s + 1e-9 for t, e in zip(reached[1:], reached, strict=False))


def test_give_up_ends_a_hold_at_once():
    presence = PeerPresence()
    presence.echoed(0.0, 0.0, time.monotonic())
    sim = FakeSim()
    gate = LockstepGate(BOUNDS, links=lambda: [GatedLink(presence, 10.0)])
    run_gated(sim, gate, 10.0, lambda: sim.polls >= 5, block_s=0.1)
    assert sim.time_s <= BOUNDS.lead_s + 1e-9 and sim.polls == 5


def test_acknowledgements_of_live_processes_count_and_ended_ones_are_forgotten(tmp_path):
    clock = ClockFile(tmp_path / "clock")
    acks = ClockAcks(clock.path)
    try:
        (acks.directory / str(os.getpid())).write_bytes(struct.pack("<d", 3.0))
        ended = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                               capture_output=True, text=True, check=True)  # fmt: skip
        (acks.directory / ended.stdout.strip()).write_bytes(struct.pack("<d", 1.0))
        (acks.directory / "12ab").write_bytes(b"x")  # not a pid: ignored
        assert acks.times() == {os.getpid(): 3.0}
        assert not (acks.directory / ended.stdout.strip()).exists()
        gate = LockstepGate(BOUNDS, acks)
        assert gate.limit_s(time.monotonic()) == pytest.approx(3.0 + BOUNDS.lead_s)
    finally:
        acks.close()
        clock.close()


def _wait(condition, what: str) -> None:
    deadline = time.monotonic() + WATCHDOG_WALL_S
    while not condition():
        assert time.monotonic() < deadline, what
        time.sleep(0.01)


def test_a_companion_clock_reader_acknowledges_until_it_is_stopped(tmp_path):
    """Importing companion.clock under a lockstep run starts the acknowledgements; a stopped
    process stops acknowledging, and its group shows as stopped to the gate."""
    clock = ClockFile(tmp_path / "clock")
    acks = ClockAcks(clock.path)
    env = os.environ | {"SWARMSITL_CLOCK_FILE": str(clock.path)}
    child = subprocess.Popen(
        [sys.executable, "-c", "import companion.clock, time; time.sleep(60)"],
        env=env, start_new_session=True,
    )  # fmt: skip
    gate = LockstepGate(BOUNDS, acks, groups=lambda: [child.pid])
    try:
        clock.publish(7.0)
        _wait(lambda: acks.times().get(child.pid) == 7.0, "the first acknowledgement")
        assert not gate.stopped(time.monotonic())
        os.killpg(child.pid, signal.SIGSTOP)
        _wait(lambda: process_state(child.pid) == "T", "the stop")
        clock.publish(8.0)
        time.sleep(0.1)  # 50 of its acknowledgement periods
        assert acks.times()[child.pid] == 7.0
        assert gate.stopped(time.monotonic() + 1.0)
        assert not gate.allows(7.0, 7.0)
        os.killpg(child.pid, signal.SIGCONT)
        _wait(lambda: acks.times().get(child.pid) == 8.0, "acknowledgements after SIGCONT")
        assert not gate.stopped(time.monotonic() + 2.0)
    finally:
        child.kill()
        child.wait()
        acks.close()
        clock.close()
    assert acks.times() == {}  # it ended: no longer a participant


def test_without_an_acknowledgement_folder_nothing_is_acknowledged(tmp_path):
    """A paced run, or a real vehicle: companion.clock starts no thread."""
    clock = ClockFile(tmp_path / "clock")
    env = os.environ | {"SWARMSITL_CLOCK_FILE": str(clock.path)}
    code = "from companion import clock; print(clock.start_acknowledging())"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True)  # fmt: skip
    clock.close()
    assert out.stdout.strip() == "False"


def test_bounds_are_checked():
    with pytest.raises(ValueError, match="lead_s"):
        LockstepBounds(lead_s=0)
    with pytest.raises(ValueError, match="half of lead_s"):
        LockstepBounds(lead_s=0.1, ping_period_s=0.08)
