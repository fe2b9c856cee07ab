"""The ``swarmsitl`` command line: start emulated vehicles, or fly the demo."""

from __future__ import annotations

import importlib.metadata
from typing import Annotated

import typer

from harness.commands.autopilot import autopilot
from harness.commands.experiment import experiment
from harness.commands.first_flight import first_flight
from harness.commands.net import cloud, net_demo
from harness.commands.params import params_app
from harness.commands.replay import replay
from harness.commands.run import demo, run
from harness.commands.sweep import sweep
from harness.commands.up import up
from harness.kernels import forbid_compiles_if_requested

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    help="swarmsitl: PyBullet UAV swarm SITL with PX4-flavoured MAVLink autopilots.\n\n"
    "Example:  swarmsitl run src/harness/scenarios/city.yaml   (a scenario; `swarmsitl up` for "
    "vehicles only, `swarmsitl COMMAND --help` for each command)",
)


def installed_version() -> str:
    """The installed swarmsitl distribution's version (what a bug report should quote)."""
    try:
        return importlib.metadata.version("swarmsitl")
    except importlib.metadata.PackageNotFoundError:  # a source tree on sys.path, not installed
        return "unknown (not installed)"


def _print_version(value: bool) -> None:
    """``--version``: print ``swarmsitl VERSION`` and exit 0 before any command runs."""
    if value:
        typer.echo(f"swarmsitl {installed_version()}")
        raise typer.Exit()


@app.callback()
def _top_level(
    version: Annotated[
        bool,
        typer.Option(
            "--version",
            callback=_print_version,
            is_eager=True,
            help="Print the installed swarmsitl version and exit.",
        ),
    ] = False,
) -> None:
    """swarmsitl: PyBullet UAV swarm SITL with PX4-flavoured MAVLink autopilots."""
    forbid_compiles_if_requested()  # SWARMSITL_FORBID_JIT_COMPILE=1: a kernel compile raises


app.command()(up)
app.command()(demo)
app.command("first-flight")(first_flight)
app.command("run")(run)
app.command("cloud")(cloud)
app.command("replay")(replay)
app.command("autopilot")(autopilot)
app.command("net-demo")(net_demo)
app.command("sweep")(sweep)
app.command("experiment")(experiment)
app.add_typer(params_app, name="params")


def main() -> None:
    """Console-script entry point."""
    app()


if __name__ == "__main__":
    main()
