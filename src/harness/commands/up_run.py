"""``swarmsitl up`` behind its flags: checked, turned into a run, served until Ctrl-C.

What the flags ask for (:class:`UpFlags`) is checked and turned into a simulation config and
what goes with the run (:func:`plan_up`), then served (:func:`serve`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import typer
from rich.markup import escape

from harness.commands.autopilot import (
    check_hil_serial,
    external_status,
    print_hil_stats,
    wait_for_autopilots,
)
from harness.commands.params import load_params_or_exit
from harness.commands.up_banner import print_banner, print_link_loads
from harness.commands.up_options import (
    camera_override,
    parse_gps_outages,
    parse_link_model,
    parse_stream_rates,
)
from harness.net.plan import NetPlan, NetRun, parse_roles
from harness.net.roles import attach, node_table, role_process, write_net_env
from harness.net.roles import write_report as write_net_report
from harness.options.params import CLIENT_PARAMS_FILE, ParamsLoad
from harness.options.signing import (
    signing_key,
    unauthenticated_warning,
)
from harness.options.wind import (
    parse_gusts,
    parse_turbulence,
    parse_wind,
    wind_config,
)
from harness.options.world import parse_frames, world_options
from harness.run.launch import console, open_simulation, run_dir_of
from harness.run.lockstep import LOCKSTEP
from harness.run.session import RunSession
from harness.sim.client_links import parse_udp_out
from harness.sim.link_models import NO_LINK, links_config
from harness.sim.simulation import EXTERNAL, INTERNAL, PortPlan, SimulationConfig
from harness.sim.world_setup import WorldSetup, world_config
from sitl.sensors.camera import MOUNT_PITCH_DEG
from sitl.sensors.gps import GpsOutages


@dataclass(frozen=True)
class UpFlags:
    """The flags of ``swarmsitl up`` as given (see its ``--help`` for each)."""

    vehicles: int
    speed: float
    lockstep: bool
    max_speed: float
    bind: str
    signing_key_file: Path | None
    signing_passphrase: str | None
    sdk_port: int
    listen_port: int
    gcs_port: int
    gcs_listen_port: int
    spacing: float
    seed: int
    frame: str
    out: Path | None
    duration: float
    stream_rate: list[str] | None
    wind: str | None
    turbulence: str | None
    gusts: str | None
    mocap: float
    mocap_port: int
    gps_outage: list[str] | None
    rangefinders: bool
    camera: bool
    camera_mount: str | None
    camera_size: str | None
    camera_hz: float | None
    camera_fov: float | None
    video_port: int
    payload_port: int
    payload_listen_port: int
    link: str
    gcs_link: str
    links: Path | None
    net: str | None
    cloud_node: bool
    net_port: int
    net_proxy_port: int
    world: Path | None
    serial: bool
    udp_out: list[str] | None
    launch_area: str | None
    params: list[str] | None
    autopilot: str
    hil_port: int
    hil_serial: list[str] | None


@dataclass(frozen=True)
class UpPlan:
    """What the flags ask for, checked: the simulation's config and what goes with the run."""

    config: SimulationConfig
    run_dir: Path
    setup: WorldSetup | None
    """The world file's setup (None: no --world)."""
    params_load: ParamsLoad | None
    """The --params files read (None: none)."""
    net_run: NetRun | None
    """The node messaging network (None: no --net)."""


def plan_up(o: UpFlags) -> UpPlan:
    """Check the flags and build the run's config; a bad flag exits with its message."""
    if o.autopilot not in (INTERNAL, EXTERNAL):
        raise typer.BadParameter(
            f"{o.autopilot!r}: expected {INTERNAL} or {EXTERNAL}", param_hint="--autopilot"
        )
    check_hil_serial(o.hil_serial or [], o.vehicles, o.autopilot, o.speed, o.lockstep)
    if o.max_speed and not o.lockstep:
        raise typer.BadParameter(
            "caps a --lockstep run; a paced run keeps --speed", param_hint="--max-speed"
        )
    if o.autopilot == EXTERNAL:
        ignored = [
            name
            for name, given in (
                ("--link", o.link != NO_LINK),
                ("--gcs-link", o.gcs_link != NO_LINK),
                ("--signing-key", bool(o.signing_key_file or o.signing_passphrase)),
                ("--params", bool(o.params)),
                ("--stream-rate", bool(o.stream_rate)),
                ("--serial", o.serial),
                ("--udp-out", bool(o.udp_out)),
            )
            if given
        ]
        if ignored:
            console.print(
                f"[yellow]warning:[/yellow] {', '.join(ignored)} configure the internal "
                "autopilot's links and parameters; with --autopilot external the autopilots own "
                "them (set them there)"
            )
    try:
        key = signing_key(o.signing_key_file, o.signing_passphrase)
    except ValueError as exc:
        console.print(f"[red]error:[/red] {escape(str(exc))}")
        raise typer.Exit(2) from exc
    exposed = unauthenticated_warning(o.bind, key)
    if exposed is not None:
        console.print(f"[yellow]warning:[/yellow] {escape(exposed)}")
    frames = parse_frames(o.frame, o.vehicles)
    try:
        udp_outs = tuple(parse_udp_out(spec) for spec in o.udp_out or [])
    except ValueError as exc:
        raise typer.BadParameter(str(exc), param_hint="--udp-out") from exc
    link = parse_link_model(o.link, "--link", o.links)
    gcs_link = parse_link_model(o.gcs_link, "--gcs-link", o.links)
    roles = None
    if o.net is not None:
        try:
            roles = parse_roles(o.net, o.vehicles)
        except ValueError as exc:
            raise typer.BadParameter(str(exc), param_hint="--net") from exc
    physics_hz = SimulationConfig().physics_hz
    if o.camera_mount is not None and o.camera_mount not in MOUNT_PITCH_DEG:
        raise typer.BadParameter(
            f"{o.camera_mount!r}: expected one of {', '.join(MOUNT_PITCH_DEG)}",
            param_hint="--camera-mount",
        )
    per_vehicle = frames * o.vehicles if len(frames) == 1 else frames
    camera_spec = (
        camera_override(
            per_vehicle, o.camera_mount, o.camera_size, o.camera_hz, o.camera_fov, physics_hz
        )
        if o.camera
        else None
    )
    if o.mocap < 0 or (
        o.mocap > 0 and abs(physics_hz / o.mocap - round(physics_hz / o.mocap)) > 1e-9
    ):
        raise typer.BadParameter(
            f"--mocap {o.mocap:g}: must be 0 or divide the {physics_hz:g} Hz physics rate"
        )
    setup = world_options(o.world, o.launch_area, o.vehicles, o.spacing)
    params_load = load_params_or_exit(o.params, o.vehicles)
    run_dir = run_dir_of(o.out)
    net_run = None
    if roles is not None:
        try:
            plan = NetPlan(
                roles, cloud=o.cloud_node, node_base=o.net_port, proxy_base=o.net_proxy_port,
                links=links_config(o.links),
            )  # fmt: skip
            net_run = NetRun(plan, o.seed, run_dir)
        except (OSError, ValueError) as exc:
            console.print(f"[red]error:[/red] {exc}")
            raise typer.Exit(2) from exc
    ports = PortPlan(
        bind_addr=o.bind,
        sdk_base=o.sdk_port,
        listen_base=o.listen_port,
        gcs_port=o.gcs_port,
        gcs_listen_base=o.gcs_listen_port,
        video_base=o.video_port,
        payload_listen_base=o.payload_listen_port,
        payload_base=o.payload_port,
        hil_base=o.hil_port,
    )
    wind_given = o.wind is not None or o.turbulence is not None or o.gusts is not None
    cfg = SimulationConfig(
        n_vehicles=o.vehicles,
        seed=o.seed,
        frames=frames,
        spacing_m=o.spacing,
        ports=ports,
        out_dir=run_dir,
        stream_rates_hz=parse_stream_rates(o.stream_rate or []),
        wind=wind_config(parse_wind(o.wind), parse_turbulence(o.turbulence), parse_gusts(o.gusts))
        if wind_given or setup is None
        else setup.wind,
        params=setup.params if setup is not None else {},
        vehicle_params=params_load.vehicle_params if params_load is not None else (),
        world=world_config(
            o.vehicles,
            setup,
            rangefinders=o.rangefinders,
            cameras=o.camera,
            camera=camera_spec,
            mocap_hz=o.mocap if o.mocap > 0 else None,
            gps_outages=GpsOutages(windows=parse_gps_outages(o.gps_outage))
            if o.gps_outage
            else None,
        ),
        mocap_port=o.mocap_port,
        onboard_link=link,
        gcs_link=gcs_link,
        links=links_config(o.links),
        router=net_run.router if net_run is not None else None,
        signing_key=key,
        autopilot=o.autopilot,
        hil_serial=tuple(o.hil_serial or ()),
        serial=o.serial,
        udp_outs=udp_outs,
        ping_period_s=LOCKSTEP.ping_period_s if o.lockstep else 0.0,
    )
    return UpPlan(cfg, run_dir, setup, params_load, net_run)


def serve(o: UpFlags, plan: UpPlan) -> None:
    """Open the simulation, say where to connect, run it until Ctrl-C or --duration, summarise."""
    cfg, run_dir, setup, params_load, net_run = (
        plan.config,
        plan.run_dir,
        plan.setup,
        plan.params_load,
        plan.net_run,
    )
    sim = open_simulation(cfg)
    pace = (
        ("lockstep" + (f" (at most {o.max_speed:g}x)" if o.max_speed else ""))
        if o.lockstep
        else f"speed {o.speed:g}x"
    )
    print_banner(
        sim, cfg, pace, run_dir, o.signing_key_file, setup, o.world, params_load, o.camera, o.speed
    )
    if sim.hil is not None and not wait_for_autopilots(sim):
        sim.close()
        raise typer.Exit(1)
    # Leaving the session closes (tlogs, truth.csv) while Ctrl-C still only sets the flag: a
    # second Ctrl-C or a SIGTERM from a wrapper during shutdown must not cut them short.
    pace_speed = None if o.lockstep else o.speed
    with RunSession(sim, run_dir, speed=pace_speed, max_speed=o.max_speed) as session:
        t_start = session.wall_start_s
        clock = session.clock
        if net_run is not None:
            attach(net_run, sim)
            console.print(node_table(net_run))
            write_net_env(net_run, run_dir / "net.env", o.speed, t_start, clock.path)
            if o.cloud_node:
                cloud_proc = role_process(
                    net_run, "cloud", 1e9, o.speed, t_start, run_dir / "cloud.log",
                    clock_file=clock.path,
                )  # fmt: skip
                session.adopt_process("cloud", cloud_proc)
                console.print(f"cloud node: process {cloud_proc.pid}, log {run_dir / 'cloud.log'}")
        console.print(
            f"simulation clock: SWARMSITL_CLOCK_FILE={clock.path} (companion.clock reads it)"
            + (
                "; lockstep: as fast as the CPU and the participants allow"
                + (f", at most {o.max_speed:g}x" if o.max_speed else "")
                if o.lockstep
                else ""
            )
        )
        console.print("Press Ctrl-C to stop.")
        shown = [t_start]

        def should_stop() -> bool:
            now = time.monotonic()
            if now - shown[0] >= 0.5:
                shown[0] = now
                if sim.fleet is None:
                    state = external_status(sim)
                else:
                    armed = sum(c.armed for c in sim.fleet.commanders)
                    flying = sum(c.in_air for c in sim.fleet.commanders)
                    state = f"{armed} armed, {flying} in the air"
                rate = sim.time_s / (now - t_start)
                status.update(f"t = {sim.time_s:8.1f} s simulated ({rate:.2f}x), {state}")
            return session.stopped

        with console.status("starting ...") as status:
            session.advance(o.duration, should_stop)
    wall = max(time.monotonic() - t_start, 1e-9)
    print_link_loads(sim)
    if sim.hil is not None:
        print_hil_stats(sim)
    if net_run is not None:
        write_net_report(
            net_run, sim.time_s, run_dir / "net_report.json", {"seed": o.seed, "speed": o.speed}
        )
    console.print(
        f"stopped at t = {sim.time_s:.1f} s simulated ({sim.time_s / wall:.2f}x real time "
        f"achieved, {'lockstep' if o.lockstep else f'{o.speed:g}x asked'}); tlogs in {run_dir}"
    )
    client_set = 0 if sim.fleet is None else sum(len(p.client_set) for p in sim.fleet.params)
    if client_set:
        console.print(
            f"{client_set} parameter(s) set by clients saved to {run_dir / CLIENT_PARAMS_FILE} "
            "(--params takes them back)",
            markup=False,
            highlight=False,
        )
