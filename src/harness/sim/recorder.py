"""Ground-truth and flight-state recording of a run, for reports, plots and CSV export.

The recorder reads the simulator's truth and the autopilots' state directly (the harness owns
both); nothing it records is fed back into the flight.
"""

from __future__ import annotations

import csv
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from harness.sim.simulation import Simulation

COLUMNS = (
    "time_s",
    "vehicle",
    "east_m",
    "north_m",
    "up_m",
    "v_east_m_s",
    "v_north_m_s",
    "v_up_m_s",
    "tilt_deg",
    "electrical_power_w",
    "battery_voltage_v",
    "battery_current_a",
    "battery_soc",
    "wind_east_m_s",
    "wind_north_m_s",
    "wind_up_m_s",
    "est_north_m",
    "est_east_m",
    "est_down_m",
    "armed",
    "main_mode",
    "sub_mode",
    "landed_state",
    "thrust",
    "wall_s",
    "quat_x",
    "quat_y",
    "quat_z",
    "quat_w",
)
"""Columns of truth.csv. Appended only (readers go by name): ``quat_*`` is the attitude, body
FLU -> world ENU, (x, y, z, w) as PyBullet (``sitl.truth.TruthState.quaternion_xyzw``)."""


STREAM_EVERY_S = 5.0
"""Simulated seconds between two appends of a streaming recorder to its CSV file."""
FORMATS = {"time_s": "{:.10g}", "wall_s": "{:.6f}"}
"""Column formats other than the default 6 significant digits (times need more)."""


@dataclass
class FlightRecorder:
    """Samples every vehicle at ``rate_hz`` of simulation time.

    With ``stream_path`` the samples are also appended to that CSV every ``STREAM_EVERY_S``
    simulated seconds (flushed), so a process killed outright still leaves its truth up to
    then; ``write_csv`` to the same path completes the file.
    """

    sim: Simulation
    rate_hz: float
    stream_path: Path | None = None
    rows: list[np.ndarray] = field(default_factory=list)
    _next_s: float = 0.0
    _written: int = 0
    _stream: object | None = None

    def maybe_record(self) -> None:
        """Record a sample if one is due."""
        t = self.sim.world.time_s
        if t + 1e-9 < self._next_s:
            return
        self._next_s = t + 1.0 / self.rate_hz
        truth = self.sim.world.truth
        fleet = self.sim.fleet
        n = truth.position_enu_m.shape[0]
        if fleet is None:  # an external autopilot: its state is not visible here
            est, state, thrust = (
                np.full((n, 3), np.nan),
                np.full((n, 4), np.nan),
                np.full(n, np.nan),
            )
        else:
            est = fleet.estimator.position_ned_m
            state = np.array(
                [
                    (c.armed, int(c.main_mode), int(c.sub_mode), int(c.landed_state))
                    for c in fleet.commanders
                ],
                dtype=float,
            )
            thrust = fleet.thrust
        block = np.column_stack(
            (
                np.full(n, t),
                np.arange(n),
                truth.position_enu_m,
                truth.velocity_enu_m_s,
                np.degrees(truth.tilt_rad),
                truth.electrical_power_w,
                truth.battery_voltage_v,
                truth.battery_current_a,
                truth.battery_soc,
                truth.wind_enu_m_s,
                est,
                state,
                thrust,
                np.full(n, time.time()),
                truth.quaternion_xyzw,
            )
        )
        self.rows.append(block)
        if self.stream_path is not None and len(self.rows) - self._written >= max(
            1, round(STREAM_EVERY_S * self.rate_hz)
        ):
            self._append(self.stream_path)

    def table(self) -> np.ndarray:
        """(samples*N, len(COLUMNS)) array of everything recorded."""
        if not self.rows:
            return np.zeros((0, len(COLUMNS)))
        return np.concatenate(self.rows)

    def vehicle(self, i: int) -> dict[str, np.ndarray]:
        """Columns of vehicle i as a dict of 1-D arrays."""
        tab = self.table()
        tab = tab[tab[:, 1] == i]
        return {name: tab[:, k] for k, name in enumerate(COLUMNS)}

    def _append(self, path: Path) -> None:
        """Append the samples not yet written to the streamed CSV (header first), flushed."""
        if self._stream is None:
            self._stream = path.open("w", newline="")
            csv.writer(self._stream).writerow(COLUMNS)
        pending = self.rows[self._written :]
        self._written = len(self.rows)
        _write_rows(self._stream, np.concatenate(pending) if pending else np.zeros((0, 0)))
        self._stream.flush()

    def write_csv(self, path: Path) -> None:
        """Write the recording as CSV with a header row (completing a streamed file)."""
        if self._stream is not None and path == self.stream_path:
            self._append(path)
            self._stream.close()
            return
        with path.open("w", newline="") as fh:
            csv.writer(fh).writerow(COLUMNS)
            _write_rows(fh, self.table())


def _write_rows(fh: object, tab: np.ndarray) -> None:
    """Rows of the table as CSV lines, each column in its format."""
    formats = [FORMATS.get(name, "{:.6g}") for name in COLUMNS]
    w = csv.writer(fh)
    for row in tab:
        w.writerow([f.format(v) for f, v in zip(formats, row, strict=True)])
