"""The ``swarmsitl`` command line: start emulated vehicles, or fly the demo."""

from __future__ import annotations

import dataclasses
import importlib.metadata
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape
from rich.table import Table

from autopilot_emu.mavlink.streams import STREAMABLE, StreamProfile
from autopilot_emu.mavlink.transport import SERIAL_BAUD
from harness.autopilot_cli import (
    AUTOPILOT_HELP,
    HIL_PORT_HELP,
    HIL_SERIAL_HELP,
    autopilot,
    check_hil_serial,
    external_status,
    print_external_table,
    print_hil_stats,
    wait_for_autopilots,
)
from harness.client_links import parse_udp_out
from harness.endpoint_table import VehicleEndpoints, endpoint_table
from harness.kernels import forbid_compiles_if_requested
from harness.launch import StopFlag, console, open_simulation, run_dir_of
from harness.link_models import NO_LINK, check_link_model, describe, links_config
from harness.lockstep import LOCKSTEP, ClockAcks, fleet_gate, run_gated
from harness.net_cli import cloud, net_demo
from harness.net_plan import NetPlan, NetRun, parse_roles
from harness.net_roles import attach, node_table, role_process, stop_processes
from harness.net_roles import write_report as write_net_report
from harness.param_options import CLIENT_PARAMS_FILE, PARAMS_HELP
from harness.params_cli import load_params_or_exit, params_app, print_params_load
from harness.replay_cli import replay
from harness.run_cli import GrpcPort, ListenPort, Out, PayloadPort, SdkPort, Seed, Speed, run
from harness.scenarios import scenario_path
from harness.signing_options import (
    SIGNING_KEY_HELP,
    SIGNING_PASSPHRASE_HELP,
    signing_key,
    unauthenticated_warning,
)
from harness.sim_clock import ClockFile
from harness.sim_options import parse_frames, world_options
from harness.simulation import EXTERNAL, INTERNAL, PortPlan, Simulation, SimulationConfig
from harness.sweep_cli import sweep
from harness.wind_options import (
    GUSTS_HELP,
    TURBULENCE_HELP,
    WIND_HELP,
    parse_gusts,
    parse_turbulence,
    parse_wind,
    wind_config,
)
from harness.world_setup import WorldSetup, world_config
from sitl.hil_server import HIL_PORT_BASE
from sitl.sensors.camera import MOUNT_PITCH_DEG, RENDER_S_PER_PIXEL, CameraSpec, with_mount
from sitl.sensors.gps import GpsOutages, GpsOutageWindow
from sitl.vehicles.multirotor import load_airframe

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


def print_world(
    setup: WorldSetup, path: Path | None, cfg: SimulationConfig, sim: Simulation
) -> None:
    """Tell what the world brought: scene, launch area, wind, and the bridges to start."""
    scene = setup.scene
    wind = cfg.wind
    wind_text = (
        "calm"
        if wind is None
        else f"{wind.speed_m_s:g} m/s from {wind.from_deg:.0f} deg, turbulence W20 "
        f"{wind.turbulence_w20_m_s:.1f} m/s, gusts {wind.gust_peak_m_s:g} m/s"
    )
    console.print(
        f"world {path} ({scene.kind}, seed {scene.seed}): {len(scene.solids)} solids, "
        f"{len(scene.targets)} targets; launch area {setup.launch_area}; wind {wind_text}",
        markup=False,
        highlight=False,
    )
    if setup.bridge:
        ports = cfg.ports
        console.print(
            "GPS-denied world: no GNSS fix; each vehicle flies on motion capture through its "
            f"bridge (EKF2_EV_CTRL {setup.params.get('EKF2_EV_CTRL', 0):g}):",
            markup=False,
        )
        for i in range(cfg.n_vehicles):
            listen = f"{ports.peer_addr}:{cfg.mocap_port + i}"
            onboard = ports.listen_port(i)
            console.print(
                f"  python -m companion.scripts.mocap_bridge --vehicle {i} --listen {listen} "
                f"--mavlink udpout:{ports.bind_addr}:{onboard}",
                markup=False,
                highlight=False,
                soft_wrap=True,
            )


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


def print_link_loads(sim: Simulation) -> None:
    """One line per modelled MAVLink link: frames, drops by reason, load."""
    elapsed = max(sim.time_s, 1e-9)
    for (i, path), shaper in sorted(sim.shapers.items()):
        stats = shaper.stats
        parts = []
        for label, d in (("to vehicle", stats.to_vehicle), ("from vehicle", stats.from_vehicle)):
            drops = ", ".join(f"{k} {v}" for k, v in sorted(d.dropped.items())) or "none"
            parts.append(
                f"{label}: {d.frames} frames, {d.bytes / elapsed:.0f} B/s, "
                f"load {100 * d.airtime_s / elapsed:.0f} %, dropped {drops}"
            )
        console.print(f"{path} link of vehicle {i + 1} ({stats.kind}): " + "; ".join(parts))


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


@app.command()
def up(
    vehicles: Annotated[int, typer.Option("--vehicles", "-n", min=1, max=255)] = 1,
    speed: Annotated[float, typer.Option(help="simulation seconds per wall second")] = 1.0,
    lockstep: Annotated[
        bool,
        typer.Option(
            "--lockstep",
            help="run as fast as the CPU allows instead of --speed; companions read the "
            "simulation time from RUN/clock (SWARMSITL_CLOCK_FILE, companion.clock)",
        ),
    ] = False,
    max_speed: Annotated[
        float,
        typer.Option(
            "--max-speed",
            min=0.0,
            help="with --lockstep: never more simulated seconds per wall second than this "
            "(0: no cap); e.g. to keep a ground station's wall-clock timeouts meaningful",
        ),
    ] = 0.0,
    bind: Annotated[
        str,
        typer.Option(
            help="address the vehicles listen on; anything but loopback exposes them to the "
            "network, so add --signing-key (e.g. --bind 0.0.0.0 --signing-key key.hex)"
        ),
    ] = "127.0.0.1",
    signing_key_file: Annotated[
        Path | None,
        typer.Option("--signing-key", metavar="FILE", dir_okay=False, help=SIGNING_KEY_HELP),
    ] = None,
    signing_passphrase: Annotated[
        str | None,
        typer.Option(metavar="TEXT", help=SIGNING_PASSPHRASE_HELP),
    ] = None,
    sdk_port: Annotated[
        int, typer.Option(help="onboard link: MAVSDK port of vehicle 0 (+i)")
    ] = 14540,
    listen_port: Annotated[
        int, typer.Option(help="onboard link: listen port of vehicle 0 (+i)")
    ] = 14580,
    gcs_port: Annotated[
        int, typer.Option(help="GCS link: ground-station port of all vehicles, 0 = no GCS link")
    ] = 14550,
    gcs_listen_port: Annotated[
        int, typer.Option(help="GCS link: listen port of vehicle 0 (+i)")
    ] = 18570,
    spacing: Annotated[float, typer.Option(help="metres between vehicles")] = 5.0,
    seed: Annotated[int, typer.Option(help="seed of every random draw")] = 0,
    frame: Annotated[
        str,
        typer.Option(
            help="airframe of every vehicle, or one per vehicle separated by commas (e.g. "
            "typhoon_h480,x500); a name from sitl/vehicles or the path of an airframe folder"
        ),
    ] = "typhoon_h480",
    out: Annotated[Path | None, typer.Option(help="run directory [default: runs/<time>]")] = None,
    duration: Annotated[float, typer.Option(help="stop after this many sim seconds")] = 0.0,
    stream_rate: Annotated[
        list[str] | None,
        typer.Option(
            help="override a stream's rate: NAME=HZ on the onboard link, gcs:NAME=HZ on the "
            "GCS link, 0 = off (repeatable; e.g. ATTITUDE=20)"
        ),
    ] = None,
    wind: Annotated[str | None, typer.Option(help=WIND_HELP)] = None,
    turbulence: Annotated[str | None, typer.Option(help=TURBULENCE_HELP)] = None,
    gusts: Annotated[str | None, typer.Option(help=GUSTS_HELP)] = None,
    mocap: Annotated[
        float,
        typer.Option(
            metavar="HZ",
            help="publish motion-capture poses of every vehicle at HZ as UDP datagrams "
            "(docs/indoor_positioning.md); 0 = off",
        ),
    ] = 0.0,
    mocap_port: Annotated[
        int, typer.Option(help="mocap datagrams of vehicle 0 go to this UDP port (+i)")
    ] = 15400,
    gps_outage: Annotated[
        list[str] | None,
        typer.Option(
            metavar="START:END[:SYSID]",
            help="no GPS fix between these simulated seconds, for every vehicle or one "
            "(repeatable; e.g. 30:40 or 30:40:2)",
        ),
    ] = None,
    rangefinders: Annotated[
        bool,
        typer.Option(
            "--rangefinders/--no-rangefinders",
            help="fly the airframes' ultrasonic rangefinders (DISTANCE_SENSOR on both links, "
            "terrain estimate; docs/sensors.md); --no-rangefinders switches them off",
        ),
    ] = True,
    camera: Annotated[
        bool,
        typer.Option(
            "--camera/--no-camera",
            help="render the cameras of the airframes that have one and stream them as MJPEG "
            "over HTTP (--no-camera: no rendering, no streams)",
        ),
    ] = True,
    camera_mount: Annotated[
        str | None,
        typer.Option(
            metavar="down|forward",
            help="point every camera down (pitch -90, outdoor) or forward (pitch 0, indoor) "
            "[default: the airframe's]",
        ),
    ] = None,
    camera_size: Annotated[
        str | None,
        typer.Option(metavar="WxH", help="camera resolution, e.g. 640x480 [default: airframe's]"),
    ] = None,
    camera_hz: Annotated[
        float | None,
        typer.Option(help="camera frame rate, Hz; divides the physics rate [default: airframe's]"),
    ] = None,
    camera_fov: Annotated[
        float | None,
        typer.Option(help="camera horizontal field of view, degrees [default: airframe's]"),
    ] = None,
    video_port: Annotated[
        int, typer.Option(help="TCP port of vehicle 0's camera stream (+i); 0: the OS picks")
    ] = 5600,
    payload_port: Annotated[
        int,
        typer.Option(
            help="UDP port of vehicle 0's MAVLink camera (compid 100, +i; PX4 SITL's 14030), "
            "where its payload link sends; 0: no MAVLink camera"
        ),
    ] = 14030,
    payload_listen_port: Annotated[
        int,
        typer.Option(
            help="UDP port vehicle 0's payload link (its camera's) listens on (+i; PX4 SITL's "
            "14280); 0: the OS picks"
        ),
    ] = 14280,
    link: Annotated[
        str,
        typer.Option(
            metavar="none|uart|sik|wifi|wired|lte|PRESET",
            help="link model of the companion <-> autopilot (onboard) path: frames are delayed, "
            "throttled and dropped as over it (e.g. --link uart: 921600 baud, 92160 B/s); "
            "none: plain UDP (docs/links.md)",
        ),
    ] = NO_LINK,
    gcs_link: Annotated[
        str,
        typer.Option(
            metavar="none|sik|uart|wifi|wired|lte|PRESET",
            help="link model of the ground-station path (e.g. --gcs-link sik: a 57600-baud "
            "telemetry radio); none: plain UDP",
        ),
    ] = NO_LINK,
    links: Annotated[
        Path | None,
        typer.Option(
            exists=True,
            dir_okay=False,
            help="your link file (presets and link classes merged over the shipped ones; "
            "docs/links.md)",
        ),
    ] = None,
    net: Annotated[
        str | None,
        typer.Option(
            metavar="ROLES",
            help="node messaging: each vehicle's companion is a node of this role (edge,fog,... "
            "one per vehicle, or one for all); datagrams between nodes cross the link models "
            "(docs/messaging.md); writes net.yaml for your companion programs",
        ),
    ] = None,
    cloud_node: Annotated[
        bool,
        typer.Option("--cloud/--no-cloud", help="with --net: start the cloud node (a process)"),
    ] = True,
    net_port: Annotated[
        int, typer.Option(help="with --net: UDP port of the first node (the cloud; +k)")
    ] = 47000,
    net_proxy_port: Annotated[
        int, typer.Option(help="with --net: the router's port standing for the first node (+k)")
    ] = 47500,
    world: Annotated[
        Path | None,
        typer.Option(
            metavar="FILE",
            help="fly in a world file (docs/worlds.md): its solids, spills, people, wind; "
            "vehicles start in its launch area; GPS-denied worlds fly on motion capture "
            "(e.g. --world my_world.yaml, or --world example:offshore for a shipped one)",
        ),
    ] = None,
    serial: Annotated[
        bool,
        typer.Option(
            "--serial",
            help="give each vehicle a serial port as PX4's TELEM2 to a companion (onboard "
            "profile, 921600 baud, always behind the uart link model: 92160 B/s): a pty behind "
            "RUN/vehicleN.serial, e.g. MAVSDK serial://RUN/vehicle1.serial:921600 "
            "(docs/links.md)",
        ),
    ] = False,
    udp_out: Annotated[
        list[str] | None,
        typer.Option(
            metavar="HOST:PORT[+i]",
            help="one more MAVLink link per vehicle (PX4 normal profile, forwarding on) sending "
            "to HOST:PORT, the same port for every vehicle as 14550 (HOST:PORT+i: vehicle i to "
            "PORT+i); repeatable, e.g. --udp-out 127.0.0.1:14600 (docs/links.md)",
        ),
    ] = None,
    launch_area: Annotated[
        str | None,
        typer.Option(
            metavar="NAME",
            help="with --world: the launch area to start from, e.g. helideck [default: the "
            "world's: helideck, land_base, safe_point, start, agent_start_<i>]",
        ),
    ] = None,
    params: Annotated[
        list[str] | None, typer.Option(metavar="[SYSID=|all=]FILE", help=PARAMS_HELP)
    ] = None,
    autopilot: Annotated[str, typer.Option(help=AUTOPILOT_HELP)] = INTERNAL,
    hil_port: Annotated[int, typer.Option(min=0, max=65535, help=HIL_PORT_HELP)] = HIL_PORT_BASE,
    hil_serial: Annotated[
        list[str] | None, typer.Option(metavar="DEVICE[:BAUD]", help=HIL_SERIAL_HELP)
    ] = None,
) -> None:
    """Start N emulated PX4 multirotors and serve MAVLink until Ctrl-C.

    Vehicle i (0-based) is MAVLink system i+1 with PX4 SITL's two links: the onboard link
    (PX4's onboard stream profile: ATTITUDE 100 Hz, positions 30-50 Hz, ...) listens on UDP
    listen_port+i and streams to sdk_port+i (MAVSDK: udpin://0.0.0.0:14540+i); the
    ground-station link (normal profile) listens on gcs_listen_port+i and streams to gcs_port
    (QGroundControl, MAVProxy: udpin:0.0.0.0:14550). Each link writes a .tlog to the run
    directory (vehicleN.tlog, vehicleN-gcs.tlog). A vehicle with a camera is also a MAVLink
    camera (component 100) on a third, payload link (payload_listen_port+i <-> payload_port+i);
    the links forward its traffic, so MAVSDK's camera plugin finds it.

    Example:  swarmsitl up --vehicles 3 --speed 2

    Example:  swarmsitl up --vehicles 20 --stream-rate ATTITUDE=20 --stream-rate HIGHRES_IMU=0

    Example:  swarmsitl up --vehicles 3 --frame typhoon_h480,x500,x500

    Example:  swarmsitl up --wind 5@270 --turbulence light --gusts 3,length=30,every=20

    Example:  swarmsitl up --vehicles 2 --mocap 50   (poses to UDP 15400, 15401)

    Example:  swarmsitl up --gps-outage 60:70   (no GPS fix from 60 s to 70 s simulated)

    Example:  swarmsitl up --vehicles 10 --no-rangefinders   (no DISTANCE_SENSOR, no ray casts)
    Example:  swarmsitl up --camera-mount forward --camera-size 640x480 --camera-hz 5
    (OpenCV reads vehicle 1's camera: cv2.VideoCapture("http://127.0.0.1:5600/video.mjpg"))

    Example:  swarmsitl up --link uart --gcs-link sik   (MAVLink as over TELEM2 and a radio)

    Example:  swarmsitl up --serial --out runs/s   (companion: MAVSDK
    serial://runs/s/vehicle1.serial:921600, pymavlink mavlink_connection(path, baud=921600))

    Example:  swarmsitl up --udp-out 127.0.0.1:14600   (a third client per vehicle, e.g.
    pymavlink udpin:0.0.0.0:14600, beside MAVSDK on 14540 and a GCS on 14550)

    Example:  swarmsitl up -n 3 --net edge,edge,fog   (then, per companion:
    SWARMSITL_NET=<run>/net.yaml SWARMSITL_NODE=edge1 python my_companion.py)

    Example:  swarmsitl up -n 3 --world src/worlds/examples/offshore.yaml --launch-area helideck
    (three vehicles on the rig's helideck in the world's sea wind; --wind etc. override it)

    Example:  swarmsitl up -n 2 --lockstep --out runs/ci   (as fast as possible; companions:
    SWARMSITL_CLOCK_FILE=runs/ci/clock python my_companion.py, waits via companion.clock)

    Example:  swarmsitl up --lockstep --max-speed 4   (lockstep, never above 4x: MAVSDK's and
    a ground station's wall-clock timeouts stay within a known number of simulated seconds)

    Example:  swarmsitl up -n 3 --params all=examples/params/tuning.params   (a QGroundControl
    file, every vehicle; what clients set goes to RUN/client_params.params, which --params
    takes back)

    Example:  swarmsitl up --bind 0.0.0.0 --signing-key key.hex   (MAVLink 2 signing on every
    link; key.hex from: openssl rand -hex 32 > key.hex)

    Example:  swarmsitl up -n 2 --autopilot external   (the simulator waits on TCP 4560, 4561
    for PX4 SITL or: swarmsitl autopilot --instance 0 / --instance 1; docs/px4.md)
    """
    if autopilot not in (INTERNAL, EXTERNAL):
        raise typer.BadParameter(
            f"{autopilot!r}: expected {INTERNAL} or {EXTERNAL}", param_hint="--autopilot"
        )
    check_hil_serial(hil_serial or [], vehicles, autopilot, speed, lockstep)
    if max_speed and not lockstep:
        raise typer.BadParameter(
            "caps a --lockstep run; a paced run keeps --speed", param_hint="--max-speed"
        )
    if autopilot == EXTERNAL:
        ignored = [
            name
            for name, given in (
                ("--link", link != NO_LINK),
                ("--gcs-link", gcs_link != NO_LINK),
                ("--signing-key", bool(signing_key_file or signing_passphrase)),
                ("--params", bool(params)),
                ("--stream-rate", bool(stream_rate)),
                ("--serial", serial),
                ("--udp-out", bool(udp_out)),
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
        key = signing_key(signing_key_file, signing_passphrase)
    except ValueError as exc:
        console.print(f"[red]error:[/red] {escape(str(exc))}")
        raise typer.Exit(2) from exc
    exposed = unauthenticated_warning(bind, key)
    if exposed is not None:
        console.print(f"[yellow]warning:[/yellow] {escape(exposed)}")
    frames = parse_frames(frame, vehicles)
    try:
        udp_outs = tuple(parse_udp_out(spec) for spec in udp_out or [])
    except ValueError as exc:
        raise typer.BadParameter(str(exc), param_hint="--udp-out") from exc
    link = parse_link_model(link, "--link", links)
    gcs_link = parse_link_model(gcs_link, "--gcs-link", links)
    roles = None
    if net is not None:
        try:
            roles = parse_roles(net, vehicles)
        except ValueError as exc:
            raise typer.BadParameter(str(exc), param_hint="--net") from exc
    physics_hz = SimulationConfig().physics_hz
    if camera_mount is not None and camera_mount not in MOUNT_PITCH_DEG:
        raise typer.BadParameter(
            f"{camera_mount!r}: expected one of {', '.join(MOUNT_PITCH_DEG)}",
            param_hint="--camera-mount",
        )
    per_vehicle = frames * vehicles if len(frames) == 1 else frames
    camera_spec = (
        camera_override(per_vehicle, camera_mount, camera_size, camera_hz, camera_fov, physics_hz)
        if camera
        else None
    )
    if mocap < 0 or (mocap > 0 and abs(physics_hz / mocap - round(physics_hz / mocap)) > 1e-9):
        raise typer.BadParameter(
            f"--mocap {mocap:g}: must be 0 or divide the {physics_hz:g} Hz physics rate"
        )
    setup = world_options(world, launch_area, vehicles, spacing)
    params_load = load_params_or_exit(params, vehicles)
    run_dir = run_dir_of(out)
    net_run = None
    if roles is not None:
        try:
            plan = NetPlan(
                roles, cloud=cloud_node, node_base=net_port, proxy_base=net_proxy_port,
                links_file=links,
            )  # fmt: skip
            net_run = NetRun(plan, seed, run_dir)
        except (OSError, ValueError) as exc:
            console.print(f"[red]error:[/red] {exc}")
            raise typer.Exit(2) from exc
    ports = PortPlan(
        bind_addr=bind,
        sdk_base=sdk_port,
        listen_base=listen_port,
        gcs_port=gcs_port,
        gcs_listen_base=gcs_listen_port,
        video_base=video_port,
        payload_listen_base=payload_listen_port,
        payload_base=payload_port,
        hil_base=hil_port,
    )
    wind_given = wind is not None or turbulence is not None or gusts is not None
    cfg = SimulationConfig(
        n_vehicles=vehicles,
        seed=seed,
        frames=frames,
        spacing_m=spacing,
        ports=ports,
        out_dir=run_dir,
        stream_rates_hz=parse_stream_rates(stream_rate or []),
        wind=wind_config(parse_wind(wind), parse_turbulence(turbulence), parse_gusts(gusts))
        if wind_given or setup is None
        else setup.wind,
        params=setup.params if setup is not None else {},
        vehicle_params=params_load.vehicle_params if params_load is not None else (),
        world=world_config(
            vehicles,
            setup,
            rangefinders=rangefinders,
            cameras=camera,
            camera=camera_spec,
            mocap_hz=mocap if mocap > 0 else None,
            gps_outages=GpsOutages(windows=parse_gps_outages(gps_outage)) if gps_outage else None,
        ),
        mocap_port=mocap_port,
        onboard_link=link,
        gcs_link=gcs_link,
        links_file=links,
        router=net_run.router if net_run is not None else None,
        signing_key=key,
        autopilot=autopilot,
        hil_serial=tuple(hil_serial or ()),
        serial=serial,
        udp_outs=udp_outs,
        ping_period_s=LOCKSTEP.ping_period_s if lockstep else 0.0,
    )
    sim = open_simulation(cfg)
    pace = (
        ("lockstep" + (f" (at most {max_speed:g}x)" if max_speed else ""))
        if lockstep
        else f"speed {speed:g}x"
    )
    if sim.hil is not None:
        print_external_table(sim, run_dir, pace)
    else:
        title = f"swarmsitl: {vehicles} vehicle(s), {pace}, run dir {run_dir}"
        modelled = link != NO_LINK or (gcs_link != NO_LINK and ports.gcs_port)
        rows = []
        for i in range(vehicles):
            lat, lon, alt = sim.world.home_geodetic(i)
            gcs = (
                f"{bind}:{ports.gcs_listen_port(i)} -> {ports.peer_addr}:{ports.gcs_port}"
                if ports.gcs_port
                else "off"
            )
            models = (
                f"{describe(link, links_config(links))} / "
                f"{describe(gcs_link, links_config(links)) if ports.gcs_port else '-'}"
            )
            rows.append(
                VehicleEndpoints(
                    sysid=i + 1,
                    airframe=sim.world.airframes[i].name,
                    onboard=f"{bind}:{ports.listen_port(i)} -> "
                    f"{ports.peer_addr}:{ports.sdk_port(i)}",
                    mavsdk=f"udpin://0.0.0.0:{ports.sdk_port(i)}",
                    gcs=gcs,
                    home=f"{lat:.6f}, {lon:.6f}, {alt:.1f}",
                    models=models if modelled else None,
                    serial=f"RUN/{Path(str(sim.serial_ports[i])).name}" if serial else None,
                    udp_out=", ".join(d.describe(i) for d in udp_outs) if udp_outs else None,
                )
            )
        console.print(endpoint_table(console, title, rows))  # fits the terminal, URLs whole
    if key is not None:
        console.print(
            "MAVLink 2 signing: every link signs its frames and accepts only frames signed with "
            f"the key of {escape(str(signing_key_file)) if signing_key_file else 'the passphrase'}"
            " (unsigned RADIO_STATUS, ADSB_VEHICLE, COLLISION excepted, as PX4); clients must "
            "sign with it (pymavlink: setup_signing; MAVSDK cannot sign, its commands are dropped)"
        )
    if sim.mocap is not None:
        console.print(
            f"motion capture: {sim.world.config.mocap_hz:g} Hz, vehicle i's poses to udp "
            f"{ports.peer_addr}:{mocap_port}+i (bridge: python -m companion.scripts.mocap_bridge)"
        )
    for i, path in enumerate(sim.serial_ports):
        if path is not None:
            console.print(
                f"serial port of vehicle {i + 1}: serial://{path}:{SERIAL_BAUD} (pymavlink: "
                f"mavlink_connection({str(path)!r}, baud={SERIAL_BAUD}))",
                soft_wrap=True,
            )
    for k, dest in enumerate(udp_outs, start=1):
        where = f"{dest.host}:{dest.port}" + ("+i" if dest.per_vehicle else " (every vehicle)")
        console.print(
            f"UDP output {k}: vehicle i's extra link (normal profile) sends to {where}; "
            f"tlogs vehicleN-udp{k}.tlog",
            soft_wrap=True,
        )
    if setup is not None:
        print_world(setup, world, cfg, sim)
    print_params_load(params_load)
    for i, (uri, spec) in enumerate(zip(sim.video_uris, sim.world.camera_specs, strict=True)):
        if uri is not None and spec is not None:
            console.print(
                f"camera of vehicle {i + 1}: {uri}  ({spec.width_px}x{spec.height_px}, "
                f"{spec.rate_hz:g} Hz, hfov {spec.hfov_deg:g} deg, pitch {spec.pitch_deg:g} deg)"
            )
    for i, manager in enumerate(sim.camera_managers):
        if manager is not None:
            console.print(
                f"MAVLink camera of vehicle {i + 1}: system {i + 1} component 100, "
                f"udp {manager.local_address[0]}:{manager.local_address[1]} <-> payload link "
                f"{bind}:{ports.payload_listen_port(i)} (forwarded to the links above)"
            )
    if camera and not any(sim.video_uris):
        console.print("cameras: none of these airframes has one (no streams)")
    render_load = (
        speed
        * RENDER_S_PER_PIXEL
        * sum(s.rate_hz * s.width_px * s.height_px for s in sim.world.camera_specs if s is not None)
    )
    if render_load > 0.5:
        console.print(
            f"[yellow]note:[/yellow] rendering the cameras takes about {render_load:.1f} CPU "
            f"seconds per wall second at --speed {speed:g}; lighten it with --camera-hz, "
            "--camera-size, or --no-camera"
        )
    if sim.hil is not None and not wait_for_autopilots(sim):
        sim.close()
        raise typer.Exit(1)
    t_start = time.monotonic()
    clock = ClockFile(run_dir / "clock")
    # Before any companion can start: companion.clock takes part only if the folder exists.
    acks = ClockAcks(clock.path) if lockstep else None
    procs: dict[str, subprocess.Popen] = {}
    if net_run is not None:
        attach(net_run, sim)
        console.print(node_table(net_run))
        env = f"SWARMSITL_SPEED={speed:g} SWARMSITL_CLOCK_ORIGIN={t_start!r}"
        (run_dir / "net.env").write_text(
            f"# source this, then set SWARMSITL_NODE (one of: "
            f"{', '.join(n.node_id for n in net_run.nodes)})\n"
            f"export SWARMSITL_SPEED={speed:g}\nexport SWARMSITL_CLOCK_ORIGIN={t_start!r}\n"
            f"export SWARMSITL_CLOCK_FILE={clock.path}\n"
            f"export SWARMSITL_NET={net_run.net_path}\n"
            f"export SWARMSITL_NET_RECORDS={net_run.records_dir}\n"
        )
        console.print(
            f"companion programs: {env} SWARMSITL_NET={net_run.net_path} SWARMSITL_NODE=<node> "
            f"python your_program.py   (records: SWARMSITL_NET_RECORDS={net_run.records_dir})"
        )
        if cloud_node:
            procs["cloud"] = role_process(
                net_run, "cloud", 1e9, speed, t_start, run_dir / "cloud.log",
                clock_file=clock.path,
            )  # fmt: skip
            console.print(f"cloud node: process {procs['cloud'].pid}, log {run_dir / 'cloud.log'}")
    console.print(
        f"simulation clock: SWARMSITL_CLOCK_FILE={clock.path} (companion.clock reads it)"
        + (
            "; lockstep: as fast as the CPU and the participants allow"
            + (f", at most {max_speed:g}x" if max_speed else "")
            if lockstep
            else ""
        )
    )
    console.print("Press Ctrl-C to stop.")
    flag = StopFlag()
    old = {s: signal.signal(s, flag) for s in (signal.SIGINT, signal.SIGTERM)}
    shown = [t_start]

    def should_stop() -> bool:
        clock.publish(sim.time_s)
        now = time.monotonic()
        if now - shown[0] >= 0.5:
            shown[0] = now
            if sim.fleet is None:
                state = external_status(sim)
            else:
                armed = sum(c.armed for c in sim.fleet.commanders)
                flying = sum(c.in_air for c in sim.fleet.commanders)
                state = f"{armed} armed, {flying} in the air"
            status.update(
                f"t = {sim.time_s:8.1f} s simulated ({sim.time_s / (now - t_start):.2f}x), {state}"
            )
        return flag.stop

    try:
        with console.status("starting ...") as status:
            if lockstep:
                gate = fleet_gate(sim, acks, max_speed)
                run_gated(sim, gate, duration if duration > 0 else float("inf"), should_stop)
            else:
                sim.run_paced(
                    speed,
                    should_stop,
                    duration if duration > 0 else float("inf"),
                    wall_origin_s=t_start,
                )
    finally:
        # Close (tlogs, truth.csv) while Ctrl-C still only sets the flag: a second Ctrl-C or
        # a SIGTERM from a wrapper during shutdown must not cut the recordings short.
        stop_processes(procs)
        sim.close()
        clock.close()
        if acks is not None:
            acks.close()
        for s, h in old.items():
            signal.signal(s, h)
    wall = max(time.monotonic() - t_start, 1e-9)
    print_link_loads(sim)
    if sim.hil is not None:
        print_hil_stats(sim)
    if net_run is not None:
        write_net_report(
            net_run, sim.time_s, run_dir / "net_report.json", {"seed": seed, "speed": speed}
        )
    console.print(
        f"stopped at t = {sim.time_s:.1f} s simulated ({sim.time_s / wall:.2f}x real time "
        f"achieved, {'lockstep' if lockstep else f'{speed:g}x asked'}); tlogs in {run_dir}"
    )
    client_set = 0 if sim.fleet is None else sum(len(p.client_set) for p in sim.fleet.params)
    if client_set:
        console.print(
            f"{client_set} parameter(s) set by clients saved to {run_dir / CLIENT_PARAMS_FILE} "
            "(--params takes them back)",
            markup=False,
            highlight=False,
        )


@app.command()
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


@app.command("first-flight")
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
    from harness.report import demo_metrics, plot_trajectory, write_report

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
    env = os.environ | {"SWARMSITL_SPEED": str(speed)}
    console.print(f"[bold]swarmsitl first-flight[/bold]: speed {speed:g}x, run dir {run_dir}")
    log = (run_dir / "client.log").open("w")
    proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=env)
    t0 = time.monotonic()
    flag = StopFlag()
    old = {s: signal.signal(s, flag) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        with console.status("flying: takeoff, hover, goto 50 m north, RTL, land ..."):
            sim.run_paced(
                speed,
                lambda: proc.poll() is not None or flag.stop or time.monotonic() - t0 > timeout,
            )
    finally:
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(10)
            except subprocess.TimeoutExpired:
                proc.kill()
        log.close()
        sim.close()  # before the handlers are restored: see `up`
        for s, h in old.items():
            signal.signal(s, h)
    import json

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


app.command("run")(run)
app.command("cloud")(cloud)
app.command("replay")(replay)
app.command("autopilot")(autopilot)
app.command("net-demo")(net_demo)
app.command("sweep")(sweep)
app.add_typer(params_app, name="params")


def main() -> None:
    """Console-script entry point."""
    app()


if __name__ == "__main__":
    main()
