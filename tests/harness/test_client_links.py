"""Several clients per vehicle (``up --serial --udp-out``): one vehicle seen the same way by a
client on the onboard UDP link, one on an extra UDP output and one on the serial port.

In-process, lockstep: every wait is in simulated time. The clients are pymavlink parsers on real
UDP sockets and on the real pseudo-terminal (``mavutil.mavlink_connection(path, baud=921600)``).
"""

from __future__ import annotations

import math
import os

import pytest
from mission_link import free_udp_port, waypoint
from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink2
from udp_client import UdpClient

from autopilot_emu.mavlink.streams import StreamProfile
from autopilot_emu.modes import AutoSubMode, MainMode, custom_mode
from autopilot_emu.params import encode_param_value
from harness.sim.client_links import UdpOut, parse_udp_out, serial_link_path
from harness.sim.simulation import PortPlan, Simulation, SimulationConfig

pytestmark = pytest.mark.sockets

BAUD = 921600
LINE_BYTES_S = BAUD / 10  # 8N1
MAX_FRAME_BYTES = 280


class SerialClient:
    """pymavlink on the serial port, as a companion opens a Pi's UART."""

    def __init__(self, path: str, sysid: int = 191) -> None:
        self.conn = mavutil.mavlink_connection(path, baud=BAUD, source_system=sysid)
        self.mav = self.conn.mav
        self.inbox: list = []

    def send(self, msg) -> None:
        self.conn.write(msg.pack(self.mav))
        self.mav.seq = (self.mav.seq + 1) & 0xFF

    def drain(self) -> None:
        while (m := self.conn.recv_msg()) is not None:
            self.inbox.append(m)

    def close(self) -> None:
        self.conn.close()


class Bench:
    """One vehicle with an onboard UDP link, one --udp-out link and a serial port."""

    def __init__(self, tmp_path, **config: object) -> None:
        self.onboard = UdpClient(245)
        self.extra = UdpClient(250)
        self.sim = Simulation(
            SimulationConfig(
                n_vehicles=1,
                seed=5,
                record_hz=0,
                ports=PortPlan(listen_base=0, sdk_base=self.onboard.port, gcs_port=0),
                out_dir=tmp_path,
                serial=True,
                udp_outs=(UdpOut("127.0.0.1", self.extra.port),),
                **config,
            )
        )
        self.onboard.to = self.sim.endpoints[0].local_address
        self.extra.to = self.sim.endpoints[-1].local_address
        self.serial = SerialClient(self.sim.serial_ports[0])
        self.clients = (self.onboard, self.extra, self.serial)

    def close(self) -> None:
        for c in self.clients:
            c.close()
        self.sim.close()

    def run(self, seconds: float) -> None:
        end = self.sim.time_s + seconds
        steps = 0
        while self.sim.time_s < end:
            self.sim.step()
            steps += 1
            if steps % 10 == 0:
                for c in self.clients:
                    c.drain()
        for c in self.clients:
            c.drain()

    def wait(self, client, pred, timeout_s: float = 5.0):
        end = self.sim.time_s + timeout_s
        seen = 0
        while True:
            for m in client.inbox[seen:]:
                if pred(m):
                    return m
            seen = len(client.inbox)
            if self.sim.time_s > end:
                raise AssertionError(f"no matching message within {timeout_s} simulated s")
            self.run(0.02)

    def wait_type(self, client, name: str, timeout_s: float = 5.0, **fields: object):
        return self.wait(
            client,
            lambda m: m.get_type() == name and all(getattr(m, k) == v for k, v in fields.items()),
            timeout_s,
        )

    def command(self, client, command: int, *params: float, timeout_s: float = 3.0) -> int:
        p = [*params, *[math.nan] * (7 - len(params))]
        client.send(mavlink2.MAVLink_command_long_message(1, 1, command, 0, *p))
        return self.wait_type(client, "COMMAND_ACK", timeout_s, command=command).result


@pytest.fixture
def bench(tmp_path):
    b = Bench(tmp_path)
    yield b
    b.close()


def test_udp_out_parses_host_port_and_per_vehicle_ports():
    port = 14600  # port-literal: parsed only
    assert parse_udp_out(f"127.0.0.1:{port}") == UdpOut("127.0.0.1", port)
    assert parse_udp_out("gcs.local:14600+i").port_of(2) == 14602  # port-literal: parsed only
    assert parse_udp_out("10.0.0.2:14600").port_of(2) == 14600  # port-literal: parsed only
    bad = ("14600", "host:", "host:port", "host:70000", "host:14600+2")  # port-literal: refused
    for spec in bad:
        with pytest.raises(ValueError, match="--udp-out"):
            parse_udp_out(spec)


def test_pymavlink_flies_over_the_serial_port(bench, tmp_path):
    """Heartbeat, a parameter read, arm and take off, all over the pty behind the symlink."""
    link = serial_link_path(tmp_path, 0)
    assert link.is_symlink() and str(link) == bench.sim.serial_ports[0]
    serial = bench.serial
    hb = bench.wait_type(serial, "HEARTBEAT")
    assert (hb.get_srcSystem(), hb.get_srcComponent()) == (1, 1)
    serial.send(mavlink2.MAVLink_param_request_read_message(1, 1, b"MAV_SYS_ID", -1))
    assert bench.wait_type(serial, "PARAM_VALUE", param_id="MAV_SYS_ID").param_value > 0
    ready = mavlink2.MAV_SYS_STATUS_SENSOR_GPS | mavlink2.MAV_SYS_STATUS_PREARM_CHECK
    bench.wait(
        serial,
        lambda m: (
            m.get_type() == "SYS_STATUS" and m.onboard_control_sensors_health & ready == ready
        ),
        timeout_s=60,
    )
    bench.run(2.0)  # home set
    assert bench.command(serial, mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 1) == 0
    assert bench.command(serial, mavlink2.MAV_CMD_NAV_TAKEOFF) == 0
    bench.wait(
        serial,
        lambda m: m.get_type() == "GLOBAL_POSITION_INT" and m.relative_alt > 2000,
        timeout_s=20,
    )
    assert bench.sim.endpoints[1].stats.parse_errors == 0


def test_the_serial_port_never_carries_more_than_921600_baud(tmp_path):
    """Streams asked far beyond the line (no PX4 data-rate scaling, nine streams at 250 Hz):
    over every simulated second the pty carries at most 92160 B (+1 frame), and the line is
    full (the limit is the UART model, not a lack of traffic)."""
    names = "ATTITUDE ATTITUDE_QUATERNION HIGHRES_IMU ODOMETRY LOCAL_POSITION_NED ALTITUDE"
    fast = dict.fromkeys((*names.split(), "GLOBAL_POSITION_INT", "VFR_HUD"), 250.0)
    sim = Simulation(
        SimulationConfig(
            n_vehicles=1,
            seed=1,
            record_hz=0,
            ports=PortPlan(listen_base=0, sdk_base=free_udp_port(), gcs_port=0),
            serial=True,
            link_datarate_bytes_s=0.0,
            stream_rates_hz={StreamProfile.ONBOARD: fast},
        )
    )
    fd = os.open(sim.serial_ports[0], os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    try:
        arrivals: list[tuple[float, int]] = []
        while sim.time_s < 4.0:
            sim.step()
            got = len(_read_all_bytes(fd))
            if got:
                arrivals.append((sim.time_s, got))
    finally:
        os.close(fd)
        sim.close()
    times = [t for t, _ in arrivals]
    sizes = [n for _, n in arrivals]
    worst = 0
    lo = 0
    window = 0
    for hi in range(len(times)):
        window += sizes[hi]
        while times[hi] - times[lo] > 1.0 - 1e-6:  # polls less than 1 s apart (float sums)
            window -= sizes[lo]
            lo += 1
        worst = max(worst, window)
    assert worst <= LINE_BYTES_S + MAX_FRAME_BYTES
    assert worst >= 0.95 * LINE_BYTES_S


def test_every_client_sees_one_vehicle(bench):
    """A mode set from the onboard link shows in every link's HEARTBEAT; a mission uploaded
    from the extra UDP link is read back over the serial port; a parameter set over the serial
    port is announced on the two UDP links; a COMMAND_ACK goes to its sender alone; each
    client's HEARTBEAT reaches the others and a message for one client reaches that client
    alone (PX4's forwarding)."""
    onboard, extra, serial = bench.clients
    beat = mavlink2.MAVLink_heartbeat_message(mavlink2.MAV_TYPE_ONBOARD_CONTROLLER, 8, 0, 0, 4, 3)
    for client in bench.clients:
        bench.wait_type(client, "HEARTBEAT")
        client.send(beat)
    bench.run(0.5)
    for client in bench.clients:
        client.send(beat)  # now that every link heard someone, broadcasts cross
    bench.run(0.5)
    senders = [
        {m.get_srcSystem() for m in c.inbox if m.get_type() == "HEARTBEAT"} for c in bench.clients
    ]
    assert senders == [{1, 250, 191}, {1, 245, 191}, {1, 245, 250}]
    # a companion's message for the client on the extra link reaches it, and only it
    serial.send(mavlink2.MAVLink_command_long_message(250, 190, 31010, 0, 1, 2, 3, 4, 5, 6, 7))
    got = bench.wait_type(extra, "COMMAND_LONG", command=31010)
    assert (got.get_srcSystem(), got.target_system) == (191, 250)
    assert not [m for m in onboard.inbox if m.get_type() == "COMMAND_LONG"]

    loiter = custom_mode(MainMode.AUTO, AutoSubMode.LOITER)
    assert (
        bench.command(onboard, mavlink2.MAV_CMD_DO_SET_MODE, 1, MainMode.AUTO, AutoSubMode.LOITER)
        == 0
    )
    for client in (extra, serial):
        bench.wait(
            client,
            lambda m: (
                m.get_type() == "HEARTBEAT" and m.get_srcSystem() == 1 and m.custom_mode == loiter
            ),
        )
    assert not [m for c in (extra, serial) for m in c.inbox if m.get_type() == "COMMAND_ACK"]

    items = [waypoint(10, 0, 5), waypoint(10, 10, 5)]
    extra.send(mavlink2.MAVLink_mission_count_message(1, 1, len(items), 0))
    while True:
        m = bench.wait(extra, lambda m: m.get_type() in ("MISSION_REQUEST_INT", "MISSION_ACK"))
        extra.inbox.remove(m)
        if m.get_type() == "MISSION_ACK":
            assert m.type == mavlink2.MAV_MISSION_ACCEPTED
            break
        item = items[m.seq]
        item.seq = m.seq
        extra.send(item)
    serial.send(mavlink2.MAVLink_mission_request_list_message(1, 1, 0))
    assert bench.wait_type(serial, "MISSION_COUNT").count == 2
    serial.send(mavlink2.MAVLink_mission_request_int_message(1, 1, 1, 0))
    second = bench.wait_type(serial, "MISSION_ITEM_INT", seq=1)
    assert (second.x, second.y) == (items[1].x, items[1].y)

    raw = encode_param_value(7.25, mavlink2.MAV_PARAM_TYPE_REAL32)
    serial.send(
        mavlink2.MAVLink_param_set_message(
            1, 1, b"MPC_XY_VEL_MAX", raw, mavlink2.MAV_PARAM_TYPE_REAL32
        )
    )
    for client in bench.clients:
        value = bench.wait_type(client, "PARAM_VALUE", param_id="MPC_XY_VEL_MAX")
        assert value.param_value == 7.25
    assert bench.sim.fleet.params[0].get("MPC_XY_VEL_MAX") == 7.25


def test_with_a_signing_key_the_serial_port_and_udp_outputs_sign(tmp_path):
    """``--signing-key`` covers the extra links too: every frame on them is signed."""
    client = UdpClient(250)
    sim = Simulation(
        SimulationConfig(
            n_vehicles=1,
            seed=2,
            record_hz=0,
            ports=PortPlan(listen_base=0, sdk_base=free_udp_port(), gcs_port=0),
            serial=True,
            udp_outs=(UdpOut("127.0.0.1", client.port),),
            signing_key=bytes(range(32)),
        )
    )
    fd = os.open(sim.serial_ports[0], os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    serial_bytes = b""
    try:
        while sim.time_s < 1.0:
            sim.step()
            serial_bytes += _read_all_bytes(fd)
        client.drain()
    finally:
        os.close(fd)
        client.close()
        sim.close()
    parser = mavlink2.MAVLink(None)
    parser.robust_parsing = True
    frames = [m for m in parser.parse_buffer(serial_bytes) or [] if m.get_type() != "BAD_DATA"]
    for msgs in (frames, client.inbox):
        assert msgs
        assert all(m.get_msgbuf()[2] & mavlink2.MAVLINK_IFLAG_SIGNED for m in msgs)


def _read_all_bytes(fd: int) -> bytes:
    out = b""
    while True:
        try:
            chunk = os.read(fd, 65536)
        except BlockingIOError:
            return out
        if not chunk:
            return out
        out += chunk
