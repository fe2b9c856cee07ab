"""The flags of ``swarmsitl up`` that need parsing: cameras, stream rates, links, GPS outages."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import typer

from autopilot_emu.mavlink.streams import STREAMABLE, StreamProfile
from harness.sim.link_models import check_link_model, links_config
from sitl.sensors.camera import CameraSpec, with_mount
from sitl.sensors.gps import GpsOutageWindow
from sitl.vehicles.multirotor import load_airframe


def camera_override(
    frames: tuple[str, ...],
    mount: str | None,
    size: str | None,
    rate_hz: float | None,
    fov_deg: float | None,
    physics_hz: float,
) -> tuple[CameraSpec | None, ...] | None:
    """Each vehicle's camera from the ``--camera-*`` options; None: the airframes' own.

    The options modify the camera of each vehicle's airframe (``frames``: one per vehicle);
    vehicles whose airframe has no camera get none.
    """
    if mount is None and size is None and rate_hz is None and fov_deg is None:
        return None
    changes: dict[str, object] = {}
    if size is not None:
        width, sep, height = size.lower().partition("x")
        try:
            changes["width_px"], changes["height_px"] = int(width), int(height)
        except ValueError:
            sep = ""
        if not sep:
            raise typer.BadParameter(f"{size!r}: expected WIDTHxHEIGHT, e.g. 640x480")
    if rate_hz is not None:
        ratio = physics_hz / rate_hz if rate_hz > 0 else 0.0
        if ratio < 1 or abs(ratio - round(ratio)) > 1e-9:
            raise typer.BadParameter(
                f"--camera-hz {rate_hz:g}: must divide the {physics_hz:g} Hz physics rate"
            )
        changes["rate_hz"] = rate_hz
    if fov_deg is not None:
        changes["hfov_deg"] = fov_deg
    cameras: dict[str, CameraSpec | None] = {}
    for name in dict.fromkeys(frames):
        spec = load_airframe(name).camera
        if spec is not None:
            try:
                spec = dataclasses.replace(spec, **changes)
                spec = with_mount(spec, mount) if mount is not None else spec
            except ValueError as exc:
                raise typer.BadParameter(str(exc)) from exc
        cameras[name] = spec
    return tuple(cameras[name] for name in frames)


def parse_stream_rates(specs: list[str]) -> dict[StreamProfile, dict[str, float]]:
    """``[gcs:]NAME=HZ`` options -> rate overrides per link kind (onboard unless ``gcs:``)."""
    rates: dict[StreamProfile, dict[str, float]] = {}
    for spec in specs:
        profile = StreamProfile.ONBOARD
        body = spec
        if spec.lower().startswith("gcs:"):
            profile, body = StreamProfile.NORMAL, spec[4:]
        name, sep, value = body.partition("=")
        name = name.strip().upper()
        try:
            rate = float(value) if sep else math.nan
        except ValueError:
            rate = math.nan
        if not (math.isfinite(rate) and rate >= 0):
            raise typer.BadParameter(f"{spec!r}: expected NAME=HZ with HZ >= 0, e.g. ATTITUDE=20")
        if name not in STREAMABLE:
            raise typer.BadParameter(
                f"{spec!r}: {name} is not a stream; streams: {', '.join(sorted(STREAMABLE))}"
            )
        rates.setdefault(profile, {})[name] = rate
    return rates


def parse_link_model(name: str, option: str, links_file: Path | None = None) -> str:
    """A ``--link`` / ``--gcs-link`` value: ``none`` or a preset of the link file."""
    try:
        return check_link_model(name.strip(), option, links_config(links_file))
    except ValueError as exc:
        raise typer.BadParameter(str(exc), param_hint=option) from exc


def parse_gps_outages(specs: list[str]) -> tuple[GpsOutageWindow, ...]:
    """``START:END[:SYSID]`` options (simulated seconds, MAVLink system id) -> outage windows."""
    windows = []
    for spec in specs:
        parts = spec.split(":")
        try:
            if len(parts) not in (2, 3):
                raise ValueError("expected START:END or START:END:SYSID")
            start, end = float(parts[0]), float(parts[1])
            vehicle = int(parts[2]) - 1 if len(parts) == 3 else None
            if vehicle is not None and vehicle < 0:
                raise ValueError("SYSID starts at 1")
            windows.append(GpsOutageWindow(start, end, vehicle))
        except ValueError as exc:
            raise typer.BadParameter(f"--gps-outage {spec!r}: {exc}") from exc
    return tuple(windows)
