"""Our autopilot emulator as a process of its own, in PX4 SITL's place (``swarmsitl autopilot``).

It is what PX4 SITL instance i is to a simulator: it connects to the simulator's TCP port
(4560+i) and speaks PX4's simulator protocol (:mod:`autopilot_emu.simulator_link`), and it serves
MAVLink on PX4 SITL's two UDP links (onboard: listens on 14580+i, sends to 14540+i; ground
station: listens on 18570+i, sends to 14550), with system id i+1. The simulator may be swarmsitl
(``swarmsitl up --autopilot external``) or any simulator that speaks PX4's protocol.

Its clock is the simulator's: every HIL_SENSOR moves it, and the MAVLink links are served at
that time (streams fall due as simulated time passes, as in the in-memory mode). Between
HIL_SENSOR messages the links still answer clients, at the latest simulated time.
"""

from __future__ import annotations

import functools
import logging
import select
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from autopilot_emu.fleet import AutopilotFleet, FleetConfig
from autopilot_emu.mavlink.endpoint import EndpointConfig, MavlinkEndpoint
from autopilot_emu.mavlink.link_hub import LinkHub
from autopilot_emu.mavlink.streams import StreamProfile
from autopilot_emu.params import ParamStore
from autopilot_emu.simulator_link import SimulatorLink, SimulatorLinkConfig
from harness.options.params import save_client_params
from harness.sim.simulation import PortPlan, apply_airframe_params, apply_rangefinder_params
from sitl.vehicles.multirotor import load_airframe
from sitl.world import WorldConfig

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ExternalAutopilotConfig:
    """One vehicle's autopilot process: which vehicle, where the simulator is, its links."""

    instance: int = 0
    """PX4's instance number: system id instance+1, ports base+instance."""
    simulator: SimulatorLinkConfig = field(default_factory=SimulatorLinkConfig)
    frame: str = "typhoon_h480"
    """Airframe whose parameters the autopilot starts with (PX4's SYS_AUTOSTART): a
    ``sitl/vehicles`` folder name or an airframe folder path; it must match the simulator's."""
    ports: PortPlan = field(default_factory=PortPlan)
    """The MAVLink ports (onboard and ground-station links; the HIL and camera fields unused)."""
    out_dir: Path | None = None
    """Where the links' tlogs and the FTP root go; None: no tlogs, FTP off."""
    params: tuple[tuple[str, float | int], ...] = ()
    """Parameters set after the airframe's (name, value), e.g. from a QGroundControl file."""

    def __post_init__(self) -> None:
        if not 0 <= self.instance <= 254:
            raise ValueError(f"instance must be 0..254, got {self.instance}")


class ExternalAutopilot:
    """One emulated autopilot, its MAVLink links and its connection to the simulator."""

    def __init__(self, config: ExternalAutopilotConfig) -> None:
        self.config = config
        i = config.instance
        store = ParamStore()
        airframe = load_airframe(config.frame)
        skipped = apply_airframe_params(store, airframe)
        if skipped:
            log.warning("airframe parameters unknown to the autopilot: %s", sorted(skipped))
        apply_rangefinder_params(store, airframe)
        for name, value in config.params:
            store.set(name, value)
        store.set("MAV_SYS_ID", i + 1)
        self.fleet = AutopilotFleet(FleetConfig(n_vehicles=1), params=[store])
        self.link = SimulatorLink(self.fleet, config.simulator)
        self.endpoints: list[MavlinkEndpoint] = []
        world_defaults = WorldConfig()
        rangefinder_hz = max((s.rate_hz for s in airframe.rangefinders), default=0.0)
        ports = config.ports
        plan = [(StreamProfile.ONBOARD, ports.listen_port(i), ports.onboard_peers(i), "")]
        if ports.gcs_port:
            plan.append((StreamProfile.NORMAL, ports.gcs_listen_port(i), ports.gcs_peers(), "-gcs"))
        out = config.out_dir
        ftp_root = None
        if out is not None:
            ftp_root = out / f"vehicle{i + 1}" / "fs"
            (ftp_root / "log").mkdir(parents=True, exist_ok=True)
        vehicle = self.fleet.vehicle(0)
        hub = LinkHub(vehicle, functools.partial(self.fleet.telemetry.lazy_snapshot, 0))
        epoch = time.time()
        try:
            for profile, listen_port, peers, suffix in plan:
                self.endpoints.append(
                    MavlinkEndpoint(
                        vehicle,
                        EndpointConfig(
                            sysid=i + 1,
                            bind_addr=ports.bind_addr,
                            listen_port=listen_port,
                            peers=peers,
                            profile=profile,
                            tlog_path=None if out is None else out / f"vehicle{i + 1}{suffix}.tlog",
                            epoch_start_s=epoch,
                            gps_rate_hz=world_defaults.gps_hz,
                            distance_sensor_rate_hz=rangefinder_hz,
                            ftp_root=ftp_root,
                        ),
                        hub=hub,
                    )
                )
        except BaseException:
            self.close()
            raise

    def run(self, should_stop: Callable[[], bool], connect_timeout_s: float | None = None) -> str:
        """Connect to the simulator and fly until it disconnects or ``should_stop()``.

        Returns:
            Why it ended: ``"stopped"``, ``"simulator closed"`` or ``"no simulator"``.
        """
        if not self.link.connect(should_stop, connect_timeout_s):
            return "no simulator"
        poller = select.poll()
        link_fd = self.link.fileno()
        poller.register(link_fd, select.POLLIN)
        eps = [(ep, ep.fileno()) for ep in self.endpoints]
        for _, fd in eps:
            poller.register(fd, select.POLLIN)
        link = self.link
        while not should_stop():
            ready = {fd for fd, _ in poller.poll(100)}
            ticked = False
            if link_fd in ready:
                ticked = link.receive()
                if link.closed_by_peer:
                    log.info("the simulator closed the connection at t = %.3f s", link.time_s)
                    return "simulator closed"
            for ep, fd in eps:
                if ticked or fd in ready:
                    ep.poll(link.time_s, fd in ready)
        return "stopped"

    def close(self) -> None:
        """Close the links (flushing tlogs), the simulator connection, and save what clients set.

        With an out_dir, ``client_params.params`` gets the parameters MAVLink clients set (as
        ``swarmsitl up`` writes it; ``--params`` of the next run takes it back).
        """
        for ep in self.endpoints:
            try:
                ep.close()
            except OSError as exc:
                log.warning("closing endpoint failed: %s", exc)
        self.link.close()
        if self.config.out_dir is not None:
            save_client_params(self.config.out_dir, self.fleet.params, self.config.instance + 1)
