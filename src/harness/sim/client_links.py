"""A vehicle's MAVLink links beyond PX4 SITL's two: a serial port and extra UDP outputs.

On a real vehicle PX4 runs one MAVLink instance per port, all serving one vehicle:

* ``up --serial``: the companion computer's UART, as PX4 configures TELEM2 for it
  (``mavlink start -d /dev/ttyS2 -b 921600 -m onboard``, forwarding on). The simulator offers a
  pseudo-terminal (:class:`~autopilot_emu.mavlink.transport.PtyTransport`) behind the stable
  symlink ``<run>/vehicle<N>.serial``; companion code opens it as it opens ``/dev/ttyAMA0`` on a
  Pi: MAVSDK ``serial://<run>/vehicle1.serial:921600``, pymavlink
  ``mavlink_connection("<run>/vehicle1.serial", baud=921600)``. The port always runs behind the
  ``uart`` link model (a real UART cannot carry more than its baud rate: 921600 baud 8N1 =
  92160 B/s; change the preset in a ``--links`` file for another rate) with PX4's default data
  rate for a serial instance (baud / 20, MAV_x_RATE = 0), and writes ``vehicle<N>-serial.tlog``.
* ``up --udp-out HOST:PORT`` (repeatable): one more UDP instance per vehicle, as a
  ``mavlink start -u <local> -o PORT -t HOST -m normal -f`` line in a PX4 start-up script: the
  normal (ground-station) stream profile, a listen port the OS picks, forwarding on. As PX4
  SITL's ground-station link (``-o 14550`` in every instance), every vehicle sends to the same
  HOST:PORT; ``HOST:PORT+i`` sends vehicle i to PORT+i instead (one port per vehicle, as
  14540+i). Each writes ``vehicle<N>-udp<K>.tlog`` (K = 1, 2, ... in option order).

All of a vehicle's links share its :class:`~autopilot_emu.mavlink.link_hub.LinkHub`: one
vehicle state, one mission, one parameter set; traffic between clients is forwarded as PX4's
``-f`` does (:mod:`autopilot_emu.mavlink.forwarding`). With ``--signing-key`` they sign as the
vehicle's other links do.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from autopilot_emu.mavlink.endpoint import EndpointConfig, MavlinkEndpoint
from autopilot_emu.mavlink.link_hub import LinkHub
from autopilot_emu.mavlink.streams import StreamProfile
from autopilot_emu.mavlink.transport import PtyTransport
from harness.sim.link_models import SERIAL, datarate_bytes_s, mavlink_shaper

if TYPE_CHECKING:
    from harness.sim.simulation import Simulation

SERIAL_LINK_MODEL = "uart"
"""Link model of every serial port: PX4's TELEM2 at 921600 baud (``sitl/links/presets.yaml``)."""

_UDP_OUT = re.compile(r"^(?P<host>[^:\s]+):(?P<port>\d+)(?P<per_vehicle>\+i)?$")


@dataclass(frozen=True)
class UdpOut:
    """One ``--udp-out`` destination."""

    host: str
    port: int
    """Where vehicle 0 sends (and every vehicle, unless ``per_vehicle``)."""
    per_vehicle: bool = False
    """Vehicle i sends to port + i (``HOST:PORT+i``)."""

    def __post_init__(self) -> None:
        if not 1 <= self.port <= 65535:
            raise ValueError(f"--udp-out port must be 1..65535, got {self.port}")

    def port_of(self, i: int) -> int:
        """Where vehicle i's link sends."""
        return self.port + i if self.per_vehicle else self.port

    def describe(self, i: int) -> str:
        """``host:port`` vehicle i sends to."""
        return f"{self.host}:{self.port_of(i)}"


def parse_udp_out(spec: str) -> UdpOut:
    """``HOST:PORT`` or ``HOST:PORT+i`` -> :class:`UdpOut`; ValueError naming the problem."""
    match = _UDP_OUT.match(spec.strip())
    if match is None:
        raise ValueError(f"--udp-out {spec!r}: expected HOST:PORT or HOST:PORT+i")
    return UdpOut(match["host"], int(match["port"]), match["per_vehicle"] is not None)


def serial_link_path(run_dir: Path, i: int) -> Path:
    """The symlink to vehicle i's serial port in the run directory."""
    return Path(run_dir) / f"vehicle{i + 1}.serial"


def client_links(
    sim: Simulation,
    i: int,
    hub: LinkHub,
    ftp_root: Path,
    distance_sensor_rate_hz: float,
) -> list[MavlinkEndpoint]:
    """Open vehicle i's serial port (``sim.config.serial``) and UDP outputs (``udp_outs``).

    Records the serial port's path in ``sim.serial_ports[i]`` and its link model in
    ``sim.shapers[(i, "serial")]``. On failure, whatever was opened is closed.
    """
    config = sim.config
    out = config.out_dir
    link_config = config.links
    base = EndpointConfig(
        sysid=i + 1,
        compid=1,
        listen_port=0,
        peers=(),
        epoch_start_s=sim.epoch_start_s,
        gps_rate_hz=sim.world.config.gps_hz,
        distance_sensor_rate_hz=distance_sensor_rate_hz,
        ftp_root=ftp_root,
        signing_key=config.signing_key,
    )
    links: list[MavlinkEndpoint] = []
    try:
        if config.serial:
            shaper = mavlink_shaper(SERIAL_LINK_MODEL, config.seed, i, SERIAL, link_config)
            rate = config.link_datarate_bytes_s
            serial = replace(
                base,
                profile=StreamProfile.ONBOARD,
                stream_rates_hz=config.stream_rates_hz.get(StreamProfile.ONBOARD, {}),
                tlog_path=None if out is None else out / f"vehicle{i + 1}-serial.tlog",
                shaper=shaper,
                datarate_bytes_s=(
                    datarate_bytes_s(SERIAL_LINK_MODEL, link_config) if rate is None else rate
                ),
            )
            transport = PtyTransport(None if out is None else serial_link_path(out, i))
            try:
                links.append(MavlinkEndpoint(hub.vehicle, serial, hub=hub, transport=transport))
            except BaseException:
                transport.close()
                raise
            sim.serial_ports[i] = transport.path
            if shaper is not None:
                sim.shapers[(i, "serial")] = shaper
        for k, dest in enumerate(config.udp_outs, start=1):
            udp = replace(
                base,
                profile=StreamProfile.NORMAL,
                stream_rates_hz=config.stream_rates_hz.get(StreamProfile.NORMAL, {}),
                bind_addr=config.ports.bind_addr,
                peers=((dest.host, dest.port_of(i)),),
                tlog_path=None if out is None else out / f"vehicle{i + 1}-udp{k}.tlog",
            )
            links.append(MavlinkEndpoint(hub.vehicle, udp, hub=hub))
    except BaseException:
        for link in links:
            link.close()
        raise
    return links
