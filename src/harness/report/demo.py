"""Metrics of a demo flight, computed from the recorded ground truth and the client's event log.

Every number here comes from what happened in the simulation: the true trajectory recorded by
:class:`~harness.sim.recorder.FlightRecorder`, with the phases delimited by the companion's own
event
log. Events carry the vehicle's own time (``vehicle_time_s``, the autopilot's time since boot,
which is the simulation clock), so the windows are in simulation time however fast the simulation
actually ran; events without it (older clients) are mapped from their wall-clock stamps through
the recorder's wall-clock column.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pymap3d

from sitl.power.battery import LipoParams, endurance_s


def _sim_time_of(wall_s: float, wall: np.ndarray, sim: np.ndarray) -> float:
    return float(np.interp(wall_s, wall, sim))


def demo_metrics(
    track: dict[str, np.ndarray],
    events: list[dict[str, Any]],
    settings: dict[str, Any],
    origin_lla: tuple[float, float, float],
    battery: LipoParams | None = None,
) -> dict[str, Any]:
    """Climb time, hover and arrival errors, tilt, power and energy of one demo flight (SI units).

    With ``battery`` (the vehicle's pack) the report adds the hover endurance: the time that pack
    delivers the hover power measured in this flight until its loaded voltage reaches cutoff.
    """
    t = track["time_s"]
    enu = np.stack((track["east_m"], track["north_m"], track["up_m"]), axis=1)
    ev = {e["event"]: e for e in events}
    wall, sim = track["wall_s"], t

    def at(name: str) -> float | None:
        if name not in ev:
            return None
        stamp = ev[name].get("vehicle_time_s")
        if stamp is not None:
            return float(stamp)
        return _sim_time_of(ev[name]["wall_s"], wall, sim)

    out: dict[str, Any] = {"completed": "disarmed" in ev and "error" not in ev}
    if "error" in ev:
        out["error"] = ev["error"].get("message")
    start = enu[0]
    alt = float(settings.get("takeoff_alt", 5.0))
    t_to = at("takeoff_commanded")
    if t_to is not None:
        after = (t >= t_to) & (enu[:, 2] - start[2] >= 0.95 * alt)
        if after.any():
            out["climb_time_s"] = float(t[np.argmax(after)] - t_to)
    t_hover = at("hover_done")
    if t_hover is not None:
        hover_s = float(settings.get("hover_s", 5.0))
        win = (t >= t_hover - 0.6 * hover_s) & (t <= t_hover)
        goal = start + np.array([0.0, 0.0, alt])
        err = np.linalg.norm(enu[win] - goal, axis=1)
        out["hover_error_rms_m"] = float(np.sqrt(np.mean(err**2))) if err.size else None
        out["hover_error_max_m"] = float(err.max()) if err.size else None
        if err.size:
            out.update(hover_power_metrics(track, win, battery))
    t_goal = at("goto_settled")
    goto = ev.get("goto_commanded")
    goto_enu = None
    if goto is not None:
        goto_enu = np.array(
            pymap3d.geodetic2enu(goto["lat"], goto["lon"], goto["alt_amsl_m"], *origin_lla)
        )
    if t_goal is not None and goto_enu is not None:
        goal = goto_enu
        i = int(np.searchsorted(t, t_goal))
        i = min(i, len(t) - 1)
        out["arrival_error_m"] = float(np.linalg.norm(enu[i] - goal))
        out["arrival_error_horizontal_m"] = float(np.linalg.norm(enu[i, :2] - goal[:2]))
        out["reported_arrival_error_m"] = ev["goto_settled"].get("reported_error_m")
    t_go, t_arrived = at("goto_commanded"), at("goto_arrived")
    if goto_enu is not None and t_go is not None and t_arrived is not None:
        out |= _cruise_metrics(t, enu, goto_enu, t_go, t_arrived, ev.get("parameters", {}))
    flying = track["landed_state"] != 1
    out["max_tilt_deg"] = float(track["tilt_deg"][flying].max()) if flying.any() else 0.0
    out["landing_offset_m"] = float(np.linalg.norm(enu[-1, :2] - start[:2]))
    armed = track["armed"] > 0.5
    if armed.any():
        ta = t[armed]
        out["armed_time_s"] = float(ta[-1] - ta[0])
    energy = electrical_energy_j(t, track["electrical_power_w"])
    out["electrical_energy_j"] = energy
    out["electrical_energy_wh"] = energy / 3600.0
    if "battery_soc" in track and len(t):
        out["battery_soc_used"] = float(track["battery_soc"][0] - track["battery_soc"][-1])
    return out


def electrical_energy_j(time_s: np.ndarray, power_w: np.ndarray) -> float:
    """Electrical energy drawn, J: the trapezoidal integral of power over simulation time."""
    if len(time_s) < 2:
        return 0.0
    return float(np.sum(0.5 * (power_w[1:] + power_w[:-1]) * np.diff(time_s)))


def hover_power_metrics(
    track: dict[str, np.ndarray], window: np.ndarray, battery: LipoParams | None
) -> dict[str, float]:
    """Mean electrical power over the hover samples ``window`` and, with a pack, the endurance.

    The endurance integrates the LiPo model (:func:`sitl.power.battery.endurance_s`) from full
    charge at that constant power down to the cutoff voltage: what this vehicle, hovering as it
    did here, would fly on a fresh pack.
    """
    hover_w = float(np.mean(track["electrical_power_w"][window]))
    out = {"hover_power_w": hover_w}
    if battery is not None:
        out["hover_endurance_min"] = endurance_s(battery, hover_w) / 60.0
    return out


CRUISE_SEGMENT = (0.3, 0.7)
"""Part of the goto leg (fractions of its length) over which the cruise speed is measured: clear
of the jerk-limited acceleration at the start and the braking before the goal."""


def _cruise_metrics(
    t: np.ndarray,
    enu: np.ndarray,
    goal_enu: np.ndarray,
    t_start: float,
    t_end: float,
    parameters: dict[str, Any],
) -> dict[str, Any]:
    """Median true horizontal ground speed over the middle of the goto leg, vs MPC_XY_CRUISE."""
    leg = (t >= t_start) & (t <= t_end)
    if leg.sum() < 3:
        return {}
    tl, pos = t[leg], enu[leg, :2]
    start, goal = pos[0], goal_enu[:2]
    length = float(np.linalg.norm(goal - start))
    if length < 1.0:
        return {}
    along = (pos - start) @ ((goal - start) / length)
    speed = np.hypot(*np.gradient(pos, tl, axis=0).T)
    lo, hi = CRUISE_SEGMENT
    middle = (along >= lo * length) & (along <= hi * length)
    if not middle.any():
        return {}
    out: dict[str, Any] = {
        "goto_leg_m": length,
        "cruise_speed_m_s": float(np.median(speed[middle])),
        "max_ground_speed_m_s": float(speed.max()),
    }
    param = parameters.get("mpc_xy_cruise_m_s")
    if param:
        out["cruise_speed_param_m_s"] = float(param)
        out["cruise_speed_error_pct"] = 100.0 * (out["cruise_speed_m_s"] / float(param) - 1.0)
    return out


def write_report(path: Path, metrics: dict[str, Any], extra: dict[str, Any]) -> None:
    """report.json with metrics (units in the key names) and run information."""
    path.write_text(json.dumps({"metrics": metrics, **extra}, indent=2, default=str))


def plot_trajectory(track: dict[str, np.ndarray], path: Path, title: str) -> None:
    """PNG: top view (north vs east) and altitude over time of the true trajectory."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, side) = plt.subplots(1, 2, figsize=(11, 4.5))
    e, n, u = track["east_m"], track["north_m"], track["up_m"]
    top.plot(e, n, lw=1.5)
    top.plot(e[:1], n[:1], "go", label="start")
    top.plot(e[-1:], n[-1:], "rx", label="end")
    top.set_xlabel("east [m]")
    top.set_ylabel("north [m]")
    top.set_aspect("equal", adjustable="datalim")
    top.grid(True, alpha=0.3)
    top.legend()
    top.set_title("ground track (truth)")
    side.plot(track["time_s"], u, lw=1.5)
    side.set_xlabel("simulation time [s]")
    side.set_ylabel("height above ground datum [m]")
    side.grid(True, alpha=0.3)
    side.set_title("altitude (truth)")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
