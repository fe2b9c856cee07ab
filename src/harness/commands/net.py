"""The messaging network on the command line: ``swarmsitl cloud`` and ``swarmsitl net-demo``.

The role processes, the node table and the report they share with ``swarmsitl up --net`` and
``swarmsitl run`` are in :mod:`harness.net.roles`.
"""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path
from typing import Annotated

import typer

from harness.net.plan import NetPlan, NetRun
from harness.net.roles import (
    attach,
    node_table,
    role_output,
    role_process,
    write_report,
)
from harness.run.launch import console, open_simulation, run_dir_of
from harness.run.session import RunSession
from harness.sim.link_models import links_config

LANDING_S = 60.0
"""Simulated seconds the demo keeps running after the roles stop, for the vehicles to land."""


def cloud(
    net: Annotated[
        Path | None,
        typer.Option(help="network file (companion.net YAML) [default: $SWARMSITL_NET]"),
    ] = None,
    node: Annotated[str, typer.Option(help="this node's id in the network file")] = "cloud",
    duration: Annotated[
        float, typer.Option(help="simulated seconds to serve (Ctrl-C ends it earlier)")
    ] = 3600.0,
    records: Annotated[Path | None, typer.Option(help="JSON file for the node's records")] = None,
) -> None:
    """Run the cloud node of seed 000's edge-fog-cloud system in this process.

    It answers the fog nodes' registrations and summaries and everyone's pings over UDP
    (companion.net), on the host, as the paper's ground server. Under `swarmsitl up --net` the
    cloud starts by itself; run this for a cloud of your own or on another machine.

    Example:  swarmsitl cloud --net runs/x/net.yaml --duration 600
    """
    from companion.roles.__main__ import main as roles_main

    if net is not None:
        os.environ["SWARMSITL_NET"] = str(net)
    if "SWARMSITL_NET" not in os.environ:
        raise typer.BadParameter("give --net FILE or set SWARMSITL_NET", param_hint="--net")
    os.environ["SWARMSITL_NODE"] = node
    argv = ["--duration-s", f"{duration:g}"] + (["--records", str(records)] if records else [])
    try:
        code = roles_main(argv)
    except (ValueError, OSError) as exc:  # a bad network file, a taken port
        console.print(f"[red]error:[/red] {exc}")
        raise typer.Exit(2) from exc
    raise typer.Exit(code)


def net_demo(
    out: Annotated[Path | None, typer.Option(help="run directory [default: runs/<time>]")] = None,
    speed: Annotated[float, typer.Option(help="simulation seconds per wall second")] = 2.0,
    duration: Annotated[float, typer.Option(help="simulated seconds of messaging")] = 60.0,
    seed: Annotated[int, typer.Option(help="seed of every random draw")] = 0,
    links: Annotated[
        Path | None,
        typer.Option(help="your link file, merged over the shipped presets (docs/links.md)"),
    ] = None,
    fly: Annotated[bool, typer.Option(help="the companions fly their vehicles at 10 m")] = True,
    sdk_port: Annotated[int, typer.Option(help="MAVLink port of vehicle 1's companion (+i)")] = (
        14540
    ),
    listen_port: Annotated[int, typer.Option(help="vehicle 1's MAVLink listen port (+i)")] = 14580,
    net_port: Annotated[int, typer.Option(help="UDP port of the first node (+k)")] = 47000,
    proxy_port: Annotated[int, typer.Option(help="router port of the first node (+k)")] = 47500,
    timeout: Annotated[float, typer.Option(help="give up after this many wall seconds")] = 600.0,
) -> None:
    """Seed 000's edge-fog-cloud system: two edge UAVs, a fog UAV and the cloud, messaging.

    Three vehicles fly (their companions take off to 10 m over MAVLink); each companion is a
    process running its role (python -m companion.roles: edges send status and compressed
    images to the fog and ping each other over WiFi, the fog decodes them and relays them
    re-compressed to the cloud and reports to it over LTE),
    and the cloud is a process on the host. Every datagram crosses the link models in
    simulation time. The run directory gets net_report.json (per link class: latency, loss,
    availability, uptime, throughput, overhead; energy per node, component and task), net.yaml,
    the nodes' records (net/) and logs, and the vehicles' tlogs.

    Example:  swarmsitl net-demo --duration 60 --out runs/net
    """
    from harness.sim.simulation import PortPlan, SimulationConfig

    if not duration > 0 or not speed > 0:
        raise typer.BadParameter("--duration and --speed must be > 0")
    run_dir = run_dir_of(out)
    try:
        link_config = links_config(links)
        plan = NetPlan(
            roles=("edge", "edge", "fog"),
            node_base=net_port,
            proxy_base=proxy_port,
            links=link_config,
        )
        net = NetRun(plan, seed, run_dir)
    except (OSError, ValueError) as exc:
        console.print(f"[red]error:[/red] {exc}")
        raise typer.Exit(2) from exc
    cfg = SimulationConfig(
        n_vehicles=len(plan.roles),
        seed=seed,
        ports=PortPlan(sdk_base=sdk_port, listen_base=listen_port, gcs_port=0, payload_base=0),
        out_dir=run_dir,
        router=net.router,
        links=link_config,
    )
    sim = open_simulation(cfg)
    attach(net, sim)
    console.print(node_table(net))
    messaging_s = 0.0
    # Leaving the session stops the roles and closes while signals only set the flag: the
    # records and tlogs stay whole.
    with RunSession(sim, run_dir, speed=speed) as session:
        procs = session.processes
        t0 = session.wall_start_s
        for node in net.nodes:
            extra = ["--seed", str(seed)]
            if fly and node.vehicle is not None:
                extra += ["--mavlink", f"udpin:127.0.0.1:{sdk_port + node.vehicle}"]
            # The roles run until told to stop: the window is measured in simulation time here.
            log_path = run_dir / f"{node.node_id}.log"
            session.adopt_process(
                node.node_id,
                role_process(net, node.node_id, 1e9, speed, t0, log_path, extra),
            )

        def gave_up() -> bool:
            return (
                session.stopped
                or time.monotonic() - t0 > timeout
                or any(p.poll() is not None for p in procs.values())
            )

        def all_ended() -> bool:
            return (
                session.stopped
                or time.monotonic() - t0 > timeout
                or all(p.poll() is not None for p in procs.values())
            )

        with console.status(f"messaging for {duration:g} simulated s at {speed:g}x ..."):
            session.advance(duration, gave_up)
            messaging_s = sim.time_s
            for proc in procs.values():  # each writes its records, then lands its vehicle
                if proc.poll() is None:
                    proc.send_signal(signal.SIGTERM)
            if not session.stopped:
                session.advance(LANDING_S, all_ended)
    interrupted = session.stopped
    outputs = {n: role_output(run_dir / f"{n}.log", proc) for n, proc in procs.items()}
    write_report(
        net,
        sim.time_s,
        run_dir / "net_report.json",
        {
            "seed": seed,
            "speed": speed,
            "messaging_s": messaging_s,
            "sim_time_s": sim.time_s,
            "achieved_speed": sim.time_s / max(time.monotonic() - t0, 1e-9),
            "roles": outputs,
            "interrupted": interrupted,
        },
        traffic_s=messaging_s if messaging_s > 0 else None,
    )
    if interrupted:
        console.print("[yellow]interrupted: the report covers the run so far[/yellow]")
        raise typer.Exit(130)
    failed = [n for n, p in procs.items() if p.returncode not in (0, -signal.SIGTERM)]
    if failed:
        console.print(f"[red]roles that failed: {', '.join(failed)}; see their logs[/red]")
        raise typer.Exit(1)
