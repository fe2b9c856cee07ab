"""A scenario's ``faults:`` in a full-stack run: applied in simulated time, inside the step loop.

Every :class:`~harness.scenarios.faults.Fault` is registered with :meth:`Simulation.at`, so it
acts at the first physics step at or after its time whatever drives the loop (lockstep or
paced), in the process that owns the emulated autopilots:

* ``crash``: the vehicle's autopilot runs flight termination, the code path of
  MAV_CMD_DO_FLIGHTTERMINATION (``vehicle.terminate()``): disarmed, motors off, "Flight
  termination active", HEARTBEAT ``MAV_STATE_FLIGHT_TERMINATION``; PyBullet lets it fall and it
  lies where it hits the ground. Its companion process keeps running (and sees all that).
* ``land``: the autopilot switches to Land here, the code path of MAV_CMD_NAV_LAND
  (``vehicle.land()``), lands and disarms itself. As with PX4, a companion that commands
  again afterwards (a goto, Offboard) takes the vehicle back.
* ``radio_tx`` / ``radio_rx`` / ``radio``: the vehicle's messaging node stops sending,
  receiving, or both (:meth:`LinkRouter.silence`; drops counted under ``fault`` in the
  report's ``net.router``). A scenario without ``node:`` roles has nothing to drop: the fault
  is still applied and reported.

What a run's checks make of a lost vehicle (crashed or landed) is the runner's
(``harness.scenarios.runner``; docs/scenarios.md "Faults").
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from typing import Any

from harness.scenarios.faults import Fault
from harness.sim.simulation import Simulation

LOST = ("crash", "land")
"""Kinds that take the vehicle out of the flight."""


class FaultInjector:
    """The faults of one run, registered with its simulation; what was applied, and when.

    Args:
        faults: the run's faults (``Scenario.faults(seed)``), in time order.
        sim: the simulation (in-process autopilots; its router, if messaging runs).
        nodes: messaging node id of each vehicle that has one, by 0-based vehicle index.

    Raises:
        ValueError: a crash or land fault with an external autopilot (nothing to command).
    """

    def __init__(self, faults: Sequence[Fault], sim: Simulation, nodes: Mapping[int, str]) -> None:
        self.faults = tuple(faults)
        self.applied_s: list[float | None] = [None] * len(self.faults)
        """Simulated time each fault was applied, s (None: not yet, or never)."""
        self._sim = sim
        self._nodes = dict(nodes)
        if sim.fleet is None and any(k in LOST for f in self.faults for k in f.kinds):
            raise ValueError("faults: crash and land need the emulated autopilots (not external)")
        for k, fault in enumerate(self.faults):
            sim.at(fault.time_s, functools.partial(self._apply, k))

    def _apply(self, k: int, now_s: float) -> None:
        fault = self.faults[k]
        sim = self._sim
        for kind in fault.kinds:
            if kind == "crash":
                sim.fleet.vehicle(fault.vehicle).terminate()
            elif kind == "land":
                sim.fleet.vehicle(fault.vehicle).land()
        tx, rx = fault.silences
        node = self._nodes.get(fault.vehicle)
        if (tx or rx) and node is not None and sim.router is not None:
            sim.router.silence(node, tx=tx, rx=rx)
        self.applied_s[k] = now_s

    def records(self) -> list[dict[str, Any]]:
        """The report's ``faults``: every fault's entry, in time order, applied or not."""
        return [f.record(t) for f, t in zip(self.faults, self.applied_s, strict=True)]

    def kinds_of(self) -> dict[int, str]:
        """The applied kinds of each faulted vehicle, in time order, joined by ``+``."""
        out: dict[int, list[str]] = {}
        for fault, t in zip(self.faults, self.applied_s, strict=True):
            if t is not None:
                out.setdefault(fault.vehicle, []).extend(fault.kinds)
        return {i: "+".join(kinds) for i, kinds in out.items()}

    def lost(self, kind: str | None = None) -> dict[int, float]:
        """When each vehicle was lost (crashed or landed; or only ``kind``), simulated s."""
        kinds = LOST if kind is None else (kind,)
        out: dict[int, float] = {}
        for fault, t in zip(self.faults, self.applied_s, strict=True):
            if t is not None and any(k in kinds for k in fault.kinds):
                out.setdefault(fault.vehicle, t)
        return out
