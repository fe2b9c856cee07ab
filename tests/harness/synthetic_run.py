"""Small synthetic run directories: truth.csv with the recorder's columns, tlogs with real frames.

Tracks are piecewise linear through keyframes; the tlogs are pymavlink-encoded frames with the
tlog framing (8-byte big-endian microsecond stamp + frame) as pymavlink and MAVProxy write them.
"""

from __future__ import annotations

import csv
import struct
from pathlib import Path

import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

from harness.sim.recorder import COLUMNS

EPOCH_S = 1_790_000_000.0
"""Unix time the synthetic tlogs put at simulation t = 0."""
RATE_HZ = 20.0
ON_GROUND, IN_AIR, TAKEOFF, LANDING = 1, 2, 3, 4
AUTO, POSCTL = 4, 3
LOITER, LAND = 3, 6


def keyframe_track(
    vehicle: int,
    keys: list[tuple[float, float, float, float]],
    end_s: float,
    spawn_enu_m: tuple[float, float, float] = (0.0, 0.0, 0.0),
    rate_hz: float = RATE_HZ,
    **overrides: np.ndarray,
) -> dict[str, np.ndarray]:
    """All COLUMNS of one vehicle moving through keyframes (t, east, north, up), world ENU.

    Armed, landed_state and power follow the height (airborne above 0.3 m); the estimate is the
    truth expressed in NED from ``spawn_enu_m`` (zero error) unless overridden.
    """
    t = np.round(np.arange(0.0, end_s + 1e-9, 1.0 / rate_hz), 6)
    kt = np.array([k[0] for k in keys])
    e, n, u = (np.interp(t, kt, [k[i] for k in keys]) for i in (1, 2, 3))
    up_rel = u - spawn_enu_m[2]
    airborne = up_rel > 0.3
    moving = np.zeros_like(t, dtype=bool)  # armed: 1 s before lift-off to 1 s after touchdown
    if airborne.any():
        idx = np.flatnonzero(airborne)
        moving[max(idx[0] - int(rate_hz), 0) : idx[-1] + int(rate_hz) + 1] = True
    power = np.where(airborne, 150.0, np.where(moving, 40.0, 3.0))
    soc = 1.0 - np.concatenate(([0.0], np.cumsum(power[:-1] * np.diff(t)))) / (3600.0 * 80.0)
    cols = {
        "time_s": t,
        "vehicle": np.full_like(t, vehicle),
        "east_m": e,
        "north_m": n,
        "up_m": u,
        "v_east_m_s": np.gradient(e, t),
        "v_north_m_s": np.gradient(n, t),
        "v_up_m_s": np.gradient(u, t),
        "tilt_deg": np.where(airborne, 5.0, 0.0),
        "electrical_power_w": power,
        "battery_voltage_v": 16.8 - 1.5 * (1.0 - soc) - 0.004 * power,
        "battery_current_a": power / 16.0,
        "battery_soc": soc,
        "wind_east_m_s": np.zeros_like(t),
        "wind_north_m_s": np.zeros_like(t),
        "wind_up_m_s": np.zeros_like(t),
        "est_north_m": n - spawn_enu_m[1],
        "est_east_m": e - spawn_enu_m[0],
        "est_down_m": -(u - spawn_enu_m[2]),
        "armed": moving.astype(float),
        "main_mode": np.full_like(t, AUTO),
        "sub_mode": np.full_like(t, LOITER),
        "landed_state": np.where(airborne, IN_AIR, ON_GROUND).astype(float),
        "thrust": np.where(airborne, 0.5, 0.0),
        "wall_s": EPOCH_S + t,
        "quat_x": np.zeros_like(t),  # upright, facing east (tilt is not modelled here)
        "quat_y": np.zeros_like(t),
        "quat_z": np.zeros_like(t),
        "quat_w": np.ones_like(t),
    }
    for name, value in overrides.items():
        assert name in cols, name
        cols[name] = np.broadcast_to(np.asarray(value, dtype=float), t.shape).copy()
    return cols


def write_truth(path: Path, tracks: list[dict[str, np.ndarray]]) -> None:
    """truth.csv the way FlightRecorder.write_csv writes it: samples interleaved by time."""
    table = np.concatenate([np.column_stack([tr[c] for c in COLUMNS]) for tr in tracks])
    order = np.lexsort((table[:, 1], table[:, 0]))
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(COLUMNS)
        for row in table[order]:
            w.writerow([f"{v:.6g}" if k != 0 else f"{v:.4f}" for k, v in enumerate(row)])


class TlogWriter:
    """Frames of one or more MAVLink systems into a tlog, stamped by a clock of sim time."""

    def __init__(self, path: Path, stamp_of=None) -> None:
        self.path = path
        self.stamp_of = stamp_of or (lambda t_s: EPOCH_S + t_s)
        self.records: list[tuple[float, bytes]] = []
        self._mavs: dict[tuple[int, int], mavlink2.MAVLink] = {}

    def add(self, t_s: float, msg, sysid: int, compid: int = 1) -> None:
        mav = self._mavs.setdefault(
            (sysid, compid), mavlink2.MAVLink(None, srcSystem=sysid, srcComponent=compid)
        )
        frame = msg.pack(mav)
        mav.seq = (mav.seq + 1) % 256
        self.records.append((t_s, frame))

    def close(self) -> bytes:
        self.records.sort(key=lambda r: r[0])
        data = b"".join(
            struct.pack(">Q", round(self.stamp_of(t) * 1e6)) + frame for t, frame in self.records
        )
        self.path.write_bytes(data)
        return data


def heartbeat(armed: bool, main_mode: int, sub_mode: int) -> mavlink2.MAVLink_heartbeat_message:
    base = mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    if armed:
        base |= mavlink2.MAV_MODE_FLAG_SAFETY_ARMED
    return mavlink2.MAVLink_heartbeat_message(
        mavlink2.MAV_TYPE_QUADROTOR,
        mavlink2.MAV_AUTOPILOT_PX4,
        base,
        (main_mode << 16) | (sub_mode << 24),
        mavlink2.MAV_STATE_ACTIVE if armed else mavlink2.MAV_STATE_STANDBY,
        3,
    )


def statustext(severity: int, text: str) -> mavlink2.MAVLink_statustext_message:
    return mavlink2.MAVLink_statustext_message(severity, text.encode())


def system_time(t_s: float) -> mavlink2.MAVLink_system_time_message:
    return mavlink2.MAVLink_system_time_message(round((EPOCH_S + t_s) * 1e6), round(t_s * 1e3))


def command_ack(command: int, result: int) -> mavlink2.MAVLink_command_ack_message:
    return mavlink2.MAVLink_command_ack_message(command, result)


def vehicle_tlog(
    path: Path,
    sysid: int,
    track: dict[str, np.ndarray],
    texts: list[tuple[float, int, str]] = (),
    acks: list[tuple[float, int, int]] = (),
    stamp_of=None,
) -> bytes:
    """A vehicle's onboard tlog: 1 Hz HEARTBEAT (from the track's armed state) and SYSTEM_TIME,
    the given STATUSTEXTs and COMMAND_ACKs, plus a companion's HEARTBEAT and a SYSTEM_TIME of
    the companion's own clock (which must not move the vehicle's events)."""
    log = TlogWriter(path, stamp_of)
    t = track["time_s"]
    for second in np.arange(0.0, t[-1], 1.0):
        k = int(np.searchsorted(t, second))
        sub = int(track["sub_mode"][k])
        log.add(second, heartbeat(track["armed"][k] > 0.5, int(track["main_mode"][k]), sub), sysid)
        log.add(second + 0.001, system_time(second + 0.001), sysid)
        log.add(second + 0.3, heartbeat(False, 0, 0), 245, 190)  # the companion
        log.add(second + 0.31, system_time(second + 1000.0), 245, 190)
    for t_s, severity, text in texts:
        log.add(t_s, statustext(severity, text), sysid)
    for t_s, command, result in acks:
        log.add(t_s, command_ack(command, result), sysid)
    return log.close()


def flight_keys(east0: float, north0: float) -> list[tuple[float, float, float, float]]:
    """Take off at 5 s to 10 m, fly 20 m east then 20 m north, land by 45 s (from (e0, n0))."""
    e, n = east0, north0
    return [
        (0.0, e, n, 0.0),
        (5.0, e, n, 0.0),
        (15.0, e, n, 10.0),
        (25.0, e + 20.0, n, 10.0),
        (35.0, e + 20.0, n + 20.0, 10.0),
        (45.0, e + 20.0, n + 20.0, 0.0),
    ]


def two_vehicle_run(run_dir: Path, spacing_m: float = 6.0, texts=(), **overrides) -> list[dict]:
    """Two vehicles flying the same pattern ``spacing_m`` apart (east); 50 s; tlogs written."""
    run_dir.mkdir(parents=True, exist_ok=True)
    tracks = [
        keyframe_track(
            i, flight_keys(i * spacing_m, 0.0), 50.0, (i * spacing_m, 0.0, 0.0), **overrides
        )
        for i in range(2)
    ]
    write_truth(run_dir / "truth.csv", tracks)
    for i, tr in enumerate(tracks):
        mine = [(t, s, x) for v, t, s, x in texts if v == i]
        vehicle_tlog(run_dir / f"vehicle{i + 1}.tlog", i + 1, tr, mine)
    return tracks
