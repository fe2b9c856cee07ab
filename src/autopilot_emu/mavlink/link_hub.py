"""What the MAVLink links of one vehicle share: one telemetry snapshot per poll, one-off events.

PX4 runs one MAVLink instance per link (PX4 SITL: the offboard/API link and the ground-station
link), all reading the same vehicle. Two things must then not be consumed by whichever link reads
first: the telemetry snapshot (read once per instant of simulation time, whatever number of links
stream from it) and the announcements the vehicle makes once (status texts, mission items
reached), which every link must forward. :class:`LinkHub` owns both; each link reads the
announcements through its own cursor. It also holds the links' forwarding group
(:mod:`autopilot_emu.mavlink.forwarding`) and the commands the vehicle sends to its other
components (a mission's camera items), which every link sends once, and the parameters a client
changed through one link, which the others announce with PARAM_VALUE (as PX4's instances send
every changed parameter, whichever link set it).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable

from autopilot_emu.mavlink.forwarding import ForwardingGroup
from autopilot_emu.mavlink.signing import SigningStreams
from autopilot_emu.mavlink.vehicle_port import TelemetrySnapshot, VehiclePort
from autopilot_emu.mission.camera_items import ComponentCommand

MAX_PENDING_ANNOUNCEMENTS = 256
"""Announcements kept for a link that has not read them yet; older ones are dropped."""

Announcement = tuple[int, str] | int
"""A status text (MAV_SEVERITY, text) or the seq of a mission item reached."""


class LinkHub:
    """The shared side of one vehicle's MAVLink links.

    Args:
        vehicle: the flight stack every link talks to.
        telemetry: where the links read the vehicle's snapshot (default ``vehicle.telemetry``);
            a source whose snapshot reads its fields on first access (a fleet's
            ``lazy_snapshot``) makes a poll read only what its due streams need.
    """

    def __init__(
        self,
        vehicle: VehiclePort,
        telemetry: Callable[[], TelemetrySnapshot] | None = None,
    ) -> None:
        self.vehicle = vehicle
        self._read_telemetry = telemetry if telemetry is not None else vehicle.telemetry
        self._snapshot: TelemetrySnapshot | None = None
        self._snapshot_key: tuple[int, int] | None = None
        self._generation = 0
        self._log: deque[tuple[int, Announcement]] = deque(maxlen=MAX_PENDING_ANNOUNCEMENTS)
        self._next_seq = 0
        self._cursors: list[int] = []
        self.forwarding = ForwardingGroup()
        """The links that relay frames for the vehicle's other components to each other."""
        self._command_queues: list[deque[ComponentCommand]] = []
        self._param_queues: list[deque[str]] = []
        self._signing: SigningStreams | None = None

    def signing(self, key: bytes) -> SigningStreams:
        """The signing state the vehicle's signed links share (created by the first one).

        Raises:
            ValueError: another link of the vehicle signs with another key.
        """
        if self._signing is None:
            self._signing = SigningStreams(key)
        elif self._signing.key != key:
            raise ValueError("the links of one vehicle must share one signing key")
        return self._signing

    # --- telemetry -------------------------------------------------------------------------

    def telemetry(self, now_us: int) -> TelemetrySnapshot:
        """The vehicle's snapshot at simulation time ``now_us``, read once for all links."""
        key = (now_us, self._generation)
        if key != self._snapshot_key or self._snapshot is None:
            self._snapshot = self._read_telemetry()
            self._snapshot_key = key
        return self._snapshot

    def touched(self) -> None:
        """A link handled input that may have changed the vehicle: read a fresh snapshot."""
        self._generation += 1

    # --- announcements ---------------------------------------------------------------------

    def subscribe(self) -> int:
        """A new link: its cursor id (it sees announcements made from now on)."""
        self._cursors.append(self._next_seq)
        self._command_queues.append(deque(maxlen=MAX_PENDING_ANNOUNCEMENTS))
        self._param_queues.append(deque(maxlen=MAX_PENDING_ANNOUNCEMENTS))
        return len(self._cursors) - 1

    def param_changed(self, origin: int, name: str) -> None:
        """Link ``origin`` changed parameter ``name`` (and echoed it): the others announce it."""
        for cursor, queue in enumerate(self._param_queues):
            if cursor != origin and name not in queue:
                queue.append(name)

    def changed_params(self, cursor: int) -> list[str]:
        """Parameters other links changed that link ``cursor`` has not announced yet."""
        queue = self._param_queues[cursor]
        if not queue:
            return []
        names = list(queue)
        queue.clear()
        return names

    def component_commands(self, cursor: int) -> list[ComponentCommand]:
        """Commands for the vehicle's other components that link ``cursor`` has not sent yet."""
        for command in self.vehicle.pop_component_commands():
            for queue in self._command_queues:
                queue.append(command)
        queue = self._command_queues[cursor]
        commands = list(queue)
        queue.clear()
        return commands

    def announcements(self, cursor: int) -> tuple[list[tuple[int, str]], list[int]]:
        """Status texts and mission items reached that link ``cursor`` has not seen yet."""
        self._collect()
        start = self._cursors[cursor]
        self._cursors[cursor] = self._next_seq
        texts: list[tuple[int, str]] = []
        reached: list[int] = []
        for seq, item in self._log:
            if seq < start:
                continue
            if isinstance(item, int):
                reached.append(item)
            else:
                texts.append(item)
        oldest_needed = min(self._cursors)
        while self._log and self._log[0][0] < oldest_needed:
            self._log.popleft()
        return texts, reached

    def _collect(self) -> None:
        """Move what the vehicle announced since the last read into the shared log."""
        for item in (*self.vehicle.pop_status_texts(), *self.vehicle.pop_mission_reached()):
            self._log.append((self._next_seq, item))
            self._next_seq += 1
