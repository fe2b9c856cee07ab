"""MAVLink behind a link model and the node router inside the simulation (lockstep, real UDP).

``onboard_link="uart"`` puts the companion path behind the 921600-baud UART model: a command's
ACK comes back no sooner than its bytes took to cross twice, the vehicle's telemetry never
exceeds the UART's 92160 B/s, and the world's random draws are untouched. The node router runs
on the simulation clock: a datagram is held for its modelled delay in simulated seconds.
"""

from __future__ import annotations

import socket

import numpy as np
import pytest
from mavlink_listener import MavlinkListener
from pymavlink.dialects.v20 import common as mavlink2
from typer.testing import CliRunner

from autopilot_emu.mavlink.streams import StreamProfile
from harness.cli import app
from harness.sim.link_models import (
    datarate_bytes_s,
    link_models,
    links_config,
    mavlink_shaper,
)
from harness.sim.simulation import PortPlan, Simulation, SimulationConfig
from sitl.devices.link_router import LinkRouter, RouterNode

pytestmark = pytest.mark.sockets

UART_BYTES_PER_S = 921_600 / 10


def config(peer_port: int, **changes) -> SimulationConfig:
    ports = PortPlan(sdk_base=peer_port, listen_base=0, gcs_port=0, payload_base=0, video_base=0)
    return SimulationConfig(ports=ports, record_hz=0, mocap_port=0, **changes)


def test_unknown_link_models_are_refused_naming_the_field(tmp_path):
    """onboard_link / gcs_link must be ``none`` or a preset of the link file; errors name it."""
    with pytest.raises(ValueError, match="onboard_link"):
        SimulationConfig(onboard_link="carrier-pigeon")
    with pytest.raises(ValueError, match="gcs_link"):
        SimulationConfig(gcs_link="UART ")
    assert {"none", "uart", "sik", "wifi", "wired", "lte"} <= set(link_models())
    for name in link_models():
        SimulationConfig(onboard_link=name, gcs_link=name)
    assert mavlink_shaper("none", 0, 0, 0) is None
    # A user's link file adds presets the options then accept.
    links = tmp_path / "links.yaml"
    links.write_text("presets:\n  slow-uart:\n    kind: uart\n    rate_bps: 115200\n"
                     "    bits_per_byte: 10\n    overhead_bytes: 0\n    in_order: true\n"
                     "    queue_bytes: 4096\n    max_datagram_bytes: 2048\n")  # fmt: skip
    SimulationConfig(onboard_link="slow-uart", links=links_config(links))
    with pytest.raises(ValueError, match="onboard_link"):
        SimulationConfig(onboard_link="slow-uart")
    assert datarate_bytes_s("slow-uart", links_config(links)) == pytest.approx(115200 / 20)


def test_each_vehicle_path_and_direction_draws_from_its_own_generator():
    """Same (seed, vehicle, path): the same drops; another vehicle, path or seed: others."""

    def draws(seed: int, vehicle: int, path: int) -> tuple[list, list]:
        """Which of 2000 datagrams each direction delivers."""
        shaper = mavlink_shaper("sik", seed, vehicle, path)
        for k in range(2000):
            shaper.inbound(k * 0.01, k.to_bytes(4, "big"), ("127.0.0.1", 1))
            shaper.outbound(k * 0.01, k.to_bytes(4, "big"))
        inbound = [int.from_bytes(d, "big") for d, _ in shaper.due_inbound(1e9)]
        outbound = [int.from_bytes(d, "big") for d in shaper.due_outbound(1e9)]
        return inbound, outbound

    first = draws(3, 1, 0)
    assert len(first[0]) < 2000  # the SiK preset loses some
    assert first == draws(3, 1, 0)
    for other in (draws(4, 1, 0), draws(3, 2, 0), draws(3, 1, 1)):
        assert other[0] != first[0] and other[1] != first[1]
    assert first[0] != first[1]  # the two directions differ too


def test_a_command_over_the_uart_is_acked_after_two_crossings_within_the_budget():
    """COMMAND_LONG -> ACK through the UART model, no sooner than two crossings take."""
    peer = MavlinkListener()
    try:
        with Simulation(config(peer.port, onboard_link="uart")) as sim:
            sim.run_lockstep(1.0)
            peer.drain()
            endpoint = sim.endpoints[0]
            shaper = sim.shapers[(0, "onboard")]
            assert endpoint.shaper is shaper
            request = mavlink2.MAVLink_command_long_message(
                1, 1, mavlink2.MAV_CMD_REQUEST_MESSAGE, 0,
                mavlink2.MAVLINK_MSG_ID_AUTOPILOT_VERSION, 0, 0, 0, 0, 0, 0,
            )  # fmt: skip
            frame = bytes(request.pack(peer.mav))
            peer.sock.sendto(frame, endpoint.local_address)
            sent_s = sim.time_s
            ack_s = None
            while ack_s is None and sim.time_s < sent_s + 1.0:
                sim.run_lockstep(0.002)
                for m in peer.drain():
                    if m.get_type() == "COMMAND_ACK" and ack_s is None:
                        ack_s = sim.time_s
            stats = shaper.stats
    finally:
        peer.close()
    assert ack_s is not None, "no COMMAND_ACK through the UART model"
    ack_bytes = 10 + 3 + 12  # MAVLink 2 header + COMMAND_ACK payload (trimmed) + CRC, at least
    assert ack_s - sent_s >= (len(frame) + ack_bytes) * 10 / 921_600
    assert stats.to_vehicle.delivered >= 1
    assert stats.from_vehicle.frames > 100
    assert stats.from_vehicle.dropped == {}


FAST = {
    name: 250.0
    for name in ("ATTITUDE", "ATTITUDE_QUATERNION", "HIGHRES_IMU", "LOCAL_POSITION_NED",
                 "GLOBAL_POSITION_INT", "ODOMETRY", "VFR_HUD")
}  # fmt: skip
"""Streams at the poll rate: about 1.4 times what a 921600-baud UART carries."""


def test_telemetry_beyond_the_uart_budget_is_throttled_to_it_and_dropped():
    """Offered > 1.2 x 92160 B/s, the peer receives 92160 B/s (+-3 %); the excess is dropped.

    (Without PX4's data-rate limit: ``link_datarate_bytes_s=0`` lets the streams overflow.)
    """
    peer = MavlinkListener()
    try:
        cfg = config(
            peer.port,
            onboard_link="uart",
            link_datarate_bytes_s=0.0,
            stream_rates_hz={StreamProfile.ONBOARD: FAST},
        )
        with Simulation(cfg) as sim:
            sim.run_lockstep(0.5)
            peer.drain()
            before, t0 = peer.bytes, sim.time_s
            while sim.time_s < t0 + 2.0:
                sim.run_lockstep(0.02)
                peer.drain()
            rate = (peer.bytes - before) / (sim.time_s - t0)
            stats = sim.shapers[(0, "onboard")].stats.from_vehicle
    finally:
        peer.close()
    offered = stats.bytes / sim.time_s
    assert offered > 1.2 * UART_BYTES_PER_S, offered
    assert rate == pytest.approx(UART_BYTES_PER_S, rel=0.03)
    assert stats.dropped.get("queue", 0) > 0


def test_streams_are_scaled_to_the_data_rate_as_px4_does():
    """Behind a serial preset the streams fit PX4's default data rate (baud / 20): the same
    fast streams that overflow the UART above arrive at <= 46080 B/s, with no queue drops."""
    peer = MavlinkListener()
    try:
        cfg = config(peer.port, onboard_link="uart", stream_rates_hz={StreamProfile.ONBOARD: FAST})
        with Simulation(cfg) as sim:
            sim.run_lockstep(2.0)  # the rate multiplier settles on the measured frame sizes
            peer.drain()
            before, t0 = peer.bytes, sim.time_s
            while sim.time_s < t0 + 3.0:
                sim.run_lockstep(0.02)
                peer.drain()
            rate = (peer.bytes - before) / (sim.time_s - t0)
            endpoint = sim.endpoints[0]
            stats = sim.shapers[(0, "onboard")].stats.from_vehicle
    finally:
        peer.close()
    limit = UART_BYTES_PER_S / 2
    assert endpoint.rate_mult < 0.5
    assert 0.7 * limit < rate <= 1.05 * limit
    assert stats.dropped.get("queue", 0) == 0


def test_the_link_model_leaves_the_world_untouched():
    """With or without the UART model, the flight's ground truth is bit-identical."""
    truths = []
    for link in ("none", "uart"):
        peer = MavlinkListener()
        try:
            with Simulation(config(peer.port, onboard_link=link, seed=5)) as sim:
                sim.run_lockstep(0.5)
                truths.append(sim.world.truth.position_enu_m.copy())
        finally:
            peer.close()
    assert np.array_equal(truths[0], truths[1])


class FixedDelay:
    """A link network stand-in: every datagram arrives 0.1 simulated seconds later."""

    def submit(self, now_s: float, src: str, dst: str, size: int):
        return now_s + 0.1, None


def test_the_router_holds_datagrams_for_their_simulated_delay():
    """A datagram sent at t is delivered at the first link poll at or after t + 0.1 s."""
    socks = {}
    for name in ("edge1", "fog1"):
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.bind(("127.0.0.1", 0))
        s.setblocking(False)
        socks[name] = s
    nodes = [RouterNode(n, n[:-1], s.getsockname(), 0) for n, s in socks.items()]
    positions = []
    try:
        cfg = SimulationConfig(
            mavlink=False,
            record_hz=0,
            mocap_port=0,
            router=lambda: LinkRouter(FixedDelay().submit, nodes),
        )
        with Simulation(cfg) as sim:
            sim.on_positions(lambda now_s, p: positions.append((now_s, p.shape)))
            router = sim.router
            edge_route = router.proxy_address("edge1")
            sim.run_lockstep(0.2)
            socks["edge1"].sendto(b"hello fog", router.proxy_address("fog1"))
            sim.run_lockstep(0.004)
            sent_s = sim.time_s
            assert router.in_flight == 1
            got_s = None
            while got_s is None and sim.time_s < sent_s + 1.0:
                sim.run_lockstep(0.004)
                try:
                    data, source = socks["fog1"].recvfrom(100)
                except BlockingIOError:
                    continue
                got_s = sim.time_s
    finally:
        for s in socks.values():
            s.close()
    assert (data, source) == (b"hello fog", edge_route)
    assert 0.1 - 0.004 <= got_s - sent_s <= 0.1 + 0.008
    assert positions and positions[0][1] == (1, 3)


@pytest.mark.parametrize("option", ["--link", "--gcs-link"])
def test_an_unknown_link_model_on_the_command_line_is_refused_naming_the_option(option):
    """``--link pigeon`` exits with a usage error naming the option and the known models."""
    result = CliRunner().invoke(app, ["up", option, "pigeon", "--duration", "1"])
    assert result.exit_code == 2
    assert option in result.output
    assert "uart" in result.output
