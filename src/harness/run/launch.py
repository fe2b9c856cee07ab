"""Starting a run from the command line: its console, its run directory, its simulation."""

from __future__ import annotations

import datetime as dt
from pathlib import Path
from types import FrameType

import typer
from rich.console import Console

from autopilot_emu.mavlink.endpoint import PortInUseError
from harness.sim.simulation import Simulation, SimulationConfig

console = Console(width=max(Console().width, 140))
"""The terminal every command prints to (wide: the endpoint tables hold whole addresses)."""


def default_run_dir() -> Path:
    """runs/<timestamp> under the current directory, as an absolute path."""
    return Path.cwd() / "runs" / dt.datetime.now().strftime("%Y%m%d-%H%M%S")


def run_dir_of(out: Path | None) -> Path:
    """The run directory of a command's ``--out``: absolute, or :func:`default_run_dir`.

    Everything a run hands on (companions' environment, bridges, the clock file a user copies)
    names this directory; companions start in other working directories, so it must not be
    relative to the caller's.
    """
    return default_run_dir() if out is None else out.absolute()


def open_simulation(cfg: SimulationConfig) -> Simulation:
    """The simulation of ``cfg``, or a clear error and exit 2 (taken port, bad parameter)."""
    try:
        return Simulation(cfg)
    except PortInUseError as exc:
        console.print(f"[red]error:[/red] {exc}")
        console.print(
            "Another swarmsitl (or PX4 SITL) is probably running; stop it or choose other "
            "ports with --listen-port / --gcs-listen-port / --payload-listen-port."
        )
        raise typer.Exit(2) from exc
    except (OSError, ValueError) as exc:  # a taken video port, a camera that sees its vehicle
        console.print(f"[red]error:[/red] {exc}")
        raise typer.Exit(2) from exc


class StopFlag:
    """Set by SIGINT/SIGTERM; the loop polls it and shuts down cleanly."""

    def __init__(self) -> None:
        self.stop = False

    def __call__(self, signum: int, frame: FrameType | None) -> None:
        """The signal handler: note the request to stop."""
        self.stop = True
