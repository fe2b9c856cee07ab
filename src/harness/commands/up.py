"""``swarmsitl up``: N emulated PX4 multirotors serving MAVLink until Ctrl-C (docs/cli.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from harness.commands.autopilot import (
    AUTOPILOT_HELP,
    HIL_PORT_HELP,
    HIL_SERIAL_HELP,
)
from harness.commands.up_run import UpFlags, plan_up, serve
from harness.options.params import PARAMS_HELP
from harness.options.signing import (
    SIGNING_KEY_HELP,
    SIGNING_PASSPHRASE_HELP,
)
from harness.options.wind import (
    GUSTS_HELP,
    TURBULENCE_HELP,
    WIND_HELP,
)
from harness.sim.link_models import NO_LINK
from harness.sim.simulation import INTERNAL
from sitl.hil_server import HIL_PORT_BASE


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
    flags = UpFlags(**locals())
    serve(flags, plan_up(flags))
