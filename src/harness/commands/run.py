"""``swarmsitl run SCENARIO.yaml``: one scenario, its companions, its report."""

from __future__ import annotations

import signal
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from autopilot_emu.mavlink.endpoint import PortInUseError
from harness.run.launch import console, run_dir_of
from harness.scenarios import scenario_path
from harness.scenarios.runner import RunOptions, RunPorts, ScenarioRun
from harness.scenarios.spec import Scenario, ScenarioError, load_scenario
from harness.swarm.run import run_swarm

SdkPort = Annotated[int, typer.Option(help="vehicle i's onboard link sends to this +i")]
ListenPort = Annotated[int, typer.Option(help="vehicle i's onboard link listens here +i")]
GrpcPort = Annotated[int, typer.Option(help="vehicle i's companion's mavsdk_server +i")]
PayloadPort = Annotated[
    int, typer.Option(help="vehicle i's MAVLink camera +i; 0: no MAVLink camera")
]
Seed = Annotated[int | None, typer.Option(min=0, help="seed of the run [default: the scenario's]")]
Speed = Annotated[
    float | None,
    typer.Option(min=0.01, help="paced: simulated seconds per wall second (e.g. 2)"),
]
Out = Annotated[Path | None, typer.Option(help="run directory [default: runs/<time>]")]

EXIT_FAILED = 1
"""A check failed, a companion failed, or the run did not complete."""
EXIT_BAD_INPUT = 2
"""The scenario (or a port, or an option) is wrong: nothing ran."""
EXIT_INTERRUPTED = 130
"""Ctrl-C: the partial report is written (``complete: false``)."""


def progress_text(run: ScenarioRun) -> str:
    """The status line under the progress bar."""
    sim = run.sim
    assert sim is not None
    commanders = sim.fleet.commanders
    armed = sum(c.armed for c in commanders)
    flying = sum(c.in_air for c in commanders)
    running = sum(c.exit_code is None for c in run.companions)
    failed = sum(c.exit_code not in (None, 0) for c in run.companions)
    text = f"{armed} armed, {flying} flying; companions {running} running"
    if failed:
        text += f", [red]{failed} failed[/red]"
    return text


def swarm_prediction_table(prediction: dict[str, Any]) -> Table:
    """Battery left and airborne time per vehicle, flight model beside swarm engine."""
    table = Table(title="swarm prediction (fidelity swarm beside this run)")
    for col in ("vehicle", "battery full %", "battery swarm %", "swarm - full", "airborne full s",
                "airborne swarm s"):  # fmt: skip
        table.add_column(col, justify="left" if col == "vehicle" else "right")

    def cell(x: Any) -> str:
        return "-" if x is None else f"{x:.1f}"

    for name, v in prediction["vehicles"].items():
        keys = ("battery_remaining_full", "battery_remaining_swarm", "battery_difference",
                "airborne_time_full", "airborne_time_swarm")  # fmt: skip
        table.add_row(name, *(cell(v.get(k)) for k in keys))
    return table


def print_report(report: dict[str, Any]) -> None:
    """The checks and the headline metrics of a finished run."""
    checks = report.get("checks", {})
    if checks:
        table = Table(title="checks")
        for col in ("check", "result", "detail"):
            table.add_column(col)
        for name, c in checks.items():
            table.add_row(
                name, "[green]ok[/green]" if c["ok"] else "[red]FAILED[/red]", c["message"]
            )
        console.print(table)
    prediction = report.get("swarm_prediction")
    if prediction and prediction.get("vehicles"):
        console.print(swarm_prediction_table(prediction))
    for key, c in report.get("companions", {}).items():
        if c.get("traceback"):
            console.print(f"[red]{key}'s companion failed[/red] ({c['log']}):\n{c['traceback']}")


def run(
    scenario: Annotated[
        Path, typer.Argument(exists=True, dir_okay=False, help="the scenario file (YAML)")
    ],
    out: Out = None,
    seed: Seed = None,
    speed: Speed = None,
    lockstep: Annotated[
        bool,
        typer.Option(
            "--lockstep",
            help="as fast as the CPU allows, companions on the simulation clock (the default "
            "without --speed)",
        ),
    ] = False,
    sdk_port: SdkPort = 14540,
    listen_port: ListenPort = 14580,
    grpc_port: GrpcPort = 50051,
    payload_port: PayloadPort = 14030,
    mocap_port: Annotated[
        int, typer.Option(help="vehicle i's motion-capture datagrams +i (GPS-denied worlds)")
    ] = 15400,
    net_port: Annotated[int, typer.Option(help="first node-messaging port (node roles)")] = 47000,
    net_proxy_port: Annotated[int, typer.Option(help="first port of the messaging router")] = 47500,
    timeout: Annotated[
        float | None, typer.Option(help="give up after this many wall seconds (report incomplete)")
    ] = None,
) -> None:
    """Run a scenario: world, fleet, one companion process per vehicle, report.

    Checks the whole scenario (and its world) before anything starts, then flies it and writes
    the run directory: report.json, truth.csv, vehicleN.tlog, timeseries/, plots/, camera/ and
    each companion's log and result (docs/scenarios.md). Exit status: 0 when the run completed
    and every check passed, 1 when not, 2 for a bad scenario, 130 after Ctrl-C (the partial
    report is written, marked incomplete).

    Example:  swarmsitl run src/harness/scenarios/offshore_demo.yaml --out runs/offshore

    Example:  swarmsitl run src/harness/scenarios/city.yaml --seed 3 --speed 2

    A scenario with ``fidelity: swarm`` runs on the swarm-scale engine, in this process, in
    lockstep (docs/swarm.md).

    Example:  swarmsitl run src/harness/scenarios/swarm_coverage.yaml --out runs/swarm
    """
    if speed is not None and lockstep:
        raise typer.BadParameter("give --speed or --lockstep, not both", param_hint="--speed")
    try:
        scenario = load_scenario(scenario)
    except ScenarioError as exc:
        console.print(f"[red]error:[/red] {exc}")
        raise typer.Exit(EXIT_BAD_INPUT) from exc
    run_dir = run_dir_of(out)
    if scenario.spec.fidelity == "swarm":
        if speed is not None:
            raise typer.BadParameter(
                "a fidelity: swarm scenario runs in lockstep only", param_hint="--speed"
            )
        _run_swarm(scenario, run_dir, seed)
        return
    ports = RunPorts(
        sdk=sdk_port,
        listen=listen_port,
        grpc=grpc_port,
        payload=payload_port,
        mocap=mocap_port,
        net=net_port,
        net_proxy=net_proxy_port,
    )
    try:
        runner = ScenarioRun(scenario, RunOptions(run_dir, seed, speed, ports, timeout))
    except ValueError as exc:  # e.g. more vehicles than a launch area holds
        console.print(f"[red]error:[/red] {exc}")
        raise typer.Exit(EXIT_BAD_INPUT) from exc
    spec = scenario.spec
    mode = "lockstep" if speed is None else f"paced at {speed:g}x"
    console.print(
        f"[bold]{spec.name}[/bold]: {spec.n_vehicles} vehicle(s), "
        f"{scenario.world.kind if scenario.world else 'no'} world, {spec.duration_s:g} s, "
        f"seed {runner.seed}, {mode}; run dir {run_dir}"
    )
    old = {
        s: signal.signal(s, lambda *_: runner.request_stop())
        for s in (signal.SIGINT, signal.SIGTERM)
    }
    try:
        with Progress(
            TextColumn("[bold]t = {task.completed:7.1f} s[/bold]"),
            BarColumn(),
            TextColumn("{task.fields[status]}"),
            TimeElapsedColumn(),
            console=console,
            transient=False,
        ) as bar:
            task = bar.add_task("simulated", total=spec.duration_s, status="starting")

            def show(r: ScenarioRun) -> None:
                bar.update(task, completed=r.sim.time_s, status=progress_text(r))

            report = runner.run(show)
    except PortInUseError as exc:
        console.print(f"[red]error:[/red] {exc} (choose other ports: --listen-port, ...)")
        raise typer.Exit(EXIT_BAD_INPUT) from exc
    except (OSError, ValueError) as exc:
        console.print(f"[red]error:[/red] {exc}")
        raise typer.Exit(EXIT_BAD_INPUT) from exc
    finally:
        for s, h in old.items():
            signal.signal(s, h)
    print_report(report)
    console.print(
        f"{report.get('stop_reason')}: {report.get('sim_time_s', 0):.1f} s simulated in "
        f"{report.get('wall_time_s', 0):.1f} s; report {run_dir / 'report.json'}"
    )
    if runner.stop_reason == "interrupted":
        raise typer.Exit(EXIT_INTERRUPTED)
    if not report.get("passed", False):
        raise typer.Exit(EXIT_FAILED)


def _run_swarm(scenario: Scenario, run_dir: Path, seed: int | None) -> None:
    """``swarmsitl run`` of a ``fidelity: swarm`` scenario: in-process, with a progress bar."""
    spec = scenario.spec
    console.print(
        f"[bold]{spec.name}[/bold]: {spec.n_vehicles} kinematic vehicle(s), "
        f"{scenario.world.kind if scenario.world else 'no'} world, {spec.duration_s:g} s, "
        f"seed {spec.seed if seed is None else seed}, fidelity swarm; run dir {run_dir}"
    )
    with Progress(
        TextColumn("[bold]t = {task.completed:7.1f} s[/bold]"),
        BarColumn(),
        TimeElapsedColumn(),
        console=console,
    ) as bar:
        task = bar.add_task("simulated", total=spec.duration_s)
        try:
            report = run_swarm(
                scenario, seed, run_dir, progress=lambda t: bar.update(task, completed=t)
            )
        except (OSError, ValueError) as exc:
            console.print(f"[red]error:[/red] {exc}")
            raise typer.Exit(EXIT_BAD_INPUT) from exc
    print_report(report)
    console.print(
        f"{report['stop_reason']}: {report['sim_time_s']:.1f} s simulated in "
        f"{report['wall_time_s']:.1f} s; report {run_dir / 'report.json'}"
    )
    if not report.get("passed", False):
        raise typer.Exit(EXIT_FAILED)


def demo(
    out: Out = None,
    seed: Seed = None,
    speed: Speed = None,
    sdk_port: SdkPort = 14540,
    listen_port: ListenPort = 14580,
    grpc_port: GrpcPort = 50051,
    payload_port: PayloadPort = 14030,
) -> None:
    """Fly the offshore demo: three hexacopters survey the sea around an oil rig for spills.

    Runs the shipped scenario src/harness/scenarios/offshore_demo.yaml (docs/scenarios.md):
    three Typhoon H480s take off from the rig's helideck, each flies its strip of a zigzag
    survey for two simulated minutes with its own companion process (plain MAVSDK-Python,
    companion/scripts/coverage.py) counting the oil spills its camera sees, and lands back on
    the deck. Headless; writes report.json (checks, per-vehicle metrics, spills seen),
    plots/map.png (trajectories over the world), truth.csv, tlogs and camera samples.

    Example:  swarmsitl demo --out runs/demo
    """
    run(
        scenario_path("offshore_demo"),
        out=out,
        seed=seed,
        speed=speed,
        sdk_port=sdk_port,
        listen_port=listen_port,
        grpc_port=grpc_port,
        payload_port=payload_port,
    )
