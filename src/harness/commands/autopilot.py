"""``swarmsitl autopilot``: our emulator as an external autopilot, and ``up``'s external mode.

``swarmsitl up --autopilot external`` makes the simulator listen on TCP 4560+i for PX4's
simulator protocol; ``swarmsitl autopilot --instance i`` (or PX4 SITL, or a Pixhawk in HITL
through a bridge) is then the autopilot of vehicle i. See docs/px4.md.
"""

from __future__ import annotations

import logging
import signal
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape
from rich.table import Table

from autopilot_emu.params import ParamError
from autopilot_emu.simulator_link import SimulatorLinkConfig
from harness.commands.params import load_params_or_exit
from harness.run.launch import StopFlag, console
from harness.sim.external_autopilot import ExternalAutopilot, ExternalAutopilotConfig
from harness.sim.simulation import EXTERNAL, PortPlan, Simulation
from sitl.hil_serial import parse_serial
from sitl.hil_server import HIL_PORT_BASE

AUTOPILOT_HELP = (
    "internal: one emulated autopilot per vehicle in this process (default); external: the "
    "simulator listens on TCP --hil-port+i for PX4's simulator protocol and waits for an "
    "autopilot per vehicle (swarmsitl autopilot, PX4 SITL, HITL), which owns the MAVLink links "
    "(e.g. --autopilot external, then: swarmsitl autopilot --instance 0)"
)
MAX_SYSID = 255
"""MAVLink system ids a parameter file may name."""
HIL_PORT_HELP = "TCP port of vehicle 0's external autopilot (+i per vehicle; PX4: 4560+instance)"
HIL_SERIAL_HELP = (
    "HITL: vehicle i's Pixhawk on this serial port instead of TCP (repeat: one per vehicle); "
    "its other MAVLink traffic is relayed to --gcs-port and --sdk-port+i; real time only "
    "(e.g. --autopilot external --hil-serial /dev/ttyACM0:921600; docs/px4.md)"
)


def check_hil_serial(
    devices: list[str], vehicles: int, autopilot: str, speed: float, lockstep: bool
) -> None:
    """``--hil-serial``: one valid DEVICE[:BAUD] per vehicle, an external autopilot, real time."""
    if not devices:
        return
    hint = "--hil-serial"
    if autopilot != EXTERNAL:
        raise typer.BadParameter("needs --autopilot external", param_hint=hint)
    if len(devices) != vehicles:
        raise typer.BadParameter(
            f"give one device per vehicle ({vehicles}), got {len(devices)}", param_hint=hint
        )
    for spec in devices:
        try:
            parse_serial(spec)
        except ValueError as exc:
            raise typer.BadParameter(str(exc), param_hint=hint) from exc
    if lockstep or speed != 1.0:
        raise typer.BadParameter(
            "a board in HITL runs on its own clock: run at --speed 1, without --lockstep",
            param_hint=hint,
        )


def print_external_table(sim: Simulation, run_dir: Path, speed_text: str) -> None:
    """What each vehicle's external autopilot connects to, and how to start one."""
    table = Table(title=f"swarmsitl: {sim.config.n_vehicles} vehicle(s), external autopilots, "
                  f"{speed_text}, run dir {run_dir}")  # fmt: skip
    for col in ("vehicle", "airframe", "simulator (PX4 protocol)", "start its autopilot with",
                "home lat, lon, alt"):  # fmt: skip
        table.add_column(col, no_wrap=True)
    for i, port in enumerate(sim.hil.ports()):
        lat, lon, alt = sim.world.home_geodetic(i)
        start = (
            "a Pixhawk in HITL (SYS_HITL 1)"
            if port == 0
            else f"swarmsitl autopilot --instance {i}"
            + ("" if port == HIL_PORT_BASE + i else f" --connect tcp:127.0.0.1:{port}")
        )
        table.add_row(
            str(i + 1),
            sim.world.airframes[i].name,
            sim.hil.describe(i),
            start,
            f"{lat:.6f}, {lon:.6f}, {alt:.1f}",
        )
    console.print(table)
    ports = sim.config.ports
    if sim.config.hil_serial:
        console.print(
            f"HITL: each board's other MAVLink traffic is relayed to udp {ports.peer_addr}:"
            f"{ports.gcs_port} (ground station) and {ports.peer_addr}:{ports.sdk_base}+i "
            "(offboard API), and what they send back to the board (docs/px4.md)"
        )
    else:
        console.print(
            "PX4 SITL instead: PX4_SYS_AUTOSTART=6011 build/px4_sitl_default/bin/px4 -i <i> -d "
            "(instance i connects to 4560+i; docs/px4.md). MAVLink clients talk to the autopilots."
        )


def print_hil_stats(sim: Simulation) -> None:
    """One line per vehicle: what its HIL connection carried and how it ended."""
    for i, st in enumerate(sim.hil.stats()):
        console.print(
            f"vehicle {i + 1} HIL: {st.connections} connection(s), {st.actuator_messages} "
            f"HIL_ACTUATOR_CONTROLS in, {st.bytes_out} B out, {st.disconnects} disconnect(s), "
            f"{st.stalls} stall(s), {st.refused} refused, {st.bad_frames} malformed"
        )


def external_status(sim: Simulation) -> str:
    """One status line of the external autopilots' connections."""
    connected = sum(sim.hil.connected)
    lost = sum(s.disconnects + s.stalls for s in sim.hil.stats())
    return f"{connected}/{sim.config.n_vehicles} autopilots connected" + (
        f", {lost} lost" if lost else ""
    )


def wait_for_autopilots(sim: Simulation) -> bool:
    """Wait (Ctrl-C ends it) until every vehicle's autopilot has connected; False if stopped."""
    flag = StopFlag()
    old = {s: signal.signal(s, flag) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        with console.status("waiting for the autopilots to connect ...") as status:
            done = sim.wait_for_autopilots(
                lambda: status.update(f"waiting: {external_status(sim)} ...") or flag.stop
            )
    finally:
        for s, h in old.items():
            signal.signal(s, h)
    if not done:
        console.print("stopped before every autopilot connected")
    return done


def _parse_connect(spec: str | None, instance: int) -> tuple[str, int]:
    if spec is None:
        return "127.0.0.1", HIL_PORT_BASE + instance
    kind, _, rest = spec.partition(":")
    host, _, port = rest.rpartition(":")
    if kind != "tcp" or not host or not port.isdigit() or not 1 <= int(port) <= 65535:
        raise typer.BadParameter(
            f"{spec!r}: expected tcp:HOST:PORT, e.g. tcp:127.0.0.1:4560", param_hint="--connect"
        )
    return host, int(port)


def autopilot(
    instance: Annotated[
        int, typer.Option(min=0, max=254, help="PX4 instance: system id i+1, ports base+i")
    ] = 0,
    connect: Annotated[
        str | None,
        typer.Option(
            metavar="tcp:HOST:PORT",
            help="the simulator's port of this vehicle [default: tcp:127.0.0.1:4560+instance]",
        ),
    ] = None,
    frame: Annotated[
        str,
        typer.Option(help="airframe whose parameters it starts with; must be the simulator's"),
    ] = "typhoon_h480",
    bind: Annotated[str, typer.Option(help="address the MAVLink links listen on")] = "127.0.0.1",
    sdk_port: Annotated[
        int, typer.Option(help="onboard link sends to this port + instance (MAVSDK)")
    ] = 14540,
    listen_port: Annotated[int, typer.Option(help="onboard link listens on this + instance")] = (
        14580
    ),
    gcs_port: Annotated[int, typer.Option(help="ground-station port (0: no GCS link)")] = 14550,
    gcs_listen_port: Annotated[
        int, typer.Option(help="GCS link listens on this + instance")
    ] = 18570,
    out: Annotated[
        Path | None, typer.Option(help="where tlogs and the FTP root go [default: none]")
    ] = None,
    no_lockstep: Annotated[
        bool,
        typer.Option(
            "--no-lockstep", help="do not flag lockstep: the simulator never waits for replies"
        ),
    ] = False,
    connect_timeout: Annotated[
        float, typer.Option(help="give up after this many wall seconds without a simulator")
    ] = 0.0,
    params: Annotated[
        list[str] | None,
        typer.Option(
            metavar="[SYSID=|all=]FILE",
            help="QGroundControl .params file(s) as up --params; this vehicle's rows load "
            "(e.g. --params run/client_params.params)",
        ),
    ] = None,
) -> None:
    """Run one emulated PX4 autopilot against a simulator over PX4's TCP simulator protocol.

    It does what PX4 SITL instance i does: connects to the simulator on TCP 4560+i (retrying
    until it is accepted), sends a HEARTBEAT, asks for HIL_STATE_QUATERNION, and answers every
    HIL_SENSOR with HIL_ACTUATOR_CONTROLS (lockstep); its MAVLink links are PX4 SITL's (onboard
    14580+i -> 14540+i, ground station 18570+i -> 14550), system id i+1. It ends when the
    simulator closes the connection, or on Ctrl-C.

    Example:  swarmsitl up --autopilot external   (in one terminal), then
              swarmsitl autopilot --instance 0   (in another; MAVSDK: udpin://0.0.0.0:14540)

    Example:  swarmsitl autopilot --instance 2 --connect tcp:sim-host:4562 --frame x500
    """
    host, port = _parse_connect(connect, instance)
    # Every system id a file may name: this instance takes its own rows (system id i+1).
    loaded = load_params_or_exit(params, MAX_SYSID)
    own = {} if loaded is None else loaded.vehicle_params[instance]
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    try:
        ap = ExternalAutopilot(
            ExternalAutopilotConfig(
                instance=instance,
                simulator=SimulatorLinkConfig(host=host, port=port, lockstep=not no_lockstep),
                frame=frame,
                ports=PortPlan(
                    bind_addr=bind,
                    sdk_base=sdk_port,
                    listen_base=listen_port,
                    gcs_port=gcs_port,
                    gcs_listen_base=gcs_listen_port,
                ),
                out_dir=out,
                params=tuple(own.items()),
            )
        )
    except (OSError, ValueError, ParamError) as exc:
        console.print(f"[red]error:[/red] {escape(str(exc))}")
        raise typer.Exit(2) from exc
    links = [
        f"{name} {ep.local_address[0]}:{ep.local_address[1]} -> "
        + ", ".join(f"{h}:{p}" for h, p in ep.peers)
        for name, ep in zip(("onboard", "ground station"), ap.endpoints, strict=False)
    ]
    console.print(
        f"autopilot of vehicle {instance + 1} ({frame}): simulator tcp {host}:{port}; MAVLink "
        + "; ".join(links)
    )
    if loaded is not None:
        console.print(f"{len(own)} parameter(s) from {', '.join(map(str, loaded.files))}")
    flag = StopFlag()
    old = {s: signal.signal(s, flag) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        ended = ap.run(lambda: flag.stop, connect_timeout if connect_timeout > 0 else None)
    finally:
        ap.close()
        for s, h in old.items():
            signal.signal(s, h)
    stats = ap.link.stats
    console.print(
        f"{ended} at t = {ap.link.time_s:.1f} s simulated: {stats.sensor_messages} HIL_SENSOR, "
        f"{stats.actuator_messages} HIL_ACTUATOR_CONTROLS, {stats.bad_frames} malformed"
    )
    if ended == "no simulator":
        raise typer.Exit(1)
