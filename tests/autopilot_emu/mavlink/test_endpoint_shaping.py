"""An endpoint behind a LinkShaper: frames and datagrams wait for their modelled arrival.

The shaper here is a fixed-delay stand-in (the link models live in ``sitl``): what matters is
that the endpoint sends nothing and handles nothing before the shaper releases it, that it logs
frames when the vehicle emits or handles them, and that it satisfies the Protocol.
"""

from __future__ import annotations

import math
import select

import pytest
from mavlink_fakes import MavClient, command_long, make_endpoint
from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink.shaping import LinkShaper
from autopilot_emu.mavlink.streams import STREAMABLE

pytestmark = pytest.mark.sockets

DELAY_S = 0.05


class DelayShaper:
    """Every frame and datagram arrives DELAY_S after it was handed over.

    With ``drop_every`` k, every k-th outgoing HEARTBEAT (MAVLink 2 message id 0) is lost.
    """

    def __init__(self, delay_s: float = DELAY_S, drop_every: int = 0) -> None:
        self.delay_s = delay_s
        self.drop_every = drop_every
        self.out: list[tuple[float, bytes]] = []
        self.inn: list[tuple[float, bytes, tuple[str, int]]] = []
        self.handed_out = 0
        self.heartbeats = 0

    def outbound(self, now_s: float, frame: bytes) -> None:
        self.handed_out += 1
        if self.drop_every and frame[0] == 0xFD and frame[7:10] == b"\0\0\0":
            self.heartbeats += 1
            if self.heartbeats % self.drop_every == 0:
                return
        self.out.append((now_s + self.delay_s, frame))

    def inbound(self, now_s: float, data: bytes, address: tuple[str, int]) -> None:
        self.inn.append((now_s + self.delay_s, data, address))

    def due_outbound(self, now_s: float) -> list[bytes]:
        due = [f for t, f in self.out if t <= now_s]
        self.out = [(t, f) for t, f in self.out if t > now_s]
        return due

    def due_inbound(self, now_s: float) -> list[tuple[bytes, tuple[str, int]]]:
        due = [(d, a) for t, d, a in self.inn if t <= now_s]
        self.inn = [(t, d, a) for t, d, a in self.inn if t > now_s]
        return due

    @property
    def next_due_s(self) -> float:
        return min([t for t, _ in self.out] + [t for t, _, _ in self.inn], default=math.inf)


def _wait_readable(client: MavClient) -> None:
    select.select([client.sock], [], [], 1.0)


def test_the_stand_in_satisfies_the_protocol():
    """LinkShaper is a runtime-checkable Protocol: a duck-typed shaper is one."""
    assert isinstance(DelayShaper(), LinkShaper)


def test_telemetry_leaves_only_when_the_link_delivers_it(vehicle):
    """HEARTBEAT emitted at t = 0 reaches the peer at the first poll at or after t + delay."""
    client = MavClient()
    shaper = DelayShaper()
    try:
        with make_endpoint(vehicle, peers=(client.address,), shaper=shaper) as ep:
            ep.poll(0.0)
            assert shaper.handed_out > 0, "nothing handed to the shaper"
            ep.poll(DELAY_S / 2)
            assert client.drain() == []
            ep.poll(DELAY_S)
            _wait_readable(client)
            got = client.drain()
    finally:
        client.close()
    assert any(m.get_type() == "HEARTBEAT" for m in got)


def test_a_command_is_executed_when_it_arrives_not_when_it_is_sent(vehicle):
    """COMMAND_LONG sent at t = 0 is neither executed nor ACKed before t = delay."""
    client = MavClient()
    shaper = DelayShaper()
    try:
        with make_endpoint(
            vehicle, peers=(client.address,), shaper=shaper, stream_rates_hz={"HEARTBEAT": 0}
        ) as ep:
            client.send(ep, command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 1.0))
            _wait_readable_endpoint(ep)
            ep.poll(0.0)
            ep.poll(0.9 * DELAY_S)
            assert not [c for c in vehicle.calls if c[0] == "arm"], "executed before arrival"
            ep.poll(DELAY_S)
            assert [c for c in vehicle.calls if c[0] == "arm"], "not executed on arrival"
            ep.poll(1.5 * DELAY_S)
            early = [m for m in client.drain() if m.get_type() == "COMMAND_ACK"]
            assert early == [], "the ACK crossed the link faster than modelled"
            ep.poll(2 * DELAY_S)
            _wait_readable(client)
            acks = [m for m in client.drain() if m.get_type() == "COMMAND_ACK"]
    finally:
        client.close()
    assert len(acks) == 1 and acks[0].command == mavlink2.MAV_CMD_COMPONENT_ARM_DISARM


def _wait_readable_endpoint(ep) -> None:
    select.select([ep.fileno()], [], [], 1.0)


def test_frames_the_link_drops_never_reach_the_peer_but_are_logged(vehicle, tmp_path):
    """A dropped frame is in the tlog (the vehicle emitted it) and not at the peer."""
    client = MavClient()
    shaper = DelayShaper(delay_s=0.0, drop_every=2)
    tlog = tmp_path / "v.tlog"
    try:
        with make_endpoint(
            vehicle,
            peers=(client.address,),
            shaper=shaper,
            tlog_path=tlog,
            stream_rates_hz={**dict.fromkeys(STREAMABLE, 0.0), "HEARTBEAT": 1.0},
        ) as ep:
            for k in range(40):
                ep.poll(k * 0.5)
                select.select([client.sock], [], [], 0.05)
                client.drain()
            received = [m for m in client.inbox if m.get_type() == "HEARTBEAT"]
    finally:
        client.close()
    log = mavutil.mavlink_connection(str(tlog))
    logged = 0
    while log.recv_match(type="HEARTBEAT") is not None:
        logged += 1
    log.close()
    assert logged >= 19
    assert len(received) == logged - logged // 2
