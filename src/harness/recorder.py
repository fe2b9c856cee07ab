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
    from harness.simulation import Simulation

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


@dataclass
class FlightRecorder:
    """Samples every vehicle at ``rate_hz`` of simulation time."""

    sim: Simulation
    rate_hz: float
    rows: list[np.ndarray] = field(default_factory=list)
    _next_s: float = 0.0

    def maybe_record(self) -> None:
        """Record a sample if one is due."""
        t = self.sim.world.time_s
        if t + 1e-9 < self._next_s:
            return
        self._next_s = t + 1.0 / self.rate_hz
        truth = self.sim.world.truth
        fleet = self.sim.fleet
        n = fleet.n
        est = fleet.estimator.position_ned_m
        state = np.array(
            [
                (c.armed, int(c.main_mode), int(c.sub_mode), int(c.landed_state))
                for c in fleet.commanders
            ],
            dtype=float,
        )
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
                fleet.thrust,
                np.full(n, time.time()),
                truth.quaternion_xyzw,
            )
        )
        self.rows.append(block)

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

    def write_csv(self, path: Path) -> None:
        """Write the recording as CSV with a header row."""
        tab = self.table()
        with path.open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(COLUMNS)
            for row in tab:
                w.writerow([f"{v:.6g}" for v in row])
