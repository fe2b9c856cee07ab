"""``swarmsitl first-flight``: one hexacopter flown by a real MAVSDK client, with a report."""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from harness.run.launch import console, open_simulation, run_dir_of
from harness.run.session import RunSession
from harness.sim.simulation import PortPlan, SimulationConfig


def first_flight(
    out: Annotated[Path | None, typer.Option(help="run directory [default: runs/<time>]")] = None,
    speed: Annotated[float, typer.Option(help="simulation seconds per wall second")] = 2.0,
    seed: Annotated[int, typer.Option(help="seed of every random draw")] = 0,
    sdk_port: Annotated[int, typer.Option(help="MAVSDK port")] = 14540,
    listen_port: Annotated[int, typer.Option(help="vehicle listen port")] = 14580,
    grpc_port: Annotated[int, typer.Option(help="port of the client's mavsdk_server")] = 50051,
    timeout: Annotated[float, typer.Option(help="give up after this many wall seconds")] = 600.0,
) -> None:
    """Fly one hexacopter through takeoff, goto, RTL and landing with a real MAVSDK client.

    The client (companion/scripts/demo_flight.py, plain MAVSDK-Python) runs in its own process
    and talks MAVLink over UDP. The run directory gets report.json (climb time, hover and
    arrival errors, max tilt, hover power and endurance, energy), trajectory.png, truth.csv
    and vehicle1.tlog.

    Example:  swarmsitl first-flight --out runs/first --speed 4
    """
    from harness.report.demo import demo_metrics, plot_trajectory, write_report

    run_dir = run_dir_of(out)
    ports = PortPlan(sdk_base=sdk_port, listen_base=listen_port, gcs_port=0)
    cfg = SimulationConfig(n_vehicles=1, seed=seed, ports=ports, out_dir=run_dir)
    sim = open_simulation(cfg)
    events_path = run_dir / "client_events.json"
    cmd = [
        sys.executable,
        "-m",
        "companion.scripts.demo_flight",
        "--url",
        f"udpin://0.0.0.0:{sdk_port}",
        "--grpc-port",
        str(grpc_port),
        "--events",
        str(events_path),
    ]
    console.print(f"[bold]swarmsitl first-flight[/bold]: speed {speed:g}x, run dir {run_dir}")
    with RunSession(sim, run_dir, speed=speed) as session:
        proc = session.start_process("client", cmd, run_dir / "client.log")
        t0 = session.wall_start_s

        def ended() -> bool:
            return proc.poll() is not None or session.stopped or time.monotonic() - t0 > timeout

        with console.status("flying: takeoff, hover, goto 50 m north, RTL, land ..."):
            session.advance(math.inf, ended)
    if not events_path.exists():
        console.print(f"[red]client wrote no event log; see {run_dir / 'client.log'}[/red]")
        raise typer.Exit(1)
    client = json.loads(events_path.read_text())
    track = sim.recorder.vehicle(0)
    origin = (
        sim.world.config.origin_lat_deg,
        sim.world.config.origin_lon_deg,
        sim.world.config.origin_alt_amsl_m,
    )
    metrics = demo_metrics(
        track, client["events"], client["settings"], origin, sim.world.power.spec.battery
    )
    write_report(
        run_dir / "report.json",
        metrics,
        {
            "speed": speed,
            "seed": seed,
            "sim_time_s": sim.time_s,
            "client_exit_code": proc.returncode,
            "events": client["events"],
            "client_settings": client["settings"],
            "units": "SI; keys carry their unit",
        },
    )
    plot_trajectory(track, run_dir / "trajectory.png", "swarmsitl first-flight: takeoff, goto, RTL")
    table = Table(title="demo flight (from simulated ground truth)")
    table.add_column("metric")
    table.add_column("value", justify="right")
    for k, v in metrics.items():
        table.add_row(k, f"{v:.3f}" if isinstance(v, float) else str(v))
    console.print(table)
    console.print(f"report: {run_dir / 'report.json'}  plot: {run_dir / 'trajectory.png'}")
    if not metrics.get("completed"):
        console.print(f"[red]the flight did not complete; see {run_dir / 'client.log'}[/red]")
        raise typer.Exit(1)
