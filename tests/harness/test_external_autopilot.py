"""The simulator and our autopilot across PX4's TCP simulator protocol, in one test process.

``Simulation(autopilot="external")`` listens on TCP; an :class:`ExternalAutopilot` per vehicle
(what ``swarmsitl autopilot`` runs) connects from a thread. In lockstep the flight must be the
in-memory mode's flight for the same seed.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable

import numpy as np
import pymap3d
import pytest

from autopilot_emu.fleet import AutopilotFleet
from autopilot_emu.simulator_link import SimulatorLinkConfig
from harness.run.ports import free_port_block
from harness.sim.external_autopilot import ExternalAutopilot, ExternalAutopilotConfig
from harness.sim.simulation import EXTERNAL, PortPlan, Simulation, SimulationConfig
from sitl.world import WorldConfig

pytestmark = pytest.mark.sockets

SDK_BASE = free_port_block(4)
"""Where the external autopilots' onboard links send (+instance; nobody listens): ports of this
module's, from the suite's allocator."""
TAKEOFF_AT_S = 2.0
GOTO_AT_S = 8.0
END_S = 14.0
SAMPLE_EVERY_S = 0.1


def _config(autopilot: str, n: int) -> SimulationConfig:
    return SimulationConfig(
        n_vehicles=n,
        seed=11,
        mavlink=False,
        record_hz=0.0,
        mocap_port=0,
        autopilot=autopilot,
        ports=PortPlan(hil_base=0, video_base=0),
        world=WorldConfig(rangefinders=True),
    )


class _Script:
    """Arm and take off at TAKEOFF_AT_S, go 10 m north and 5 m east at GOTO_AT_S (sim time)."""

    def __init__(self) -> None:
        self.done: set[str] = set()

    def __call__(self, t_s: float, fleet: AutopilotFleet) -> None:
        if t_s >= TAKEOFF_AT_S - 1e-9 and "takeoff" not in self.done:
            self.done.add("takeoff")
            for i in range(fleet.n):
                fleet.vehicle(i).arm(False)
                fleet.vehicle(i).takeoff(None)
        if t_s >= GOTO_AT_S - 1e-9 and "goto" not in self.done:
            self.done.add("goto")
            for i in range(fleet.n):
                v = fleet.vehicle(i)
                tel = v.telemetry()
                lat, lon, _ = pymap3d.ned2geodetic(
                    10.0, 5.0, 0.0, tel.home.lat_deg, tel.home.lon_deg, tel.home.alt_amsl_m
                )
                v.reposition(float(lat), float(lon), tel.alt_amsl_m, 0.0, math.nan)


def _sample(sim: Simulation) -> np.ndarray:
    """Position, velocity, attitude and rotor speeds of every vehicle, one row each."""
    t = sim.world.truth
    return np.hstack((t.position_enu_m, t.velocity_enu_m_s, t.quaternion_xyzw, t.rotor_speed_rad_s))


def _fly_in_memory(n: int) -> np.ndarray:
    script = _Script()
    out = []
    with Simulation(_config("internal", n)) as sim:
        while sim.time_s < END_S - 1e-9:
            sim.run_lockstep(SAMPLE_EVERY_S)
            script(sim.time_s, sim.fleet)
            out.append(_sample(sim))
    return np.stack(out)


def _autopilot_thread(
    port: int, instance: int, script: Callable[[float, AutopilotFleet], None], stop: threading.Event
) -> tuple[threading.Thread, dict]:
    result: dict = {}
    ap = ExternalAutopilot(
        ExternalAutopilotConfig(
            instance=instance,
            simulator=SimulatorLinkConfig(port=port),
            ports=PortPlan(sdk_base=SDK_BASE, listen_base=0, gcs_port=0),
        )
    )

    def should_stop() -> bool:
        # Runs in the autopilot's loop between messages: the script acts at the simulated time
        # the autopilot has reached, as the in-memory script acts between steps.
        script(ap.link.time_s, ap.fleet)
        return stop.is_set()

    def body() -> None:
        try:
            result["ended"] = ap.run(should_stop, connect_timeout_s=30.0)
            result["stats"] = ap.link.stats
        finally:
            ap.close()

    thread = threading.Thread(target=body, daemon=True)
    thread.start()
    return thread, result


def _fly_external(n: int) -> tuple[np.ndarray, list[dict], Simulation]:
    stop = threading.Event()
    out = []
    with Simulation(_config(EXTERNAL, n)) as sim:
        runs = [
            _autopilot_thread(port, i, _Script(), stop) for i, port in enumerate(sim.hil.ports())
        ]
        assert sim.wait_for_autopilots(timeout_s=30.0)
        while sim.time_s < END_S - 1e-9:
            sim.run_lockstep(SAMPLE_EVERY_S)
            out.append(_sample(sim))
        stats = sim.hil.stats()
    for thread, _ in runs:
        thread.join(timeout=30.0)  # the simulator closed: each autopilot ends by itself
    stop.set()
    return np.stack(out), [r for _, r in runs], stats


@pytest.mark.parametrize("n", [1, 2])
def test_lockstep_over_tcp_flies_the_in_memory_trajectory(n: int) -> None:
    """Same seed, same script: the TCP lockstep flight is the in-memory one, bit for bit.

    The HIL messages hold float32 values in memory too (what the wire carries), the messages
    arrive in the in-memory order, and each reply is applied at the step after its HIL_SENSOR.
    """
    memory = _fly_in_memory(n)
    tcp, results, stats = _fly_external(n)
    assert memory.shape == tcp.shape
    climb = memory[-1, :, 2] - memory[0, :, 2]
    moved = memory[-1, :, 1] - memory[0, :, 1]
    assert climb.min() > 1.5 and moved.min() > 5.0  # it really flew the script
    assert np.array_equal(memory, tcp), float(np.max(np.abs(memory - tcp)))
    for r in results:
        assert r["ended"] == "simulator closed"
    for s in stats:
        assert s.connections == 1 and s.disconnects == 0 and s.bad_frames == 0
