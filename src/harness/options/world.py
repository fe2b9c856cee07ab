"""Options of the commands that start a simulation: airframes per vehicle, a world file.

Shared by ``swarmsitl up`` and ``swarmsitl params dump`` (which must start each vehicle as ``up``
would).
"""

from __future__ import annotations

from pathlib import Path

import typer
from rich.markup import escape

import worlds
from harness.run.launch import console
from harness.sim.world_setup import WorldSetup, world_setup
from sitl.vehicles.multirotor import airframe_yaml_path
from worlds.examples import world_path


def parse_frames(spec: str, n_vehicles: int) -> tuple[str, ...]:
    """``--frame`` -> one airframe per vehicle: one name for all, or exactly one per vehicle."""
    names = tuple(name.strip() for name in spec.split(","))
    if any(not name for name in names) or len(names) not in (1, n_vehicles):
        raise typer.BadParameter(
            f"{spec!r}: give one airframe for all vehicles or one per vehicle ({n_vehicles}), "
            "separated by commas, e.g. --frame typhoon_h480,x500",
            param_hint="--frame",
        )
    for name in names:
        try:
            airframe_yaml_path(name)
        except ValueError as exc:
            raise typer.BadParameter(str(exc), param_hint="--frame") from exc
    return names


def world_options(
    path: Path | None, launch_area: str | None, n_vehicles: int, spacing_m: float
) -> WorldSetup | None:
    """``--world`` / ``--launch-area`` -> the world's setup; a bad file or area exits with 2."""
    if path is None:
        if launch_area is not None:
            raise typer.BadParameter("needs --world FILE", param_hint="--launch-area")
        return None
    try:
        built = worlds.build(worlds.load_world(world_path(path)))
        return world_setup(built, n_vehicles, launch_area, spacing_m)
    except (OSError, ValueError) as exc:  # WorldSpecError is a ValueError: file:line: field
        console.print(f"[red]error:[/red] {escape(str(exc))}", highlight=False)
        raise typer.Exit(2) from exc
