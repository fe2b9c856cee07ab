"""What a simulation is asked for: vehicles, airframes, world, ports, links, parameters.

:class:`SimulationConfig` (and its :class:`PortPlan`) is everything a
``harness.sim.simulation.Simulation`` is built from, checked when it is made; the parameter helpers
here are how the simulation writes an airframe's and the user's parameters into each autopilot.
``harness.sim.simulation`` re-exports these names.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from autopilot_emu.mavlink.streams import StreamProfile
from autopilot_emu.params import MAV_PARAM_TYPE_INT32, ParamError, ParamStore
from autopilot_emu.rangefinder import ROTATION_DOWNWARD
from harness.options.suggest import did_you_mean
from harness.sim.client_links import UdpOut
from harness.sim.link_models import (
    NO_LINK,
    check_link_model,
    links_config,
)
from sitl.devices.link_router import LinkRouter
from sitl.hil_server import HIL_PORT_BASE
from sitl.links.config import LinksConfig
from sitl.physics.wind import WindConfig
from sitl.vehicles.multirotor import MultirotorSpec
from sitl.world import WorldConfig

INTERNAL = "internal"
"""The autopilots run in this process; HIL messages are handed over in memory."""
EXTERNAL = "external"
"""The autopilots are other processes (PX4 SITL, HITL, ``swarmsitl autopilot``) on TCP 4560+i."""


@dataclass(frozen=True)
class PortPlan:
    """PX4 SITL's two MAVLink links of vehicle i (ROMFS init.d-posix/px4-rc.mavlink).

    * onboard link (offboard API, MAVSDK/MAVROS; PX4's onboard stream profile): listens on
      listen_base+i, sends to sdk_base+i;
    * ground-station link (QGroundControl, MAVProxy; normal profile): listens on
      gcs_listen_base+i, sends to gcs_port (the same port for every vehicle).
    * onboard payload link (vehicles with a camera): listens on payload_listen_base+i, sends to
      payload_base+i, where the vehicle's MAVLink camera (compid 100) listens; the links forward
      the camera's traffic to each other (autopilot_emu.mavlink.forwarding).

    A base of 0 lets the OS pick the listen port (for one vehicle).
    """

    bind_addr: str = "127.0.0.1"
    """Address the vehicles listen on (127.0.0.1 keeps them off the network)."""
    sdk_base: int = 14540
    """Offboard/MAVSDK port of vehicle 0 (its onboard link sends here)."""
    listen_base: int = 14580
    """Port vehicle 0's onboard link listens on."""
    gcs_port: int = 14550
    """Ground-station port every vehicle's GCS link sends to; 0: no GCS link."""
    gcs_listen_base: int = 18570
    """Port vehicle 0's GCS link listens on."""
    peer_addr: str = "127.0.0.1"
    """Where the companion / ground station run."""
    video_base: int = 5600
    """TCP port of vehicle 0's camera stream (MJPEG over HTTP, +i; PX4's Gazebo camera streams
    to 5600); 0: the OS picks."""
    payload_listen_base: int = 14280
    """Port vehicle 0's onboard payload link listens on (PX4 SITL: 14280+i; its camera talks to
    it); 0: the OS picks."""
    payload_base: int = 14030
    """Port of vehicle 0's camera, where the payload link sends (PX4 SITL: 14030+i, the Gazebo
    camera's MAVLink port); 0: no payload link and no MAVLink camera."""
    hil_base: int = HIL_PORT_BASE
    """TCP port the simulator listens on for vehicle 0's external autopilot (+i; PX4's
    simulator port 4560+i); used only with ``SimulationConfig.autopilot = "external"``; 0: the
    OS picks."""

    def __post_init__(self) -> None:
        for name in (
            "sdk_base",
            "listen_base",
            "gcs_port",
            "gcs_listen_base",
            "video_base",
            "payload_listen_base",
            "payload_base",
            "hil_base",
        ):
            if not 0 <= getattr(self, name) <= 65535:
                raise ValueError(f"{name} must be 0..65535, got {getattr(self, name)}")

    def listen_port(self, i: int) -> int:
        """UDP port vehicle i's onboard link listens on."""
        return self.listen_base + i if self.listen_base else 0

    def sdk_port(self, i: int) -> int:
        """UDP port vehicle i's onboard link sends to."""
        return self.sdk_base + i

    def gcs_listen_port(self, i: int) -> int:
        """UDP port vehicle i's ground-station link listens on."""
        return self.gcs_listen_base + i if self.gcs_listen_base else 0

    def video_port(self, i: int) -> int:
        """TCP port of vehicle i's camera stream (0: the OS picks)."""
        return self.video_base + i if self.video_base else 0

    def payload_listen_port(self, i: int) -> int:
        """UDP port vehicle i's payload link listens on (0: the OS picks)."""
        return self.payload_listen_base + i if self.payload_listen_base else 0

    def payload_port(self, i: int) -> int:
        """UDP port of vehicle i's camera (its payload link sends there); 0: no payload link."""
        return self.payload_base + i if self.payload_base else 0

    def onboard_peers(self, i: int) -> tuple[tuple[str, int], ...]:
        """Destinations of vehicle i's onboard link."""
        return ((self.peer_addr, self.sdk_port(i)),)

    def gcs_peers(self) -> tuple[tuple[str, int], ...]:
        """Destinations of every ground-station link (none without a GCS port)."""
        return ((self.peer_addr, self.gcs_port),) if self.gcs_port else ()


@dataclass(frozen=True)
class SimulationConfig:
    """What to simulate and how to connect it."""

    n_vehicles: int = 1
    seed: int = 0
    physics_hz: float = 500.0
    frames: tuple[str, ...] = ("typhoon_h480",)
    """Airframe of every vehicle (one name), or one per vehicle in vehicle order: names of
    ``sitl/vehicles`` folders or paths of airframe folders (``swarmsitl up --frame``)."""
    spacing_m: float = 5.0
    """Distance between neighbouring vehicles at spawn, m."""
    mavlink: bool = True
    """Open each vehicle's MAVLink links (onboard, and ground station if ports.gcs_port)."""
    ports: PortPlan = field(default_factory=PortPlan)
    mavlink_poll_hz: float = 250.0
    """How often endpoints read their sockets and emit streams, Hz of simulation time."""
    out_dir: Path | None = None
    """Run directory for tlogs and recordings; None writes nothing."""
    record_hz: float = 20.0
    """Rate of the ground-truth recording, Hz (0 disables)."""
    wind: WindConfig | None = None
    """Wind of the world (steady, turbulence, gusts); None: calm air."""
    world: WorldConfig | None = None
    """The world beyond the fields above: scene, obstacles, sensors switched on, spawn points,
    GNSS outages, motion capture (mocap_hz > 0 publishes poses), ... None: a plain field.
    Its ``n_vehicles``, ``seed``, ``physics_hz``, ``spacing_m``, ``airframe`` and ``wind`` are
    the same settings as this config's: each is taken from whichever of the two sets it, and
    set differently in both is a ValueError. :meth:`world_config` is the world the run builds."""
    mocap_port: int = 15400
    """UDP port vehicle 0's motion-capture poses go to (+i), on ports.peer_addr; 0: none."""
    stream_rates_hz: dict[StreamProfile, dict[str, float]] = field(default_factory=dict)
    """Overrides of the stream profiles' default rates per link kind, e.g.
    {StreamProfile.ONBOARD: {"ATTITUDE": 20.0}}; 0 Hz switches a stream off. Fewer messages
    make large swarms faster (PX4: ``mavlink stream -r``)."""
    onboard_link: str = NO_LINK
    """Link model of every companion <-> autopilot (onboard) link: a preset of the link file
    (``uart``: 921600 baud, see ``harness.sim.link_models``); ``none``: plain UDP."""
    gcs_link: str = NO_LINK
    """Link model of every ground-station link (``sik``: a 57600-baud telemetry radio)."""
    link_datarate_bytes_s: float | None = None
    """Data-rate limit of the MAVLink instances on serial link models, B/s (PX4's MAV_x_RATE):
    their streams are scaled down together to fit. None: PX4's default for MAV_x_RATE = 0,
    baud / 20 (half the line); 0: no limit (what exceeds the line queues and drops)."""
    links: LinksConfig | None = None
    """The link presets and classes (``harness.sim.link_models.links_config``: the shipped
    ``sitl/links/presets.yaml`` with a user's link file merged over; a scenario's
    ``Scenario.links_config()``); None: the shipped presets."""
    params: dict[str, float] = field(default_factory=dict)
    """Autopilot parameters set on every vehicle after its airframe's (e.g. a GPS-denied world's
    EKF2_EV_CTRL, ``harness.sim.world_setup``); an unknown name raises ValueError naming it."""
    vehicle_params: tuple[dict[str, float], ...] = ()
    """Autopilot parameters per vehicle (one dict per vehicle, in vehicle order), set after
    ``params`` (a scenario's roles: ``harness.scenarios.spec``); empty: none."""
    serial: bool = False
    """Give every vehicle a serial port too (a pty behind ``<out_dir>/vehicle<N>.serial``,
    PX4's TELEM2 to a companion; ``harness.sim.client_links``)."""
    udp_outs: tuple[UdpOut, ...] = ()
    """Extra UDP links of every vehicle (``up --udp-out``; ``harness.sim.client_links``)."""
    router: LinkRouter | Callable[[], LinkRouter] | None = None
    """The paced UDP router of node messaging, or a factory of it, polled with the MAVLink
    links on the simulation clock (the simulation closes it); None: no router."""
    autopilot: str = INTERNAL
    """``internal``: one emulated autopilot per vehicle in this process, with its MAVLink links.
    ``external``: the simulator listens on TCP ``ports.hil_base + i`` and speaks PX4's
    simulator protocol (``sitl.hil_server``) with whatever autopilot connects (PX4 SITL, a
    Pixhawk in HITL, ``swarmsitl autopilot``); that autopilot owns the MAVLink links, its
    parameters and its failsafes, so ``mavlink``, ``params`` and link models do not apply."""
    hil_serial: tuple[str, ...] = ()
    """With an external autopilot: one serial device per vehicle (``/dev/ttyACM0[:BAUD]``, a
    Pixhawk in HITL) instead of the TCP ports; the board's other MAVLink traffic is relayed to
    ``ports.gcs_port`` and ``ports.sdk_base + i`` (``sitl.hil_serial``)."""
    signing_key: bytes | None = None
    """MAVLink 2 signing key (32 bytes) of every vehicle link: each signs what it sends and
    handles only correctly signed frames (``autopilot_emu.mavlink.signing``; the MAVLink
    cameras sign too); None: no signing."""
    ping_period_s: float = 0.0
    """Simulated seconds between the PING requests every onboard and ground-station link sends
    (their echoes tell a lockstep run how far each companion has read: ``harness.run.lockstep``);
    0: none."""

    def __post_init__(self) -> None:
        if self.out_dir is not None:  # absolute: printed to users, handed to processes
            object.__setattr__(self, "out_dir", Path(self.out_dir).absolute())
        if self.world is not None:
            if not isinstance(self.world, WorldConfig):
                raise ValueError(f"world must be a WorldConfig or None, got {self.world!r}")
            for name, value in _shared_world_settings(self, self.world).items():
                object.__setattr__(self, name, value)
        if self.links is None:
            object.__setattr__(self, "links", links_config())
        links = self.links
        check_link_model(self.onboard_link, "onboard_link", links)
        check_link_model(self.gcs_link, "gcs_link", links)
        if self.n_vehicles < 1:
            raise ValueError(f"n_vehicles must be >= 1, got {self.n_vehicles}")
        if isinstance(self.frames, str) or len(self.frames) not in (1, self.n_vehicles):
            raise ValueError(
                f"frames: give one airframe for all vehicles or one per vehicle "
                f"({self.n_vehicles}), got {self.frames!r}"
            )
        if self.signing_key is not None and len(self.signing_key) != 32:
            raise ValueError(f"signing_key must have 32 bytes, got {len(self.signing_key)}")
        self.world_config()  # a world that cannot be built is this config's error
        if self.params:
            object.__setattr__(self, "params", check_params(self.params))
        if self.vehicle_params:
            if len(self.vehicle_params) != self.n_vehicles:
                raise ValueError(
                    f"vehicle_params: one dict per vehicle ({self.n_vehicles}), got "
                    f"{len(self.vehicle_params)}"
                )
            object.__setattr__(
                self, "vehicle_params", tuple(check_params(p) for p in self.vehicle_params)
            )
        if self.autopilot not in (INTERNAL, EXTERNAL):
            raise ValueError(
                f"autopilot must be {INTERNAL!r} or {EXTERNAL!r}, got {self.autopilot!r}"
            )
        if self.hil_serial and self.autopilot != EXTERNAL:
            raise ValueError("hil_serial needs autopilot='external' (a board flies the vehicle)")
        ratio = self.physics_hz / self.mavlink_poll_hz
        if abs(ratio - round(ratio)) > 1e-9 or ratio < 1:
            raise ValueError(
                f"mavlink_poll_hz ({self.mavlink_poll_hz}) must divide physics_hz "
                f"({self.physics_hz})"
            )

    def world_config(self) -> WorldConfig:
        """The world of this run: ``world`` (or the defaults) with this config's settings."""
        return replace(
            self.world if self.world is not None else _DEFAULT_WORLD,
            n_vehicles=self.n_vehicles,
            seed=self.seed,
            physics_hz=self.physics_hz,
            spacing_m=self.spacing_m,
            airframe=tuple(self.frames),
            wind=self.wind,
        )


_DEFAULT_WORLD = WorldConfig()
_SHARED = {
    "n_vehicles": "n_vehicles",
    "seed": "seed",
    "physics_hz": "physics_hz",
    "spacing_m": "spacing_m",
    "frames": "airframe",
    "wind": "wind",
}
"""SimulationConfig fields that are also WorldConfig fields (by their name there)."""
_CONFIG_DEFAULTS = {f.name: f.default for f in fields(SimulationConfig) if f.name in _SHARED}


def _shared_world_settings(config: SimulationConfig, world: WorldConfig) -> dict[str, Any]:
    """The shared settings the world sets and the config leaves at its default.

    Raises:
        ValueError: a setting both set, to different values.
    """
    out: dict[str, Any] = {}
    for ours, theirs in _SHARED.items():
        mine, default = getattr(config, ours), _CONFIG_DEFAULTS[ours]
        given, world_default = getattr(world, theirs), getattr(_DEFAULT_WORLD, theirs)
        if ours == "frames":
            given = (given,) if isinstance(given, str) else tuple(given)
            world_default = (world_default,)
        if given in (world_default, mine):
            continue
        if mine != default:
            raise ValueError(
                f"world.{theirs}={given!r} disagrees with {ours}={mine!r}: set it in one place"
            )
        out[ours] = given
    return out


def apply_airframe_params(store: ParamStore, airframe: MultirotorSpec) -> set[str]:
    """Set the parameters PX4's airframe file sets (the YAML's ``px4`` section) in ``store``.

    Returns:
        The names ``store`` does not know (left out); a known name with a bad value raises.
    """
    known = set(store.names)
    unknown = set()
    for name, value in airframe.px4_params.items():
        if name in known:
            store.set(name, value)
        else:
            unknown.add(name)
    return unknown


def check_params(params: dict[str, float]) -> dict[str, float | int]:
    """The values as the autopilot stores them; ValueError naming an unknown name or bad value.

    A whole float for an INT32 parameter (``EKF2_EV_CTRL: 9.0``, as a YAML or JSON number may
    arrive) is taken as that integer.
    """
    store = ParamStore()
    known = set(store.names)
    unknown = sorted(name for name in params if name not in known)
    if unknown:
        hint = did_you_mean(unknown[0], store.names, otherwise=f" (of {unknown})")
        raise ValueError(f"params: unknown autopilot parameter {unknown[0]!r}{hint}")
    out: dict[str, float | int] = {}
    for name, value in params.items():
        if (
            store.type_of(name) == MAV_PARAM_TYPE_INT32
            and isinstance(value, float)
            and value.is_integer()
        ):
            value = int(value)
        try:
            store.set(name, value)
        except ParamError as exc:
            raise ValueError(f"params: {name}: {exc}") from exc
        out[name] = value
    return out


def apply_rangefinder_params(store: ParamStore, airframe: MultirotorSpec) -> None:
    """EKF2_RNG_POS_X/Y/Z: where the airframe's downward range finder sits (as a PX4 user sets).

    Nothing changes for an airframe without a downward-facing (MAV_SENSOR_ROTATION 25) one.
    """
    down = [s for s in airframe.rangefinders if s.orientation == ROTATION_DOWNWARD]
    if down:
        for axis, value in zip("XYZ", down[0].position_frd_m, strict=True):
            store.set(f"EKF2_RNG_POS_{axis}", value)
