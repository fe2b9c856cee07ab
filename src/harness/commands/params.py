"""``swarmsitl params dump`` and the ``--params`` option of ``swarmsitl up`` (docs/cli.md)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape

from autopilot_emu.param_file import format_param_file, store_rows
from harness.options.params import PARAMS_HELP, ParamsLoad, load_params_options
from harness.options.world import parse_frames, world_options
from harness.run.launch import console
from harness.sim.simulation import Simulation, SimulationConfig
from harness.sim.world_setup import world_config

params_app = typer.Typer(
    no_args_is_help=True,
    help="The autopilot's parameters as QGroundControl .params files (docs/cli.md).\n\n"
    "Example:  swarmsitl params dump -n 3 --params all=examples/params/tuning.params",
)


def load_params_or_exit(specs: list[str] | None, n_vehicles: int) -> ParamsLoad | None:
    """The ``--params`` options, or a one-line ``error: FILE:LINE: ...`` and exit code 2."""
    if not specs:
        return None
    try:
        return load_params_options(specs, n_vehicles)
    except ValueError as exc:  # ParamFileError: FILE:LINE: message
        console.print(f"[red]error:[/red] {escape(str(exc))}", highlight=False, soft_wrap=True)
        raise typer.Exit(2) from exc


def print_params_load(load: ParamsLoad | None) -> None:
    """Say which files were loaded and what was skipped in them."""
    if load is None:
        return
    counts = ", ".join(f"{len(p)}" for p in load.vehicle_params)
    console.print(
        f"parameters from {', '.join(map(str, load.files))}: {counts} per vehicle",
        markup=False,
        highlight=False,
        soft_wrap=True,
    )
    for note in load.notes:
        console.print(f"  {note}", markup=False, highlight=False, soft_wrap=True)


@params_app.command()
def dump(
    vehicles: Annotated[int, typer.Option("--vehicles", "-n", min=1, max=255)] = 1,
    frame: Annotated[
        str,
        typer.Option(help="airframe of every vehicle, or one per vehicle (as swarmsitl up)"),
    ] = "typhoon_h480",
    rangefinders: Annotated[
        bool,
        typer.Option(
            "--rangefinders/--no-rangefinders",
            help="as swarmsitl up: with rangefinders, EKF2_RNG_POS_* hold the downward one's place",
        ),
    ] = True,
    world: Annotated[
        Path | None,
        typer.Option(metavar="FILE", help="as swarmsitl up --world: the world's parameters too"),
    ] = None,
    params: Annotated[list[str] | None, typer.Option(help=PARAMS_HELP)] = None,
    sysid: Annotated[
        int | None,
        typer.Option(
            min=1,
            max=255,
            help="write only this vehicle's rows (QGroundControl loads a file only into the "
            "vehicle whose id it names)",
        ),
    ] = None,
    out: Annotated[
        Path | None, typer.Option("--out", "-o", help="file to write [default: standard output]")
    ] = None,
) -> None:
    """Write the parameters an `up` run's vehicles start with as a QGroundControl .params file.

    Every parameter of the emulated autopilot, with the value `swarmsitl up` with the same
    options starts it at: PX4's default, then the airframe's (the `px4:` section of its YAML),
    the rangefinder position, the world's, the --params files. Rows are tab-separated
    `Vehicle-Id Component-Id Name Value Type` (Type: MAV_PARAM_TYPE, 6 INT32, 9 REAL32), as
    QGroundControl's "Save to file" writes them; QGroundControl's "Load from file" and
    `swarmsitl up --params` read it back.

    Example:  swarmsitl params dump -o typhoon.params

    Example:  swarmsitl params dump -n 3 --frame typhoon_h480,x500,x500 --sysid 2 -o x500.params

    Example:  swarmsitl params dump --params all=examples/params/tuning.params   (the merged
    result, to stdout)
    """
    frames = parse_frames(frame, vehicles)
    if sysid is not None and sysid > vehicles:
        raise typer.BadParameter(f"{sysid}: no such vehicle (1..{vehicles})", param_hint="--sysid")
    setup = world_options(world, None, vehicles, SimulationConfig().spacing_m)
    load = load_params_or_exit(params, vehicles)
    cfg = SimulationConfig(
        n_vehicles=vehicles,
        frames=frames,
        mavlink=False,
        record_hz=0,
        mocap_port=0,
        params=setup.params if setup is not None else {},
        vehicle_params=load.vehicle_params if load is not None else (),
        world=world_config(vehicles, setup, rangefinders=rangefinders),
    )
    with Simulation(cfg) as sim:
        rows = [
            row
            for i, store in enumerate(sim.fleet.params)
            if sysid is None or i + 1 == sysid
            for row in store_rows(i + 1, store)
        ]
        names = ",".join(a.name for a in sim.world.airframes)
    text = format_param_file(
        rows,
        comments=(
            f"swarmsitl params dump: start values of {vehicles} vehicle(s), airframes {names}",
        ),
    )
    if out is None:
        sys.stdout.write(text)
        sys.stdout.flush()
    else:
        try:
            out.write_text(text)
        except OSError as exc:
            console.print(f"[red]error:[/red] {escape(str(out))}: {exc.strerror or exc}")
            raise typer.Exit(2) from exc
        console.print(f"{len(rows)} parameters written to {out}", markup=False, highlight=False)
