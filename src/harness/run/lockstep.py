"""Lockstep with the companions: the simulation never runs away from a participant that lags.

A lockstep run goes as fast as the CPU allows, but its participants keep their own time: a
companion process, the ``mavsdk_server`` it talks through, a user's script. Before each block of
simulated time the :class:`LockstepGate` asks every live participant how far it has got and
waits (answering the MAVLink links meanwhile, so no command times out) until the block is
allowed:

- a process that reads the simulation clock through ``companion.clock`` acknowledges the time
  it has seen (``<clock>.acks/<pid>``, refreshed every 2 wall ms); the simulation leads the
  slowest acknowledgement of a live process by at most ``lead_s``;
- a MAVLink peer that answers the links' PING requests (``mavsdk_server`` does) echoes the
  simulation time it has read; the simulation leads the latest echo by at most ``lead_s``;
- a ground station's HEARTBEATs (MAVSDK sends one a wall second): the simulation stays within
  ``heartbeat_share`` of COM_DL_LOSS_T after the last one, so a live companion is never
  declared lost because the simulation outran its wall-clock heartbeat;
- a scenario's companion processes: while any process of a companion's process group is
  stopped (SIGSTOP, a debugger), the simulation waits.

A peer whose echoes or heartbeats stopped ``silence_wall_s`` ago, or a process that ended, no
longer takes part: the simulation goes on without it (and PX4's data-link-loss failsafe acts
after COM_DL_LOSS_T simulated seconds, as on a vehicle). On a link behind a link model
(``--link uart``) PING echoes and heartbeats arrive only as simulated time passes, so they
cannot hold the simulation back without stalling it: such a link caps the speed at
``heartbeat_share`` x COM_DL_LOSS_T simulated seconds per wall second instead, while its peer
sends heartbeats. docs/scenarios.md states the guarantee and its limits.
"""

from __future__ import annotations

import contextlib
import enum
import math
import mmap
import os
import struct
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from autopilot_emu.mavlink.presence import PeerPresence
from harness.run.sim_clock import CLOCK_FORMAT, ack_dir

if TYPE_CHECKING:
    from harness.sim.simulation import Simulation

STOPPED_STATES = frozenset("Tt")
"""/proc/<pid>/stat states of a stopped process: by a signal (T) or a tracer (t)."""
GONE_STATES = frozenset("ZXx")
"""States of a process that has ended (a zombie waits only for its parent to reap it)."""
CAP_SLACK_WALL_S = 0.1
"""How far a speed-capped simulation may fall behind its pace before the pace starts anew."""
HEARTBEAT_PERIOD_WALL_S = 1.0
"""How often a MAVSDK or QGroundControl ground station sends HEARTBEAT, wall s."""
KEEP_ALIVE_LOOK_WALL_S = 0.1
"""How often a holding gate has the links send their wall-clock HEARTBEATs if due, wall s."""
CAP_LOOK_WALL_S = 0.005
"""Longest sleep of a gate that waits for the speed cap (the links are answered between)."""


class Refusal(enum.Enum):
    """Why the gate does not let the simulation go on now."""

    PARTICIPANT = "participant"
    """A participant lags (or is stopped): the wait is a lockstep hold."""
    CAP = "cap"
    """The speed cap's pace is not due yet."""


@dataclass(frozen=True)
class LockstepBounds:
    """How far a lockstep simulation may run ahead of its participants."""

    lead_s: float = 0.25
    """Most simulated time the simulation runs ahead of a participant that reports its time
    (a ``companion.clock`` acknowledgement, a PING echo), s."""
    silence_wall_s: float = 5.0
    """A peer whose echoes or heartbeats stopped this many wall seconds ago has gone (wall
    seconds while a companion was stopped do not count: after it continues, its peers get this
    long again to be heard)."""
    heartbeat_share: float = 0.5
    """Share of COM_DL_LOSS_T the simulation may run past a live peer's last heartbeat."""
    wait_wall_s: float = 0.0005
    """Wall seconds between two looks while waiting."""
    stopped_check_wall_s: float = 0.05
    """How often the companions' processes are checked for a stop, wall s."""
    ping_period_s: float = 0.05
    """Simulated seconds between the links' PING requests (a quarter of ``lead_s`` or less)."""

    def __post_init__(self) -> None:
        for name in ("lead_s", "silence_wall_s", "heartbeat_share", "ping_period_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if self.ping_period_s > self.lead_s / 2:
            raise ValueError(
                f"ping_period_s ({self.ping_period_s} s) must be at most half of lead_s "
                f"({self.lead_s} s): the echo of the last ping must be able to keep up"
            )


LOCKSTEP = LockstepBounds()
"""The bounds of ``swarmsitl run`` and ``swarmsitl up --lockstep`` (docs/scenarios.md)."""


@dataclass(frozen=True)
class GatedLink:
    """A MAVLink link whose peer takes part."""

    presence: PeerPresence
    dl_loss_s: float
    """The vehicle's COM_DL_LOSS_T, s."""
    shaped: bool = False
    """Behind a link model: its traffic arrives in simulated time (see the module docstring)."""


def gated_links(
    sim: Simulation, vehicles: Iterable[int], onboard_only: bool = True
) -> list[GatedLink]:
    """The MAVLink links of ``vehicles`` whose peers take part: onboard (and ground station)."""
    out = []
    for i in vehicles:
        dl_loss_s = sim.fleet.params[i].floats()["COM_DL_LOSS_T"]
        links = sim.vehicle_links[i][:1] if onboard_only else sim.vehicle_links[i]
        for link, kind in zip(links, ("onboard", "gcs"), strict=False):
            out.append(GatedLink(link.presence, dl_loss_s, shaped=(i, kind) in sim.shapers))
    return out


def fleet_gate(sim: Simulation, acks: ClockAcks | None, max_speed: float = 0.0) -> LockstepGate:
    """The gate of ``swarmsitl up --lockstep [--max-speed X]``.

    The links of every emulated vehicle (onboard and ground station) and the clock readers of
    ``acks`` take part. It sees no processes (its peers are the user's): a stopped peer holds
    it through its silence.
    """
    vehicles = range(len(sim.vehicle_links))

    def links() -> list[GatedLink]:
        return gated_links(sim, vehicles, onboard_only=False) if sim.fleet is not None else []

    return LockstepGate(LOCKSTEP, acks, links, max_speed=max_speed)


def process_state(pid: int) -> str | None:
    """The state letter of ``/proc/<pid>/stat`` (R, S, T, Z, ...); None if there is no such pid."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            stat = f.read()
    except OSError:
        return None
    end = stat.rfind(b")")  # the command name may hold spaces and parentheses
    return stat[end + 2 : end + 3].decode() if end > 0 else None


def process_table() -> Iterator[tuple[int, int, int]]:
    """(pid, parent pid, process group) of every process, from /proc."""
    for entry in os.scandir("/proc"):
        if not entry.name.isdigit():
            continue
        try:
            with open(f"/proc/{entry.name}/stat", "rb") as f:
                stat = f.read()
        except OSError:  # it ended meanwhile
            continue
        fields = stat[stat.rfind(b")") + 2 :].split()  # after the name: state, ppid, pgrp
        if len(fields) > 2:
            yield int(entry.name), int(fields[1]), int(fields[2])


def group_members(pgids: set[int]) -> dict[int, list[int]]:
    """The live processes of each process group in ``pgids``, from /proc."""
    members: dict[int, list[int]] = {g: [] for g in pgids}
    if pgids:
        for pid, _, pgrp in process_table():
            if pgrp in members:
                members[pgrp].append(pid)
    return members


class ClockAcks:
    """The acknowledgements of the processes that read one clock file (``companion.clock``)."""

    def __init__(self, clock_path: Path) -> None:
        self.directory = ack_dir(clock_path)
        self.directory.mkdir(parents=True, exist_ok=True)
        self._maps: dict[int, mmap.mmap] = {}

    def times(self) -> dict[int, float]:
        """Simulation time each live participant has seen, by pid (ended ones are forgotten)."""
        out: dict[int, float] = {}
        try:
            names = os.listdir(self.directory)
        except OSError:
            return out
        for name in names:
            if not name.isdigit():
                continue
            pid = int(name)
            state = process_state(pid)
            if state is None or state in GONE_STATES:
                self._forget(pid)
                continue
            view = self._maps.get(pid)
            if view is None:
                view = self._map(pid)
                if view is None:
                    continue
            (seen_s,) = struct.unpack_from(CLOCK_FORMAT, view)
            if math.isfinite(seen_s):
                out[pid] = seen_s
        return out

    def _map(self, pid: int) -> mmap.mmap | None:
        try:
            with (self.directory / str(pid)).open("rb") as f:
                view = mmap.mmap(f.fileno(), 8, access=mmap.ACCESS_READ)
        except (OSError, ValueError):  # being written: next time
            return None
        self._maps[pid] = view
        return view

    def _forget(self, pid: int) -> None:
        view = self._maps.pop(pid, None)
        if view is not None:
            view.close()
        with contextlib.suppress(OSError):
            (self.directory / str(pid)).unlink()

    def close(self) -> None:
        """Release the mappings (the files stay, as the clock file does)."""
        for view in self._maps.values():
            view.close()
        self._maps.clear()


class LinkPoller(Protocol):
    """What the gate needs of the simulation: answering links while it waits."""

    @property
    def time_s(self) -> float:
        """The simulation time, s."""
        ...

    def poll_links(self) -> None:
        """Read and answer the links without stepping."""
        ...

    def keep_links_alive(self) -> None:
        """Send the HEARTBEATs a peer's wall-clock watchdog needs while the clock is held."""
        ...


@dataclass
class LockstepGate:
    """Holds a lockstep simulation back to what its live participants allow."""

    bounds: LockstepBounds
    acks: ClockAcks | None = None
    links: Callable[[], Iterable[GatedLink]] = lambda: ()
    """The links whose peers take part, asked anew before each block."""
    groups: Callable[[], Iterable[int]] = lambda: ()
    """Process groups of the companions that take part (a stopped member holds the simulation)."""
    wall_clock_s: Callable[[], float] = time.monotonic
    sleep: Callable[[float], None] = time.sleep
    """How the gate waits, wall s (a test's fake wall clock advances in it)."""
    max_speed: float = 0.0
    """Never more simulated seconds per wall second than this (0: as fast as the participants
    allow); ``swarmsitl up --lockstep --max-speed X``."""
    holds: int = 0
    """Blocks that had to wait for a participant (not for the speed cap)."""
    held_wall_s: float = 0.0
    """Wall seconds spent waiting."""
    _members: dict[int, list[int]] = field(default_factory=dict)
    _members_at: float = -math.inf
    _stopped: bool = False
    _stopped_at: float = -math.inf
    _resumed_at: float = -math.inf
    _cap_origin: tuple[float, float] | None = None
    _cap_due_wall: float = -math.inf
    """Wall time at which the speed cap lets the simulation go on (:meth:`_capped`)."""
    _alive_at: float = -math.inf

    def limit_s(self, now_wall: float, links: Iterable[GatedLink] | None = None) -> float:
        """Latest simulation time every live participant allows now (``links``: asked anew)."""
        bounds = self.bounds
        limit = math.inf
        if self.acks is not None:
            for seen_s in self.acks.times().values():
                limit = min(limit, seen_s + bounds.lead_s)
        for link in self.links() if links is None else links:
            p = link.presence
            if link.shaped:
                continue  # its traffic waits for simulated time: capped in `_capped` instead
            if self._heard(p.echo_wall_s, now_wall):
                limit = min(limit, p.echo_s + bounds.lead_s)
            if self._heard(p.heartbeat_wall_s, now_wall):
                limit = min(limit, p.heartbeat_s + bounds.heartbeat_share * link.dl_loss_s)
        return limit

    def _heard(self, wall_s: float, now_wall: float) -> bool:
        """A peer last heard at ``wall_s`` still counts (its silence began after any stop)."""
        if wall_s == -math.inf:
            return False
        return now_wall - max(wall_s, self._resumed_at) <= self.bounds.silence_wall_s

    def stopped(self, now_wall: float) -> bool:
        """Some process of a participating companion is stopped (checked every few wall ms)."""
        if now_wall - self._stopped_at < self.bounds.stopped_check_wall_s:
            return self._stopped
        self._stopped_at = now_wall
        pgids = set(self.groups())
        if not pgids:
            self._stopped = False
            return False
        if set(self._members) != pgids or now_wall - self._members_at > 1.0:
            self._members, self._members_at = group_members(pgids), now_wall
        stopped = any(
            process_state(pid) in STOPPED_STATES for pids in self._members.values() for pid in pids
        )
        if self._stopped and not stopped:
            self._resumed_at = now_wall
        self._stopped = stopped
        return stopped

    def _capped(self, now_s: float, now_wall: float, links: Iterable[GatedLink]) -> bool:
        """The simulation is ahead of a speed cap's pace (:attr:`max_speed`, a shaped link).

        A block may start once the simulation's time is due (so it ends at most one block
        ahead of the pace). The pace runs from an origin that moves up to now whenever the
        simulation fell more than ``CAP_SLACK_WALL_S`` behind it (a hold, slow steps): a capped
        simulation never bursts to catch up.
        """
        caps = [
            max(1.0, self.bounds.heartbeat_share * link.dl_loss_s / HEARTBEAT_PERIOD_WALL_S)
            for link in links
            if link.shaped and self._heard(link.presence.heartbeat_wall_s, now_wall)
        ]
        if self.max_speed > 0:
            caps.append(self.max_speed)
        if not caps:
            self._cap_origin = None
            return False
        if self._cap_origin is None:
            self._cap_origin = (now_s, now_wall)
        origin_s, origin_wall = self._cap_origin
        self._cap_due_wall = origin_wall + (now_s - origin_s) / min(caps)
        if now_wall - self._cap_due_wall > CAP_SLACK_WALL_S:
            self._cap_origin = now_s, now_wall
            return False
        return self._cap_due_wall > now_wall

    def refusal(self, target_s: float, now_s: float) -> Refusal | None:
        """Who keeps the simulation at ``now_s`` from running to ``target_s`` now (None: go)."""
        now_wall = self.wall_clock_s()
        if self.stopped(now_wall):
            return Refusal.PARTICIPANT
        links = list(self.links())  # built once per look: the runner reads each vehicle's params
        if self.limit_s(now_wall, links) < target_s - 1e-9:
            return Refusal.PARTICIPANT
        return Refusal.CAP if self._capped(now_s, now_wall, links) else None

    def allows(self, target_s: float, now_s: float) -> bool:
        """Every live participant and the speed cap let the simulation reach ``target_s`` now."""
        return self.refusal(target_s, now_s) is None

    def hold(
        self, sim: LinkPoller, target_s: float, give_up: Callable[[], bool] = lambda: False
    ) -> None:
        """Wait, answering the links, until the simulation may run to ``target_s`` (or give_up).

        While it waits the links keep sending HEARTBEAT once a wall second
        (``sim.keep_links_alive``): a peer's wall-clock watchdog must not declare lost a
        vehicle whose clock only waits. A wait for the speed cap sleeps until the pace is
        due (looking at the links every ``CAP_LOOK_WALL_S``); a wait for a participant looks
        every ``bounds.wait_wall_s``.
        """
        refusal = self.refusal(target_s, sim.time_s)
        if refusal is None:
            return
        start = self.wall_clock_s()
        held = refusal is Refusal.PARTICIPANT
        while not give_up():
            sim.poll_links()
            now_wall = self.wall_clock_s()
            if now_wall - self._alive_at >= KEEP_ALIVE_LOOK_WALL_S:
                self._alive_at = now_wall
                sim.keep_links_alive()
            if refusal is Refusal.CAP:
                pause = min(max(self._cap_due_wall - now_wall, 0.0), CAP_LOOK_WALL_S)
            else:
                pause = self.bounds.wait_wall_s
            self.sleep(max(pause, self.bounds.wait_wall_s))
            refusal = self.refusal(target_s, sim.time_s)
            if refusal is None:
                break
            held = held or refusal is Refusal.PARTICIPANT
        if held:
            self.holds += 1
            self.held_wall_s += self.wall_clock_s() - start

    def summary(self) -> dict[str, float]:
        """What the report says of the lockstep: its bound and how often it waited."""
        return {
            "lead_s": self.bounds.lead_s,
            "holds": self.holds,
            "held_wall_s": round(self.held_wall_s, 3),
        }

    def close(self) -> None:
        """Release the acknowledgement mappings."""
        if self.acks is not None:
            self.acks.close()


class SteppedSimulation(LinkPoller, Protocol):
    """A simulation the gate can drive: one physics step at a time."""

    def step(self) -> None:
        """Advance one physics step."""
        ...


def run_gated(
    sim: SteppedSimulation,
    gate: LockstepGate,
    duration_s: float,
    should_stop: Callable[[], bool],
    block_s: float = 0.02,
) -> None:
    """Run ``duration_s`` of simulated time in blocks the gate allows, until ``should_stop``."""
    end = sim.time_s + duration_s
    while sim.time_s < end - 1e-9:
        target = min(sim.time_s + block_s, end)
        gate.hold(sim, target, should_stop)
        if should_stop():
            return
        while sim.time_s < target - 1e-9:
            sim.step()
