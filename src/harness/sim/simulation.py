"""The simulation loop: PyBullet world + emulated autopilots + MAVLink endpoints, in lockstep.

One physics step at a time: the world advances with the last HIL_ACTUATOR_CONTROLS, then any
HIL_SENSOR / HIL_GPS / BATTERY_STATUS messages that became due go to the autopilots, whose replies
drive the next step. The MAVLink endpoints are polled on the simulation clock. Two ways to run it:

* lockstep (``speed=None``): as fast as the CPU allows, deterministic for a given seed;
* paced (``speed=k``): simulation time = wall time x k, for companion processes.
"""

from __future__ import annotations

import contextlib
import errno
import functools
import heapq
import itertools
import logging
import math
import select
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from autopilot_emu.fleet import AutopilotFleet, FleetConfig
from autopilot_emu.mavlink.endpoint import EndpointConfig, MavlinkEndpoint
from autopilot_emu.mavlink.link_hub import LinkHub
from autopilot_emu.mavlink.streams import STREAMABLE, StreamProfile
from autopilot_emu.params import ParamStore
from harness.options.params import save_client_params
from harness.sim.autopilot_side import AutopilotSide, FleetSide, HilSide, Readings
from harness.sim.client_links import client_links
from harness.sim.config import (
    EXTERNAL,
    INTERNAL,
    PortPlan,
    SimulationConfig,
    apply_airframe_params,
    apply_rangefinder_params,
    check_params,
)
from harness.sim.link_models import (
    GCS,
    NO_LINK,
    ONBOARD,
    datarate_bytes_s,
    mavlink_shaper,
)
from harness.sim.mocap_publisher import MocapPublisher
from harness.sim.recorder import FlightRecorder
from sitl.devices.camera_manager import CameraManager, CameraProtocol, JpegStore
from sitl.devices.link_router import LinkRouter
from sitl.devices.mjpeg_server import MjpegServer
from sitl.hil_server import HilServer, HilServerConfig
from sitl.links.shaper import MavlinkLinkShaper
from sitl.sensors.camera import CameraFrame, CameraSpec
from sitl.world import World

__all__ = [
    "EXTERNAL",
    "INTERNAL",
    "PortPlan",
    "Simulation",
    "SimulationConfig",
    "apply_airframe_params",
    "apply_rangefinder_params",
    "check_params",
]
"""``SimulationConfig`` and its parts live in ``harness.sim.config``; importing them
from here works as it always did."""

log = logging.getLogger(__name__)

_PAYLOAD = "-payload"
POSITION_HOOK_HZ = 10.0
"""Rate of the ``Simulation.on_positions`` hooks, Hz of simulation time."""
PAYLOAD_STREAM_RATES_HZ: dict[str, float] = {
    **dict.fromkeys(STREAMABLE, 0.0),
    "HEARTBEAT": 1.0,
}
"""Streams of the payload link: HEARTBEAT only. PX4 runs it in the onboard mode at 4000 B/s,
which scales its streams down to a trickle; the camera here geotags from the rendered frame's
pose and needs no telemetry, and commands for it arrive by forwarding."""
EVENT_SLACK_S = 1e-9
"""An event due this close after a step's time runs at that step (a time read from a file)."""


def _close_logging_errors(link: MavlinkEndpoint) -> None:
    """Close a link; a failure is logged, not raised (the others must close too)."""
    try:
        link.close()
    except OSError as exc:
        log.warning("closing endpoint failed: %s", exc)


class Simulation:
    """World, autopilots and endpoints of one run."""

    def __init__(self, config: SimulationConfig) -> None:
        self.config = config
        n = config.n_vehicles
        self._resources = contextlib.ExitStack()
        """What :meth:`close` releases, the last opened first (a failed construction too)."""
        self._closed = False
        self.world = World(config.world_config())
        self._resources.callback(self.world.close)
        self._resources.callback(self._save_recordings)  # after every link is closed
        self.airframe_params_skipped: set[str] = set()
        """Parameters of the airframes' ``px4`` sections this autopilot does not know (skipped)."""
        self.fleet: AutopilotFleet | None = None
        """The in-process autopilots (None with an external autopilot)."""
        self.hil: HilServer | None = None
        """The simulator's TCP side of PX4's simulator protocol (external autopilot only)."""
        self.epoch_start_s = time.time()
        self.endpoints: list[MavlinkEndpoint] = []
        self.vehicle_links: list[list[MavlinkEndpoint]] = [[] for _ in range(n)]
        """Vehicle i's onboard link, then its ground-station link (if any)."""
        self.shapers: dict[tuple[int, str], MavlinkLinkShaper] = {}
        """The modelled MAVLink links by (vehicle index, ``onboard``, ``gcs`` or ``serial``)."""
        self.serial_ports: list[str | None] = [None] * n
        """What a client opens for each vehicle's serial port (None: no ``serial``)."""
        self.router: LinkRouter | None = None
        self._position_hooks: list[Callable[[float, np.ndarray], None]] = []
        self._frame_hooks: list[Callable[[list[CameraFrame]], None]] = []
        self._next_positions_s = 0.0
        self._events: list[tuple[float, int, Callable[[float], None]]] = []
        """Actions due at a simulated time (:meth:`at`): a heap of (due s, order, action)."""
        self._event_order = itertools.count()
        self._next_event_s = math.inf
        self._payload_links: list[MavlinkEndpoint | None] = [None] * n
        """Every MAVLink link: vehicle 0's onboard link, its GCS link (if any), vehicle 1's ..."""
        self.ftp_roots: list[Path] = []
        """Directory each vehicle serves over MAVLink FTP: ``<out_dir>/vehicle<N>/fs``, or a
        temporary directory removed on close when there is no out_dir."""
        self._scratch: tempfile.TemporaryDirectory | None = None
        self.mocap: MocapPublisher | None = None
        """Sends motion-capture datagrams when the world has mocap_hz > 0 and mocap_port."""
        self.video_servers: list[MjpegServer | None] = []
        """Each vehicle's camera stream server (None: no camera, or cameras off)."""
        self.camera_managers: list[CameraManager | None] = [None] * n
        """Each vehicle's MAVLink camera (compid 100) on its payload link; None: no camera, no
        MAVLink or no payload link."""
        self.recorder: FlightRecorder | None = None
        try:
            self._open()
        except BaseException:
            self._resources.close()
            raise

    def _open(self) -> None:
        """Open the autopilots and every link, each registered with ``_resources`` as opened."""
        config, n, resources = self.config, self.config.n_vehicles, self._resources
        if config.autopilot == EXTERNAL:
            self._external_init()
            resources.callback(self.hil.close)
        else:
            self._internal_init()
        if config.out_dir is not None:
            config.out_dir.mkdir(parents=True, exist_ok=True)
        if config.mavlink and self.fleet is not None:
            for i in range(n):
                for link in self._links(i):
                    self.endpoints.append(link)
                    resources.callback(_close_logging_errors, link)
        if config.mocap_port and self.world.config.mocap_hz > 0:
            self.mocap = MocapPublisher(config.ports.peer_addr, config.mocap_port, n)
            resources.callback(self.mocap.close)
        for i, spec in enumerate(self.world.camera_specs):
            server = None if spec is None else self._video_server(i)
            self.video_servers.append(server)
            if server is not None:
                resources.callback(server.close)
        for i, spec in enumerate(self.world.camera_specs):
            if spec is not None and self._payload_links[i] is not None:
                camera = self.camera_managers[i] = self._camera_manager(i, spec)
                resources.callback(camera.close)
        router = config.router
        self.router = router if router is None or isinstance(router, LinkRouter) else router()
        if self.router is not None:
            resources.callback(self.router.close)
        self._readiness = select.poll()
        self._link_fds = [(ep, ep.fileno()) for ep in self.endpoints]
        self._camera_fds = [(c, c.fileno()) for c in self.camera_managers if c is not None]
        for _, fd in (*self._link_fds, *self._camera_fds):
            self._readiness.register(fd, select.POLLIN)
        self._poll_every = round(config.physics_hz / config.mavlink_poll_hz)
        self._step_count = 0
        self._actuators: list | None = None
        if config.record_hz > 0:
            truth_csv = None if config.out_dir is None else config.out_dir / "truth.csv"
            self.recorder = FlightRecorder(self, config.record_hz, truth_csv)
        self._side: AutopilotSide = (
            HilSide(self.hil) if self.hil is not None else FleetSide(self.fleet)
        )
        """Where each step's readings go (:meth:`step`, stages 3 and 5)."""
        self._truth = lambda: self.world.truth
        """The world's ground truth for a side that sends it (built once, not every step)."""
        self.phase_seconds: dict[str, float] | None = None
        """Wall seconds per stage of ``step`` once ``time_phases()`` was called."""
        self._readings = Readings(None, None, None, None)
        """What the measure stage read on this step (the deliver stage hands it on)."""
        self._mocap_sample: Any = None
        self._frames: list[CameraFrame] | None = None
        self._stages = tuple(stage for _, stage in self._stage_methods())
        """What :meth:`step` runs, in order (timed wrappers after ``time_phases()``)."""

    def _internal_init(self) -> None:
        """One emulated autopilot per vehicle, with the airframes' and the config's parameters."""
        config, n = self.config, self.config.n_vehicles
        stores = [ParamStore() for _ in range(n)]
        for i, (store, spec) in enumerate(zip(stores, self.world.airframes, strict=True)):
            self.airframe_params_skipped |= apply_airframe_params(store, spec)
            if self.world.config.rangefinders:
                apply_rangefinder_params(store, spec)
            for name, value in config.params.items():
                store.set(name, value)
            for name, value in (config.vehicle_params[i] if config.vehicle_params else {}).items():
                store.set(name, value)
        if self.airframe_params_skipped:
            log.warning(
                "airframe parameters unknown to the autopilot, not set: %s",
                ", ".join(sorted(self.airframe_params_skipped)),
            )
        self.fleet = AutopilotFleet(FleetConfig(n_vehicles=n), params=stores)
        for i, p in enumerate(self.fleet.params):
            p.set("MAV_SYS_ID", i + 1)

    def _external_init(self) -> None:
        """Listen for the external autopilots on TCP (PX4's simulator protocol)."""
        config = self.config
        if config.params or config.vehicle_params:
            log.warning(
                "external autopilot: parameters are the autopilot's own, not applied here: %s",
                ", ".join(sorted({*config.params, *(k for p in config.vehicle_params for k in p)})),
            )
        ports = config.ports
        self.hil = HilServer(
            HilServerConfig(
                n_vehicles=config.n_vehicles,
                bind_addr=ports.bind_addr,
                port_base=ports.hil_base,
                serial=config.hil_serial,
                relay_addr=ports.peer_addr,
                relay_gcs_port=ports.gcs_port,
                relay_sdk_base=ports.sdk_base,
            ),
            lambda: self.world.time_s,
        )

    def _links(self, i: int) -> list[MavlinkEndpoint]:
        """Vehicle i's MAVLink links, as PX4 SITL: onboard first, then the ground station's."""
        ports = self.config.ports
        out = self.config.out_dir
        vehicle = self.fleet.vehicle(i)
        hub = LinkHub(vehicle, functools.partial(self.fleet.telemetry.lazy_snapshot, i))
        ftp_root = self._ftp_root(i)
        plan = [(StreamProfile.ONBOARD, ports.listen_port(i), ports.onboard_peers(i), "")]
        models = {"": (ONBOARD, self.config.onboard_link), "-gcs": (GCS, self.config.gcs_link)}
        if ports.gcs_port:
            plan.append((StreamProfile.NORMAL, ports.gcs_listen_port(i), ports.gcs_peers(), "-gcs"))
        if ports.payload_base and self.world.camera_specs[i] is not None:
            plan.append(self._payload_plan(i))
        links: list[MavlinkEndpoint] = []
        try:
            for profile, listen_port, peers, suffix in plan:
                payload = suffix == _PAYLOAD
                path, model = models.get(suffix, (None, NO_LINK))
                link_config = self.config.links
                shaper = (
                    mavlink_shaper(model, self.config.seed, i, path, link_config)
                    if path is not None
                    else None
                )
                if shaper is not None:
                    self.shapers[(i, "onboard" if path == ONBOARD else "gcs")] = shaper
                config = EndpointConfig(
                    sysid=i + 1,
                    compid=1,
                    bind_addr=ports.bind_addr,
                    listen_port=listen_port,
                    peers=peers,
                    profile=profile,
                    tlog_path=(
                        (out / f"vehicle{i + 1}{suffix}.tlog")
                        if out is not None and not payload
                        else None
                    ),
                    epoch_start_s=self.epoch_start_s,
                    gps_rate_hz=self.world.config.gps_hz,
                    distance_sensor_rate_hz=self._rangefinder_rate_hz(i),
                    ftp_root=ftp_root,
                    stream_rates_hz=(
                        PAYLOAD_STREAM_RATES_HZ
                        if payload
                        else self.config.stream_rates_hz.get(profile, {})
                    ),
                    shaper=shaper,
                    datarate_bytes_s=(
                        datarate_bytes_s(model, link_config)
                        if self.config.link_datarate_bytes_s is None
                        else self.config.link_datarate_bytes_s
                    )
                    if model != NO_LINK
                    else 0.0,
                    signing_key=self.config.signing_key,
                    ping_period_s=0.0 if payload else self.config.ping_period_s,
                )
                links.append(MavlinkEndpoint(vehicle, config, hub=hub))
                if not payload:
                    self.vehicle_links[i].append(links[-1])
                if payload:
                    self._payload_links[i] = links[-1]
            if self.config.serial or self.config.udp_outs:
                links.extend(client_links(self, i, hub, ftp_root, self._rangefinder_rate_hz(i)))
        except BaseException:
            for link in links:
                link.close()
            raise
        return links

    def _rangefinder_rate_hz(self, i: int) -> float:
        """Rate of vehicle i's fastest range finder, Hz (0: none, or switched off)."""
        if not self.world.config.rangefinders:
            return 0.0
        return max((s.rate_hz for s in self.world.airframes[i].rangefinders), default=0.0)

    def _payload_plan(self, i: int) -> tuple[StreamProfile, int, tuple[tuple[str, int], ...], str]:
        """Vehicle i's onboard payload link, its camera's: few streams, forwarding on.

        PX4 SITL: ``mavlink start -x -u 14280+i -r 4000 -f -m onboard -o 14030+i``. PX4 starts
        it whether a camera is there or not; here only vehicles with a camera have it (nothing
        else would use it, and a run without cameras binds no extra ports).
        """
        ports = self.config.ports
        peers = ((ports.bind_addr, ports.payload_port(i)),)
        return (StreamProfile.ONBOARD, ports.payload_listen_port(i), peers, _PAYLOAD)

    def _camera_manager(self, i: int, spec: CameraSpec) -> CameraManager:
        """Vehicle i's camera as MAVLink component 100 on its payload link."""
        base = self.config.out_dir
        if base is None:
            base = self._scratch_dir()
        protocol = CameraProtocol(
            spec,
            sysid=i + 1,
            origin=self.world.origin,
            epoch_start_s=self.epoch_start_s,
            store=JpegStore(base / f"vehicle{i + 1}" / "camera"),
            stream_uri=self.video_uris[i],
        )
        ports = self.config.ports
        link = self._payload_links[i]
        return CameraManager(
            protocol,
            ports.bind_addr,
            ports.payload_port(i),
            link.local_address[1],
            signing_key=self.config.signing_key,
        )

    def _video_server(self, i: int) -> MjpegServer:
        """Vehicle i's MJPEG stream on TCP ports.video_port(i)."""
        ports = self.config.ports
        try:
            return MjpegServer(ports.bind_addr, ports.video_port(i))
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                raise OSError(
                    errno.EADDRINUSE,
                    f"TCP {ports.bind_addr}:{ports.video_port(i)} (camera stream of vehicle "
                    f"{i + 1}) is already in use; choose another video port base",
                ) from exc
            raise

    @property
    def video_uris(self) -> list[str | None]:
        """Each vehicle's camera stream URL (cv2.VideoCapture opens it), None without a camera."""
        return [None if s is None else s.uri for s in self.video_servers]

    def on_frames(self, hook: Callable[[list[CameraFrame]], None]) -> None:
        """Call ``hook(frames)`` with the camera frames of every step that rendered some.

        For observers of a run (the scenario runner saves sample images); nothing it does is fed
        back into the flight.
        """
        self._frame_hooks.append(hook)

    def _on_frames(self, frames: list[CameraFrame]) -> None:
        """Hand the frames taken this step to their vehicles' stream servers and the hooks."""
        for hook in self._frame_hooks:
            hook(frames)
        servers = self.video_servers
        for frame in frames:
            server = servers[frame.vehicle]
            if server is not None:
                server.publish(frame)
            camera = self.camera_managers[frame.vehicle]
            if camera is not None:
                camera.on_frame(frame)

    def _scratch_dir(self) -> Path:
        """A temporary directory for what a run without ``out_dir`` keeps, removed on close."""
        if self._scratch is None:
            self._scratch = tempfile.TemporaryDirectory(prefix="swarmsitl-fs-")
            self._resources.callback(self._scratch.cleanup)
        return Path(self._scratch.name)

    def _ftp_root(self, i: int) -> Path:
        """Create vehicle i's FTP root with an empty ``log/`` (PX4 SITL's rootfs has one)."""
        base = self.config.out_dir
        if base is None:
            base = self._scratch_dir()
        root = base / f"vehicle{i + 1}" / "fs"
        (root / "log").mkdir(parents=True, exist_ok=True)
        self.ftp_roots.append(root)
        return root

    @property
    def time_s(self) -> float:
        """Simulation time, s."""
        return self.world.time_s

    def step(self) -> None:
        """Advance one physics step and run everything that became due.

        The stages, in order (the same with the autopilots in memory or across TCP):

        1. physics: the world steps under the last actuator commands;
        2. events: the actions due by the new time run (:meth:`at`);
        3. measure: the world's sensors, motion capture, cameras, battery and rangefinders
           (polled in this order: their random draws depend on it);
        4. deliver: the readings go to the autopilots (:class:`AutopilotSide`);
        5. observe: motion capture is published, camera frames go to their servers and hooks
           (an external autopilot computes meanwhile);
        6. actuate: the autopilots' commands for the next step;
        7. links: the MAVLink links are polled every ``_poll_every`` steps;
        8. record.

        Each stage is a method without arguments (what one hands the next is kept on the
        simulation); :meth:`time_phases` swaps in timed wrappers of the same methods.
        """
        for stage in self._stages:
            stage()

    def _stage_physics(self) -> None:
        self.world.step(self._actuators)

    def _stage_events(self) -> None:
        now = self.world.time_s
        if now + EVENT_SLACK_S < self._next_event_s:
            return
        events = self._events
        while events and events[0][0] <= now + EVENT_SLACK_S:
            _, _, action = heapq.heappop(events)
            action(now)
        self._next_event_s = events[0][0] if events else math.inf

    def at(self, time_s: float, action: Callable[[float], None]) -> None:
        """Call ``action(now_s)`` at the first physics step at or after ``time_s`` (simulated s).

        It runs right after that step's physics, before the step's readings reach the
        autopilots, so what it changes (an autopilot terminated or landing, a node silenced)
        shapes that step's commands; ``now_s`` is the step's time. Actions due at the same step
        run in the order of their times, then of their registration. One due already runs at
        the next step. How a scenario's ``faults:`` are injected
        (``harness.scenarios.fault_injection``).
        """
        heapq.heappush(self._events, (float(time_s), next(self._event_order), action))
        self._next_event_s = self._events[0][0]

    def _stage_measure(self) -> None:
        world = self.world
        sensors, gps = world.poll_sensors()
        self._mocap_sample = world.poll_mocap() if self.mocap is not None else None
        self._frames = world.poll_cameras()
        battery = world.poll_battery()
        ranges = world.poll_rangefinders()
        self._readings = Readings(sensors, gps, battery, ranges)

    def _stage_deliver(self) -> None:
        self._side.deliver(self._readings, self.world.time_s, self._truth)

    def _stage_observe(self) -> None:
        if self.mocap is not None:
            self.mocap.publish(self._mocap_sample)
        if self._frames is not None:
            self._on_frames(self._frames)

    def _stage_actuate(self) -> None:
        self._actuators = self._side.actuators()  # None: the world keeps every command

    def _stage_links(self) -> None:
        self._step_count += 1
        if (self.endpoints or self.router) and self._step_count % self._poll_every == 0:
            self._poll_links(self.world.time_s)

    def _stage_record(self) -> None:
        if self.recorder is not None:
            self.recorder.maybe_record()

    def _stage_methods(self) -> tuple[tuple[str, Callable[[], None]], ...]:
        """The stages of :meth:`step` by name, in order."""
        return (
            ("physics", self._stage_physics),
            ("events", self._stage_events),
            ("measure", self._stage_measure),
            ("deliver", self._stage_deliver),
            ("observe", self._stage_observe),
            ("actuate", self._stage_actuate),
            ("links", self._stage_links),
            ("record", self._stage_record),
        )

    def wait_for_autopilots(
        self, should_stop: Callable[[], bool] = lambda: False, timeout_s: float | None = None
    ) -> bool:
        """With an external autopilot: block until every vehicle's has connected (else True)."""
        return True if self.hil is None else self.hil.wait_for_autopilots(should_stop, timeout_s)

    def poll_links(self) -> None:
        """Read and answer every link at the current time without stepping.

        A paused lockstep calls it: commands are still acknowledged, PING echoes and heartbeats
        still noted.
        """
        if self.endpoints or self.router:
            self._poll_links(self.world.time_s)

    def keep_links_alive(self) -> None:
        """Send the HEARTBEATs a held clock owes its peers' wall-clock watchdogs.

        A held lockstep calls it: every emulated autopilot's link that sent no HEARTBEAT for a
        wall second sends one (``MavlinkEndpoint.keep_alive``), so no peer declares lost a
        vehicle that only waits for it.
        """
        for ep in self.endpoints:
            ep.keep_alive()

    def _poll_links(self, now_s: float) -> None:
        """Poll every MAVLink link; only those whose socket has data read it."""
        ready = {fd for fd, _ in self._readiness.poll(0)}
        for ep, fd in self._link_fds:
            if fd in ready or not ep.quiet_from_s <= now_s < ep.quiet_until_s:
                ep.poll(now_s, fd in ready)
        for camera, fd in self._camera_fds:
            camera.poll(now_s, fd in ready)
        if self.router is not None:
            if self._position_hooks and now_s >= self._next_positions_s:
                self._next_positions_s = now_s + 1.0 / POSITION_HOOK_HZ
                positions = self.world.truth.position_enu_m
                for hook in self._position_hooks:
                    hook(now_s, positions)
            self.router.poll(now_s)

    def on_positions(self, hook: Callable[[float, np.ndarray], None]) -> None:
        """Call ``hook(now_s, position_enu_m)`` before router polls, at POSITION_HOOK_HZ.

        Where a link network learns the vehicles' positions ((N, 3) ENU, m) for range and
        coverage; called only while a router runs.
        """
        self._position_hooks.append(hook)

    def time_phases(self) -> None:
        """Accumulate the wall time of each stage of :meth:`step` in ``phase_seconds``.

        The stages are wrapped, not copied: a timed step runs the same methods in the same order.
        """
        acc = self.phase_seconds = {name: 0.0 for name, _ in self._stage_methods()}
        clock = time.perf_counter

        def timed(name: str, stage: Callable[[], None]) -> Callable[[], None]:
            def run() -> None:
                t0 = clock()
                stage()
                acc[name] += clock() - t0

            return run

        self._stages = tuple(timed(name, stage) for name, stage in self._stage_methods())

    def run_lockstep(
        self, duration_s: float, until: Callable[[Simulation], bool] | None = None
    ) -> None:
        """Run as fast as possible for duration_s of simulation time (or until ``until``)."""
        end = self.world.time_s + duration_s
        check_every = max(1, round(self.config.physics_hz / 50))
        while self.world.time_s < end - 1e-9:
            self.step()
            if until is not None and self._step_count % check_every == 0 and until(self):
                return

    def run_paced(
        self,
        speed: float,
        should_stop: Callable[[], bool],
        max_duration_s: float = float("inf"),
        wall_origin_s: float | None = None,
    ) -> None:
        """Run with simulation time = wall time x speed until should_stop() or max duration.

        ``wall_origin_s``: the ``time.monotonic()`` instant the current simulation time stands
        for (default: now), so that processes told that instant (``SWARMSITL_CLOCK_ORIGIN``)
        read the same time as the simulation.
        """
        if not speed > 0:
            raise ValueError(f"speed must be > 0, got {speed}")
        t0_sim = self.world.time_s
        t0_wall = time.perf_counter()
        if wall_origin_s is not None:
            t0_wall -= time.monotonic() - wall_origin_s
        end = t0_sim + max_duration_s
        steps_per_check = max(1, round(self.config.physics_hz / 100))
        while self.world.time_s < end:
            for _ in range(steps_per_check):
                self.step()
            if should_stop():
                return
            ahead = (self.world.time_s - t0_sim) / speed - (time.perf_counter() - t0_wall)
            if ahead > 0.0005:
                time.sleep(ahead)

    def close(self) -> None:
        """Close the links (flushing tlogs), write the recordings, release PyBullet."""
        if self._closed:
            return
        self._closed = True
        self._resources.close()

    def _save_recordings(self) -> None:
        """The ground truth and the vehicles' parameters into the run directory (if any)."""
        out = self.config.out_dir
        if out is None:
            return
        if self.recorder is not None:
            self.recorder.write_csv(out / "truth.csv")
        if self.fleet is not None:
            save_client_params(out, self.fleet.params)

    def __enter__(self) -> Simulation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
