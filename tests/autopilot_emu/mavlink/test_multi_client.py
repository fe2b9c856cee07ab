"""Several clients per vehicle, as PX4 serves them: ACKs to the sender, parameters on every link."""

from __future__ import annotations

import time

import pytest
from mavlink_fakes import FakeVehicle, MavClient, command_long, make_endpoint
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink.link_hub import LinkHub
from autopilot_emu.mavlink.streams import STREAMABLE

pytestmark = pytest.mark.sockets

QUIET = dict.fromkeys(STREAMABLE, 0.0)
"""No telemetry streams: only replies and announcements reach the clients."""
GCS_HEARTBEAT = mavlink2.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3)


def _poll_all(endpoints, clients, now_s=0.0, rounds=5):
    for _ in range(rounds):
        for ep in endpoints:
            ep.poll(now_s)
        time.sleep(0.002)
    for c in clients:
        c.drain()


@pytest.fixture
def two_links():
    """Two links of one vehicle (onboard, extra UDP output) and three clients: two on the first
    link (different addresses, different system ids), one on the second."""
    vehicle = FakeVehicle()
    hub = LinkHub(vehicle)
    a, b, c = MavClient(245, 190), MavClient(250, 191), MavClient(255, 190)
    first = make_endpoint(vehicle, hub=hub, stream_rates_hz=QUIET)
    second = make_endpoint(vehicle, peers=(c.address,), hub=hub, stream_rates_hz=QUIET)
    yield vehicle, (first, second), (a, b, c)
    for item in (first, second, a, b, c):
        item.close()


def test_a_command_ack_goes_to_the_sender_alone(two_links):
    """Both clients of the first link are its peers (learned), yet only the one that sent
    the command gets its ACK; the client of the other link gets none either."""
    vehicle, (first, second), (a, b, c) = two_links
    a.send(first, GCS_HEARTBEAT)
    b.send(first, GCS_HEARTBEAT)
    c.send(second, GCS_HEARTBEAT)
    _poll_all((first, second), (a, b, c))
    assert set(first.peers) == {a.address, b.address}
    for client in (a, b, c):
        client.inbox.clear()
    a.send(first, command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 1))
    _poll_all((first, second), (a, b, c))
    acks = a.take("COMMAND_ACK")
    assert [(m.command, m.target_system, m.target_component) for m in acks] == [(400, 245, 190)]
    assert not b.take("COMMAND_ACK") and not c.take("COMMAND_ACK")
    assert ("arm", False) in vehicle.calls
    b.send(first, command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 0))
    _poll_all((first, second), (a, b, c))
    assert [m.target_system for m in b.take("COMMAND_ACK")] == [250]
    assert not a.take("COMMAND_ACK") and not c.take("COMMAND_ACK")


def test_a_parameter_set_on_one_link_is_announced_on_every_link(two_links):
    vehicle, (first, second), (a, b, c) = two_links
    a.send(first, GCS_HEARTBEAT)
    _poll_all((first, second), (a, b, c))
    a.send(
        first,
        mavlink2.MAVLink_param_set_message(
            1, 1, b"MPC_XY_VEL_MAX", 7.5, mavlink2.MAV_PARAM_TYPE_REAL32
        ),
    )
    _poll_all((first, second), (a, b, c))
    _poll_all((first, second), (a, b, c), now_s=0.05)  # the other link's next announcement tick
    for client in (a, c):
        values = [m for m in client.take("PARAM_VALUE") if m.param_id == "MPC_XY_VEL_MAX"]
        assert [m.param_value for m in values] == [7.5]
    assert vehicle.params.get("MPC_XY_VEL_MAX") == 7.5
    # setting the same value again changes nothing: no announcement on the other link
    a.send(
        first,
        mavlink2.MAVLink_param_set_message(
            1, 1, b"MPC_XY_VEL_MAX", 7.5, mavlink2.MAV_PARAM_TYPE_REAL32
        ),
    )
    _poll_all((first, second), (a, b, c), now_s=0.1)
    _poll_all((first, second), (a, b, c), now_s=0.15)
    assert len(a.take("PARAM_VALUE")) == 1  # the echo to the sender's link
    assert not c.take("PARAM_VALUE")


def test_a_rejected_parameter_set_is_not_announced(two_links):
    _, (first, second), (a, b, c) = two_links
    a.send(
        first,
        mavlink2.MAVLink_param_set_message(
            1, 1, b"MPC_XY_VEL_MAX", -3.0, mavlink2.MAV_PARAM_TYPE_REAL32
        ),
    )
    _poll_all((first, second), (a, b, c))
    _poll_all((first, second), (a, b, c), now_s=0.05)
    assert a.take("PARAM_ERROR") and not a.take("PARAM_VALUE")
    assert not c.take("PARAM_VALUE") and not c.take("PARAM_ERROR")
