"""A finished (or interrupted) run directory read back: truth tracks and the vehicles' events.

:meth:`FlightLog.load` reads ``truth.csv`` (columns of :data:`harness.sim.recorder.COLUMNS`, vehicle
column 0-based) into one :class:`Track` of numpy arrays per vehicle, and from each
``vehicleN.tlog`` (the onboard link of vehicle N, N = sysid = index + 1) the events that matter:
STATUSTEXT, HEARTBEAT armed/mode transitions and COMMAND_ACK results of that vehicle's autopilot
(frames decoded by pymavlink; records walked by :func:`harness.report.tlog_records.scan_tlog`, which
survives cut and corrupt files).

Times are simulation seconds everywhere. Untimed messages (HEARTBEAT, STATUSTEXT, COMMAND_ACK)
are placed through the tlog stamps of the nearest timed messages of the same autopilot
(SYSTEM_TIME.time_boot_ms, ALTITUDE.time_usec, both on the simulation clock): the offset between a
record's stamp and simulation time is interpolated, which is exact for the harness's tlogs (stamped
with the simulation clock) and close for tlogs a ground station stamped with the wall clock.

A run stopped with Ctrl-C or killed may leave a last line or frame half written: what is whole is
read and :attr:`FlightLog.warnings` says what was not. A missing file raises
:class:`FileNotFoundError` naming it.
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink2

from harness.report.tlog_records import scan_tlog
from harness.sim.recorder import COLUMNS

TRUTH_FILE = "truth.csv"
REQUIRED_COLUMNS = ("time_s", "vehicle", "east_m", "north_m", "up_m")
"""Columns without which a truth file is unusable; any other missing column reads as NaN."""
AUTOPILOT_COMPID = 1
"""Component id of the emulated autopilot in every vehicle's tlog."""
TIMED_MESSAGES = {"SYSTEM_TIME": "time_boot_ms", "ALTITUDE": "time_usec"}
"""Messages of the autopilot whose time field (simulation time since boot) anchors the others:
ALTITUDE's microseconds when the tlog has any (onboard link 10 Hz, GCS link 1 Hz), else
SYSTEM_TIME's milliseconds."""
EVENT_MESSAGES = ("HEARTBEAT", "STATUSTEXT", "COMMAND_ACK")
_WANTED = frozenset(
    getattr(mavlink2, f"MAVLINK_MSG_ID_{name}") for name in (*TIMED_MESSAGES, *EVENT_MESSAGES)
)
STATUSTEXT_CHUNK_BYTES = 50
"""Text bytes of one STATUSTEXT; longer texts are chunks sharing an id (MAVLink 2)."""
ON_GROUND, IN_AIR, LANDING = 1, 2, 4
"""MAV_LANDED_STATE values in the truth's ``landed_state`` column."""
AIRBORNE_STATES = (IN_AIR, LANDING)
"""Landed states counted as airborne (TAKEOFF is the spin-up on the ground before lift-off)."""


@dataclass(frozen=True)
class StatusText:
    """A STATUSTEXT of the autopilot."""

    time_s: float
    """Simulation time, s."""
    severity: int
    """MAV_SEVERITY (0 emergency .. 7 debug)."""
    text: str


@dataclass(frozen=True)
class StateChange:
    """The autopilot's HEARTBEAT showed a new armed state or flight mode (or its first state)."""

    time_s: float
    """Simulation time of the first HEARTBEAT showing it, s (HEARTBEAT comes at 1 Hz)."""
    armed: bool
    mode: str
    """pymavlink's mode name, e.g. ``"POSCTL"``, ``"TAKEOFF"``, ``"OFFBOARD"``."""


@dataclass(frozen=True)
class CommandAck:
    """A COMMAND_ACK the autopilot sent."""

    time_s: float
    """Simulation time, s."""
    command: int
    """MAV_CMD id."""
    result: int
    """MAV_RESULT."""

    @property
    def command_name(self) -> str:
        """MAV_CMD name, e.g. ``"MAV_CMD_NAV_TAKEOFF"``."""
        entry = mavlink2.enums["MAV_CMD"].get(self.command)
        return entry.name if entry is not None else str(self.command)

    @property
    def result_name(self) -> str:
        """MAV_RESULT name, e.g. ``"MAV_RESULT_ACCEPTED"``."""
        entry = mavlink2.enums["MAV_RESULT"].get(self.result)
        return entry.name if entry is not None else str(self.result)


@dataclass(frozen=True)
class Track:
    """One vehicle's truth samples: every column of truth.csv as a 1-D array in time order."""

    columns: dict[str, np.ndarray]

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __len__(self) -> int:
        return len(self.columns["time_s"])

    @property
    def time_s(self) -> np.ndarray:
        """Simulation time of each sample, s."""
        return self.columns["time_s"]

    @property
    def enu_m(self) -> np.ndarray:
        """(n, 3) true position, world ENU, m."""
        c = self.columns
        return np.column_stack((c["east_m"], c["north_m"], c["up_m"]))

    @property
    def velocity_enu_m_s(self) -> np.ndarray:
        """(n, 3) true velocity, world ENU, m/s."""
        c = self.columns
        return np.column_stack((c["v_east_m_s"], c["v_north_m_s"], c["v_up_m_s"]))

    @property
    def airborne(self) -> np.ndarray:
        """Boolean mask of the samples where the autopilot reports the vehicle in the air."""
        return np.isin(self.columns["landed_state"], AIRBORNE_STATES)


@dataclass
class VehicleLog:
    """Everything read about one vehicle."""

    index: int
    """0-based index (truth.csv's vehicle column); the tlog is ``vehicle{index + 1}.tlog``."""
    track: Track
    status_texts: list[StatusText] = field(default_factory=list)
    state_changes: list[StateChange] = field(default_factory=list)
    command_acks: list[CommandAck] = field(default_factory=list)

    @property
    def name(self) -> str:
        """``vehicleN`` with N = sysid = index + 1, as the run directory names its files."""
        return f"vehicle{self.index + 1}"


@dataclass
class FlightLog:
    """A run directory read back (see the module docstring)."""

    run_dir: Path
    vehicles: list[VehicleLog]
    warnings: list[str] = field(default_factory=list)
    """What could not be read whole (truncated files), one sentence each."""

    @classmethod
    def load(cls, run_dir: Path, require_tlogs: bool = True) -> FlightLog:
        """Read truth.csv and every vehicle's tlog of ``run_dir``.

        Args:
            run_dir: the run directory.
            require_tlogs: a vehicle of truth.csv without its tlog raises FileNotFoundError;
                with False it is a warning and that vehicle has no events (partial reports).
        """
        run_dir = Path(run_dir)
        if not run_dir.is_dir():
            raise FileNotFoundError(f"run directory {run_dir} does not exist")
        warnings: list[str] = []
        tracks = read_truth(run_dir / TRUTH_FILE, warnings)
        vehicles = []
        for index, track in enumerate(tracks):
            vehicle = VehicleLog(index, track)
            tlog = run_dir / f"{vehicle.name}.tlog"
            if require_tlogs or tlog.is_file():
                read_tlog_events(tlog, index + 1, vehicle, warnings)
            else:
                warnings.append(f"{tlog.name} missing: {vehicle.name} has no events")
            vehicles.append(vehicle)
        return cls(run_dir, vehicles, warnings)

    def vehicle(self, index: int) -> VehicleLog:
        """Vehicle ``index`` (0-based); ``IndexError`` saying how many there are otherwise."""
        if not 0 <= index < len(self.vehicles):
            raise IndexError(
                f"no vehicle index {index} in {self.run_dir}: it has {len(self.vehicles)} "
                f"vehicle(s), indices 0..{len(self.vehicles) - 1}"
            )
        return self.vehicles[index]

    def selected(self, vehicle: int | None) -> list[VehicleLog]:
        """``[vehicle(index)]``, or every vehicle for ``None``."""
        return list(self.vehicles) if vehicle is None else [self.vehicle(vehicle)]

    @property
    def end_s(self) -> float:
        """Simulation time of the last truth sample of any vehicle, s (0 without samples)."""
        ends = [float(v.track.time_s[-1]) for v in self.vehicles if len(v.track)]
        return max(ends, default=0.0)


def read_truth(path: Path, warnings: list[str]) -> list[Track]:
    """One :class:`Track` per vehicle (index = position in the list) from a truth.csv.

    A half-written last line is dropped and noted in ``warnings``, as is any other line that does
    not parse; columns missing from an older file read as NaN (noted too).
    """
    if not path.is_file():
        raise FileNotFoundError(f"truth file {path} does not exist")
    text = path.read_text(errors="replace")
    lines = text.splitlines()
    if not lines:
        warnings.append(f"{path.name} is empty: no truth samples")
        return []
    header = [h.strip() for h in lines[0].split(",")]
    missing = [c for c in REQUIRED_COLUMNS if c not in header]
    if missing:
        raise ValueError(f"{path}: header lacks column(s) {missing}; it has {header}")
    body = lines[1:]
    if body and not text.endswith("\n"):
        body = body[:-1]
        warnings.append(f"{path.name}: last line cut short (run interrupted?); dropped it")
    rows, bad = _parse_rows(body, len(header))
    if bad:
        warnings.append(
            f"{path.name}: {len(bad)} line(s) did not parse (first: line {bad[0] + 2}); skipped"
        )
    absent = [c for c in COLUMNS if c not in header]
    if absent:
        warnings.append(f"{path.name}: no column(s) {absent}; they read as NaN")
    table = {name: rows[:, k] for k, name in enumerate(header)}
    for name in absent:
        table[name] = np.full(len(rows), np.nan)
    vehicle_col = table["vehicle"]
    count = int(np.nanmax(vehicle_col)) + 1 if len(rows) else 0
    tracks = []
    for i in range(count):
        mine = vehicle_col == i
        order = np.argsort(table["time_s"][mine], kind="stable")
        tracks.append(Track({name: col[mine][order] for name, col in table.items()}))
    return tracks


def _parse_rows(lines: list[str], width: int) -> tuple[np.ndarray, list[int]]:
    """(rows, indices of the lines skipped): the lines of ``width`` floats, others skipped."""
    try:  # all lines whole: numpy's C parser
        table = np.loadtxt(io.StringIO("\n".join(lines)), delimiter=",", ndmin=2)
        if table.shape == (len(lines), width):
            return (table, [])
    except ValueError:
        pass
    rows = []
    bad = []
    for k, line in enumerate(lines):
        parts = line.split(",")
        try:
            if len(parts) != width:
                raise ValueError(line)
            rows.append([float(p) for p in parts])
        except ValueError:
            bad.append(k)
    return (np.array(rows, dtype=float).reshape(-1, width), bad)


def read_tlog_events(path: Path, sysid: int, vehicle: VehicleLog, warnings: list[str]) -> None:
    """Append the autopilot ``sysid``'s events in tlog ``path`` to ``vehicle`` (see module doc)."""
    if not path.is_file():
        raise FileNotFoundError(f"tlog {path} of {vehicle.name} does not exist")
    data = path.read_bytes()
    scan = scan_tlog(
        data, lambda msgid, src, comp: msgid in _WANTED and (src, comp) == (sysid, AUTOPILOT_COMPID)
    )
    warnings.extend(scan.problems(path.name, len(data)))
    anchors: dict[str, list[tuple[float, float]]] = {f: [] for f in TIMED_MESSAGES.values()}
    events: list[tuple[float, Any]] = []
    for stamp_s, msg in scan.records:
        kind = msg.get_type()
        if kind in TIMED_MESSAGES:
            field_name = TIMED_MESSAGES[kind]
            scale = 1e-3 if field_name == "time_boot_ms" else 1e-6
            anchors[field_name].append((stamp_s, getattr(msg, field_name) * scale))
        else:
            events.append((stamp_s, msg))
    if not events:
        return
    stamps = np.array([s for s, _ in events])
    # time_usec anchors are exact; time_boot_ms ones are truncated to the millisecond.
    best = anchors["time_usec"] or anchors["time_boot_ms"]
    if best:
        a = np.array(sorted(best))
        # Rounded to the microsecond: the stamps are Unix times, whose float has ~0.2 us of noise.
        times = np.round(stamps + np.interp(stamps, a[:, 0], a[:, 1] - a[:, 0]), 6)
    else:
        warnings.append(
            f"{path.name}: no SYSTEM_TIME or ALTITUDE of system {sysid}; event times are "
            "seconds since the tlog's first record"
        )
        times = np.round(stamps - stamps[0], 6)
    _collect(vehicle, [(float(t), m) for t, (_, m) in zip(times, events, strict=True)])


def _collect(vehicle: VehicleLog, events: list[tuple[float, Any]]) -> None:
    """Sort decoded messages into the vehicle's event lists."""
    state: tuple[bool, str] | None = None
    chunks: dict[int, list] = {}  # chunk id -> [time of the first chunk, severity, pieces]
    for t, msg in events:
        kind = msg.get_type()
        if kind == "STATUSTEXT":
            text, chunk_id = str(msg.text), int(getattr(msg, "id", 0))
            if chunk_id == 0:
                vehicle.status_texts.append(StatusText(t, int(msg.severity), text))
                continue
            # A text longer than 50 bytes comes in chunks sharing an id; a short chunk ends it.
            pending = chunks.setdefault(chunk_id, [t, int(msg.severity), []])
            pending[2].append(text)
            if len(msg.text.encode()) < STATUSTEXT_CHUNK_BYTES:
                first_t, severity, pieces = chunks.pop(chunk_id)
                vehicle.status_texts.append(StatusText(first_t, severity, "".join(pieces)))
        elif kind == "COMMAND_ACK":
            vehicle.command_acks.append(CommandAck(t, int(msg.command), int(msg.result)))
        elif kind == "HEARTBEAT":
            armed = bool(msg.base_mode & mavlink2.MAV_MODE_FLAG_SAFETY_ARMED)
            now = (armed, mavutil.mode_string_v10(msg))
            if now != state:
                vehicle.state_changes.append(StateChange(t, *now))
                state = now
    for first_t, severity, pieces in chunks.values():  # the log ended inside a chunked text
        vehicle.status_texts.append(StatusText(first_t, severity, "".join(pieces)))
    vehicle.status_texts.sort(key=lambda s: s.time_s)
