"""The report of a run directory: metrics with units, per-vehicle time series and plots.

:func:`write_run_report` reads the run back with
:class:`~harness.report.flight_log.FlightLog` and writes
``report.json`` (every number as ``{"value": v, "unit": u}``, non-finite numbers as null),
``timeseries/vehicleN.csv`` and ``plots/{map,errors,battery}.png``. It works on a partial run
(truth cut short, a tlog missing, no truth at all): what can be computed is, the rest is listed
under ``warnings``. :func:`summary_table` turns a report into a rich table for the terminal.

Estimation error: the autopilot's local NED estimate (``est_*`` columns, origin = where its EKF
started = the vehicle's spawn point) moved to world ENU by the spawn point, minus the true ENU.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from rich.console import Console
from rich.table import Table

from harness.report.demo import electrical_energy_j
from harness.report.flight_checks import closest_approach, failsafe_texts, landed_and_disarmed
from harness.report.flight_log import FlightLog, Track, VehicleLog

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from shapely.geometry import Polygon

    import worlds

REPORT_FILE = "report.json"
TIMESERIES_COLUMNS = (
    "time_s",
    "est_error_horizontal_m",
    "est_error_vertical_m",
    "battery_soc",
    "battery_voltage_v",
    "battery_current_a",
    "electrical_power_w",
)
"""Columns of ``timeseries/vehicleN.csv``."""


def quantity(value: float | bool | str | None, unit: str) -> dict[str, Any]:
    """``{"value": value, "unit": unit}``, a non-finite float as None (JSON has no NaN)."""
    if isinstance(value, float | np.floating) and not math.isfinite(value):
        value = None
    elif isinstance(value, np.generic):
        value = value.item()
    return {"value": value, "unit": unit}


def estimation_errors(track: Track, spawn_enu_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(horizontal, vertical) error of the autopilot's position estimate per sample, m."""
    c = track.columns
    est = np.column_stack((c["est_east_m"], c["est_north_m"], -c["est_down_m"])) + spawn_enu_m
    diff = est - track.enu_m
    return np.hypot(diff[:, 0], diff[:, 1]), np.abs(diff[:, 2])


def _rms(x: np.ndarray) -> float:
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x**2))) if x.size else math.nan


def _max(x: np.ndarray) -> float:
    x = x[np.isfinite(x)]
    return float(x.max()) if x.size else math.nan


def vehicle_metrics(v: VehicleLog, log: FlightLog, spawn_enu_m: np.ndarray) -> dict[str, Any]:
    """Distance, airborne time, tilt, speed, energy, battery and estimation error of one vehicle."""
    tr = v.track
    if len(tr) == 0:
        return {"samples": quantity(0, "count")}
    t = tr.time_s
    dt = np.diff(t)
    steps = np.linalg.norm(np.diff(tr.enu_m, axis=0), axis=1)
    airborne = tr.airborne
    vel = tr.velocity_enu_m_s
    horizontal, vertical = estimation_errors(tr, spawn_enu_m)
    end = landed_and_disarmed(log, v.index)
    return {
        "samples": quantity(len(tr), "count"),
        "distance_flown": quantity(float(np.nansum(steps)), "m"),
        "airborne_time": quantity(float(np.sum(dt[airborne[:-1]])), "s"),
        "max_tilt": quantity(_max(tr["tilt_deg"]), "deg"),
        "max_speed": quantity(_max(np.linalg.norm(vel, axis=1)), "m/s"),
        "max_horizontal_speed": quantity(_max(np.hypot(vel[:, 0], vel[:, 1])), "m/s"),
        "energy_used": quantity(electrical_energy_j(t, tr["electrical_power_w"]) / 3600.0, "Wh"),
        "final_battery_soc": quantity(float(tr["battery_soc"][-1]), "fraction"),
        "est_error_horizontal_rms": quantity(_rms(horizontal), "m"),
        "est_error_horizontal_max": quantity(_max(horizontal), "m"),
        "est_error_vertical_rms": quantity(_rms(vertical), "m"),
        "est_error_vertical_max": quantity(_max(vertical), "m"),
        "landed_and_disarmed": quantity(end.ok, "bool") | {"message": end.message},
        "status_texts": quantity(len(v.status_texts), "count"),
        "final_mode": quantity(v.state_changes[-1].mode if v.state_changes else None, ""),
    }


def fleet_metrics(log: FlightLog) -> dict[str, Any]:
    """Closest approaches (all samples, both airborne) and the failsafe texts of the fleet."""
    out: dict[str, Any] = {
        "vehicles": quantity(len(log.vehicles), "count"),
        "simulated_time": quantity(log.end_s, "s"),
    }
    for key, airborne in (("min_separation", False), ("min_separation_airborne", True)):
        c = closest_approach(log, airborne_only=airborne)
        out[key] = quantity(c.distance_m, "m") | {
            "time_s": None if c.first < 0 else c.time_s,
            "between": [] if c.first < 0 else [f"vehicle{c.first + 1}", f"vehicle{c.second + 1}"],
        }
    found = failsafe_texts(log)
    out["failsafe_texts"] = quantity(len(found), "count") | {
        "texts": [{"vehicle": v.name, "time_s": s.time_s, "text": s.text} for v, s in found]
    }
    return out


def _companion_result(path: Path, warnings: list[str]) -> dict[str, Any] | None:
    """A vehicle's result.json (ScenarioEnv.write_result), None if absent or unreadable."""
    if not path.is_file():
        return None
    try:
        body = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        warnings.append(f"{path}: unreadable ({exc}); not merged")
        return None
    if not isinstance(body, dict):
        warnings.append(f"{path}: not a JSON object; not merged")
        return None
    return body


def _spawns(log: FlightLog, spawn_enu_m: np.ndarray | None) -> np.ndarray:
    """(N, 3) spawn points: the given ones, or each vehicle's first truth sample."""
    n = len(log.vehicles)
    if spawn_enu_m is not None:
        spawn = np.asarray(spawn_enu_m, dtype=float)
        if spawn.shape != (n, 3):
            raise ValueError(f"spawn_enu_m must have shape ({n}, 3), got {spawn.shape}")
        return spawn
    out = np.zeros((n, 3))
    for v in log.vehicles:
        if len(v.track):
            out[v.index] = v.track.enu_m[0]
    return out


def write_run_report(
    run_dir: Path,
    world: worlds.World | None,
    spawn_enu_m: np.ndarray | None,
    extra: dict[str, Any],
) -> dict[str, Any]:
    """Compute the run's metrics, write report.json, time series and plots; return the report.

    Args:
        run_dir: the run directory (truth.csv, vehicleN.tlog, vehicleN/result.json).
        world: the run's world, drawn under the trajectories; None for a plain plane.
        spawn_enu_m: (N, 3) world ENU point of each vehicle's EKF origin, m; None = each
            vehicle's first truth sample.
        extra: merged into the report last (seed, versions, config hash, ``complete``).
    """
    run_dir = Path(run_dir)
    report: dict[str, Any] = {"run_dir": str(run_dir)}
    try:
        log = FlightLog.load(run_dir, require_tlogs=False)
    except (FileNotFoundError, ValueError) as exc:
        report |= {"error": str(exc), "vehicles": {}, "fleet": {}, "warnings": [str(exc)]}
        report |= extra
        (run_dir / REPORT_FILE).write_text(json.dumps(report, indent=2, default=str) + "\n")
        return report
    warnings = list(log.warnings)
    spawns = _spawns(log, spawn_enu_m)
    vehicles: dict[str, Any] = {}
    for v in log.vehicles:
        metrics = vehicle_metrics(v, log, spawns[v.index])
        companion = _companion_result(run_dir / v.name / "result.json", warnings)
        if companion is not None:
            metrics["companion"] = companion
        vehicles[v.name] = metrics
    report |= {"vehicles": vehicles, "fleet": fleet_metrics(log)}
    try:
        report["files"] = _write_outputs(run_dir, log, world, spawns, extra.get("seed"))
    except Exception as exc:  # a failed plot must not cost the report
        report["files"] = []
        warnings.append(f"time series or plots not written: {exc!r}")
    report["warnings"] = warnings
    report |= extra
    (run_dir / REPORT_FILE).write_text(json.dumps(report, indent=2, default=str) + "\n")
    return report


def _write_outputs(
    run_dir: Path,
    log: FlightLog,
    world: worlds.World | None,
    spawns: np.ndarray,
    seed: int | None = None,
) -> list[str]:
    """Time-series CSVs and plots; the paths written, relative to ``run_dir``.

    ``seed`` is the run's seed, for the map's title (the world's own seed is another number).
    """
    written = []
    series_dir = run_dir / "timeseries"
    series_dir.mkdir(exist_ok=True)
    errors = {}
    for v in log.vehicles:
        tr = v.track
        errors[v.index] = estimation_errors(tr, spawns[v.index])
        table = np.column_stack(
            (tr.time_s, *errors[v.index], *(tr[c] for c in TIMESERIES_COLUMNS[3:]))
        )
        path = series_dir / f"{v.name}.csv"
        np.savetxt(
            path,
            table,
            delimiter=",",
            header=",".join(TIMESERIES_COLUMNS),
            comments="",
            fmt=["%.4f"] + ["%.6g"] * (len(TIMESERIES_COLUMNS) - 1),
        )
        written.append(str(path.relative_to(run_dir)))
    plots = run_dir / "plots"
    plots.mkdir(exist_ok=True)
    plot_map(plots / "map.png", log, world, seed)
    plot_errors(plots / "errors.png", log, errors)
    plot_battery(plots / "battery.png", log)
    written += [f"plots/{name}" for name in ("map.png", "errors.png", "battery.png")]
    return written


# -- plots ---------------------------------------------------------------------------------------


def _figure(figsize: tuple[float, float], rows: int = 1) -> tuple[Any, Any]:
    """A pyplot-free matplotlib Figure (Agg) and its axes."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    axes = fig.subplots(rows, 1, sharex=rows > 1, squeeze=False)[:, 0]
    return fig, axes


def _save(fig: Any, path: Path) -> None:
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def _polygon_patch(poly: Polygon, **style: Any) -> Any:
    """A matplotlib patch of a shapely (multi)polygon, holes included."""
    from matplotlib.patches import PathPatch
    from matplotlib.path import Path as MplPath

    parts = getattr(poly, "geoms", [poly])
    paths = [
        MplPath(np.asarray(ring.coords)[:, :2], closed=True)
        for p in parts
        for ring in (p.exterior, *p.interiors)
    ]
    return PathPatch(MplPath.make_compound_path(*paths), **style)


def _draw_world(ax: Axes, world: worlds.World) -> None:
    """Boundary, zones, solids' footprints, spills, people, hotspots, tasks and launch areas."""
    from matplotlib.patches import Circle

    from worlds import Hotspot, OilSpill, Person, TaskPoint

    labelled: set[str] = set()

    def label(name: str) -> str:
        if name in labelled:
            return "_nolegend_"
        labelled.add(name)
        return name

    ax.add_patch(
        _polygon_patch(world.boundary, fill=False, ec="black", lw=1.2, label=label("boundary"))
    )
    for zone in world.no_fly:
        ax.add_patch(
            _polygon_patch(
                zone, fc=(0.9, 0.2, 0.2, 0.2), ec="red", hatch="//", label=label("no-fly zone")
            )
        )
    for zone in world.low_interest:
        ax.add_patch(
            _polygon_patch(
                zone, fc=(0.95, 0.85, 0.2, 0.25), ec="goldenrod", label=label("low-interest zone")
            )
        )
    for solid in world.solids:
        foot = solid.footprint_at(0.0)
        if solid.motion is None:
            style = {"fc": (*solid.rgba[:3], 0.7), "ec": "dimgray", "label": label("solid")}
        else:
            style = {
                "fill": False,
                "ec": "dimgray",
                "ls": "--",
                "label": label("moving solid (t = 0)"),
            }
        ax.add_patch(_polygon_patch(foot, **style))
    for spill in world.targets_of(OilSpill):
        ax.add_patch(
            _polygon_patch(
                spill.polygon,
                fc=(0.1, 0.08, 0.08, 0.75),
                ec="black",
                label=label("oil spill (appears at)"),
            )
        )
        minx, _, maxx, maxy = spill.polygon.bounds
        ax.annotate(
            f"{spill.appear_s:.0f} s",
            ((minx + maxx) / 2.0, maxy),
            fontsize=7,
            color="darkred",
            ha="center",
            va="bottom",
        )
    people = world.targets_of(Person)
    if people:
        xy = np.array([p.position_enu_m[:2] for p in people])
        ax.plot(xy[:, 0], xy[:, 1], "P", color="darkorange", ms=8, label=label("person"))
    for spot in world.targets_of(Hotspot):
        ax.add_patch(
            Circle(
                spot.center_xy_m,
                spot.radius_m,
                fill=False,
                ec="purple",
                ls=":",
                label=label("demand hotspot (t = 0)"),
            )
        )
    tasks = world.targets_of(TaskPoint)
    if tasks:
        xy = np.array([t.position_xy_m for t in tasks])
        ax.plot(xy[:, 0], xy[:, 1], ".", color="teal", ms=4, label=label("task point"))
    for area in world.launch_areas:
        ax.add_patch(
            Circle(
                area.center_enu_m[:2],
                area.radius_m,
                fc=(0.2, 0.7, 0.3, 0.3),
                ec="green",
                label=label("launch area"),
            )
        )
        ax.annotate(
            area.name, area.center_enu_m[:2], fontsize=7, color="darkgreen", ha="center", va="top"
        )


MAP_MARGIN_FRACTION = 0.15
"""Margin of the map around the tracks, as a fraction of their larger extent."""
MAP_MARGIN_MIN_M = 10.0
"""Smallest margin around the tracks, m: a hover or a 20 m hop still shows its surroundings."""


def plot_map(
    path: Path, log: FlightLog, world: worlds.World | None, seed: int | None = None
) -> None:
    """PNG: :func:`draw_map`."""
    fig, (ax,) = _figure((10.5, 8.0))
    draw_map(ax, log, world, seed)
    _save(fig, path)


def draw_map(ax: Axes, log: FlightLog, world: worlds.World | None, seed: int | None = None) -> None:
    """Top view of every vehicle's true trajectory over the world map (or a plain plane).

    The axes frame the tracks (:func:`track_window`), not the whole world: a 20 m flight over a
    2 km city would otherwise be a speck. World features inside the window are drawn; ``seed``
    (the run's seed) goes into the title.
    """
    if world is not None:
        _draw_world(ax, world)
    east, north = [], []
    for v in log.vehicles:
        if len(v.track) == 0:
            continue
        e, n = v.track["east_m"], v.track["north_m"]
        east.append(e)
        north.append(n)
        (line,) = ax.plot(e, n, lw=1.3, label=v.name)
        ax.plot(e[:1], n[:1], "o", color=line.get_color(), ms=5)
        ax.plot(e[-1:], n[-1:], "x", color=line.get_color(), ms=7)
    window = track_window(np.concatenate(east), np.concatenate(north)) if east else None
    _map_axes(ax, world, "trajectories (truth; o start, x end)", seed, window)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7)


def track_window(
    east_m: np.ndarray, north_m: np.ndarray
) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """(east, north) axis limits framing the track points with a margin; None: no finite point.

    The margin is :data:`MAP_MARGIN_FRACTION` of the tracks' larger extent, at least
    :data:`MAP_MARGIN_MIN_M`, so the map shows what the vehicles flew among.
    """
    east_m, north_m = np.asarray(east_m, dtype=float), np.asarray(north_m, dtype=float)
    finite = np.isfinite(east_m) & np.isfinite(north_m)
    if not finite.any():
        return None
    e, n = east_m[finite], north_m[finite]
    extent = max(float(np.ptp(e)), float(np.ptp(n)))
    margin = max(MAP_MARGIN_FRACTION * extent, MAP_MARGIN_MIN_M)
    return (
        (float(e.min()) - margin, float(e.max()) + margin),
        (float(n.min()) - margin, float(n.max()) + margin),
    )


def _map_axes(
    ax: Axes,
    world: worlds.World | None,
    what: str,
    seed: int | None = None,
    window: tuple[tuple[float, float], tuple[float, float]] | None = None,
) -> None:
    """Equal axes in metres over ``window`` (None: all drawn), grid, and a title.

    The title names ``what`` is drawn, over which world, and the run's ``seed`` if given.
    """
    ax.set_aspect("equal", adjustable="datalim")  # widens one axis: the window stays in view
    if window is None:
        ax.autoscale_view()
    else:  # auto=None: the equal aspect may still widen the limits (no "fixed limits" warning)
        ax.set_xlim(*window[0], auto=None)
        ax.set_ylim(*window[1], auto=None)
    ax.set_xlabel("east [m]")
    ax.set_ylabel("north [m]")
    ax.grid(True, alpha=0.3)
    title = f"{what} over {f'{world.kind} world' if world is not None else 'a plain plane'}"
    ax.set_title(title if seed is None else f"{title}, run seed {seed}")


def plot_tracks(
    path: Path, position_enu_m: np.ndarray, world: worlds.World | None, seed: int | None = None
) -> None:
    """PNG: top view of (T, N, 3) sampled positions over the world (swarm-scale runs).

    One line collection for the fleet, so a thousand vehicles draw as fast as ten. The axes
    frame the tracks (:func:`track_window`); ``seed`` (the run's seed) goes into the title.
    """
    from matplotlib.collections import LineCollection

    fig, (ax,) = _figure((10.5, 8.0))
    if world is not None:
        _draw_world(ax, world)
    tracks = np.transpose(np.asarray(position_enu_m)[:, :, :2], (1, 0, 2))
    n = len(tracks)
    ax.add_collection(LineCollection(tracks, lw=0.8 if n <= 50 else 0.3, cmap="viridis",
                                     array=np.arange(n, dtype=float)))  # fmt: skip
    if len(tracks) and tracks.shape[1]:
        ax.plot(tracks[:, 0, 0], tracks[:, 0, 1], "k.", ms=2)
    window = track_window(tracks[..., 0].ravel(), tracks[..., 1].ravel()) if tracks.size else None
    _map_axes(ax, world, f"{n} kinematic vehicles (colour: vehicle index; . start)", seed, window)
    _save(fig, path)


def plot_errors(
    path: Path, log: FlightLog, errors: dict[int, tuple[np.ndarray, np.ndarray]]
) -> None:
    """PNG: horizontal and vertical estimation error of each vehicle vs simulation time."""
    _plot_two(
        path,
        log,
        lambda v: errors[v.index],
        ("horizontal error [m]", "vertical error [m]"),
        "position estimate (autopilot EKF) minus truth",
    )


def plot_battery(path: Path, log: FlightLog) -> None:
    """PNG: battery state of charge and voltage of each vehicle vs simulation time."""
    _plot_two(
        path,
        log,
        lambda v: (100.0 * v.track["battery_soc"], v.track["battery_voltage_v"]),
        ("state of charge [%]", "voltage [V]"),
        "battery",
    )


def _plot_two(
    path: Path,
    log: FlightLog,
    series: Callable[[VehicleLog], tuple[np.ndarray, np.ndarray]],
    ylabels: tuple[str, str],
    title: str,
) -> None:
    """Two stacked panels of one quantity pair per vehicle against simulation time."""
    fig, (top, bottom) = _figure((10.0, 6.0), rows=2)
    for v in log.vehicles:
        upper, lower = series(v)
        top.plot(v.track.time_s, upper, lw=1.0, label=v.name)
        bottom.plot(v.track.time_s, lower, lw=1.0, label=v.name)
    top.set_ylabel(ylabels[0])
    bottom.set_ylabel(ylabels[1])
    bottom.set_xlabel("simulation time [s]")
    top.set_title(title)
    for ax in (top, bottom):
        ax.grid(True, alpha=0.3)
    if log.vehicles:
        top.legend(fontsize=7)
    _save(fig, path)


# -- terminal ------------------------------------------------------------------------------------

SUMMARY_COLUMNS = (
    ("distance_flown", "distance", "{:.0f} m"),
    ("airborne_time", "airborne", "{:.0f} s"),
    ("max_tilt", "max tilt", "{:.1f} deg"),
    ("max_speed", "max speed", "{:.1f} m/s"),
    ("energy_used", "energy", "{:.2f} Wh"),
    ("final_battery_soc", "battery", "{:.0%}"),
    ("est_error_horizontal_rms", "est. err h rms", "{:.2f} m"),
    ("est_error_vertical_rms", "est. err v rms", "{:.2f} m"),
)


def _cell(entry: dict[str, Any] | None, fmt: str) -> str:
    if not entry or entry.get("value") is None:
        return "-"
    return fmt.format(entry["value"])


def summary_table(report: dict[str, Any]) -> Table:
    """A rich table of a report: one row per vehicle, the fleet's numbers in the caption."""
    table = Table(title=f"run {report.get('run_dir', '')}")
    table.add_column("vehicle")
    for _, header, _ in SUMMARY_COLUMNS:
        table.add_column(header, justify="right")
    table.add_column("landed+disarmed")
    table.add_column("companion")
    for name, m in report.get("vehicles", {}).items():
        end = m.get("landed_and_disarmed", {}).get("value")
        companion = m.get("companion", {})
        results = ", ".join(
            f"{k} {v.get('value')} {v.get('unit', '')}".strip()
            for k, v in list(companion.items())[:3]
            if isinstance(v, dict)
        )
        table.add_row(
            name,
            *(_cell(m.get(key), fmt) for key, _, fmt in SUMMARY_COLUMNS),
            {True: "yes", False: "[red]no[/red]"}.get(end, "-"),
            results or "-",
        )
    fleet = report.get("fleet", {})
    sep = fleet.get("min_separation", {})
    parts = []
    if sep.get("value") is not None:
        parts.append(
            f"min separation {sep['value']:.1f} m ({' / '.join(sep['between'])} "
            f"at t = {sep['time_s']:.1f} s)"
        )
    if "failsafe_texts" in fleet:
        parts.append(f"failsafe texts: {fleet['failsafe_texts']['value']}")
    if "complete" in report:
        parts.append("complete" if report["complete"] else "[yellow]INCOMPLETE[/yellow]")
    if report.get("warnings"):
        parts.append(f"{len(report['warnings'])} warning(s)")
    if report.get("error"):
        parts.append(f"[red]{report['error']}[/red]")
    table.caption = "; ".join(parts)
    return table


def print_summary(report: dict[str, Any], console: Console) -> None:
    """Print :func:`summary_table` and the report's warnings."""
    console.print(summary_table(report))
    for warning in report.get("warnings", []):
        console.print(f"[yellow]warning:[/yellow] {warning}")
