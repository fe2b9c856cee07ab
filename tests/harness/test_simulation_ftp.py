"""Each vehicle of a Simulation serves its own MAVLink FTP root."""

from __future__ import annotations

import socket
import time

import pytest
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink.ftp_codec import FtpPayload, Opcode, decode
from harness.run.ports import free_port_block
from harness.sim.simulation import PortPlan, Simulation, SimulationConfig

pytestmark = pytest.mark.sockets


def _sim(n_vehicles: int, out_dir=None) -> Simulation:
    base = free_port_block(2 * n_vehicles)
    ports = PortPlan(listen_base=base, sdk_base=base + n_vehicles, gcs_port=0)
    return Simulation(
        SimulationConfig(n_vehicles=n_vehicles, ports=ports, out_dir=out_dir, record_hz=0)
    )


def _list_over_udp(sim: Simulation, i: int, directory: bytes) -> FtpPayload:
    """ListDirectory to vehicle i's endpoint while the simulation steps; the reply."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sock.setblocking(False)
    mav = mavlink2.MAVLink(None, srcSystem=245, srcComponent=190)
    try:
        request = FtpPayload(0, 0, Opcode.LIST_DIRECTORY, len(directory), data=directory)
        message = mavlink2.MAVLink_file_transfer_protocol_message(0, i + 1, 1, request.encode())
        sock.sendto(message.pack(mav), sim.endpoints[i].local_address)
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline:
            sim.run_lockstep(0.01)
            try:
                data = sock.recv(65535)
            except BlockingIOError:
                continue
            for msg in mav.parse_buffer(data) or []:
                if msg.get_type() == "FILE_TRANSFER_PROTOCOL":
                    return decode(msg.payload)
        raise AssertionError("no FTP reply")
    finally:
        sock.close()


def test_each_vehicle_serves_its_own_root_in_the_run_directory(tmp_path):
    out = tmp_path / "run"
    with _sim(2, out) as sim:
        assert sim.ftp_roots == [out / "vehicle1" / "fs", out / "vehicle2" / "fs"]
        (sim.ftp_roots[1] / "log" / "only_on_2.txt").write_bytes(b"two")
        first = _list_over_udp(sim, 0, b"/log\0")
        second = _list_over_udp(sim, 1, b"/log\0")
    assert first.valid_data == b"S\0S\0"  # an empty log/
    assert second.valid_data == b"S\0S\0Fonly_on_2.txt\t3\0"
    assert (out / "vehicle2" / "fs" / "log" / "only_on_2.txt").exists()  # kept with the run


def test_without_a_run_directory_the_root_is_temporary(tmp_path):
    with _sim(1) as sim:
        (root,) = sim.ftp_roots
        assert (root / "log").is_dir()
        assert _list_over_udp(sim, 0, b"/\0").valid_data == b"S\0S\0Dlog\0"
    assert not root.exists()
    assert not root.parent.parent.exists()


def test_no_mavlink_no_root():
    with Simulation(SimulationConfig(mavlink=False, record_hz=0)) as sim:
        assert sim.ftp_roots == []
