"""Forwarding between one vehicle's links, as PX4's ``-f``: the camera's traffic, other systems'."""

from __future__ import annotations

import math
import time

import pytest
from mavlink_fakes import FakeVehicle, MavClient, command_long, has, make_endpoint
from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink.forwarding import ForwardingGroup, required_target, should_forward
from autopilot_emu.mavlink.link_hub import LinkHub
from autopilot_emu.mavlink.streams import STREAMABLE
from autopilot_emu.mission.camera_items import ComponentCommand

pytestmark = pytest.mark.sockets

QUIET = dict.fromkeys(STREAMABLE, 0.0)
"""No telemetry streams: only forwarded frames and replies reach the clients."""


def _message(msg: mavlink2.MAVLink_message, src: tuple[int, int]) -> mavlink2.MAVLink_message:
    """``msg`` as received from ``src`` (packed and parsed back, so the header ids are set)."""
    mav = mavlink2.MAVLink(None, srcSystem=src[0], srcComponent=src[1])
    return mav.parse_char(msg.pack(mav))


HEARTBEAT = mavlink2.MAVLink_heartbeat_message(mavlink2.MAV_TYPE_CAMERA, 8, 0, 0, 4, 3)


@pytest.mark.parametrize(
    ("msg", "src", "expected"),
    [
        (HEARTBEAT, (1, 100), True),  # our camera's broadcast
        (command_long(2000, target_component=100), (245, 190), True),  # an SDK's command for it
        (mavlink2.MAVLink_command_ack_message(2000, 0, 0, 0, 245, 190), (1, 100), True),
        (command_long(2000, target_component=1), (1, 100), False),  # for the autopilot alone
        (command_long(2000, target_component=100), (245, 190), True),
        (command_long(400, target_component=1), (245, 190), False),  # for the autopilot
        (command_long(400, target_component=0), (245, 190), True),  # for all our components
        (command_long(2000, target_system=2, target_component=100), (245, 190), True),
        (HEARTBEAT, (255, 190), True),  # a ground station's heartbeat (MAV_HB_FORW_EN)
        (HEARTBEAT, (1, 1), False),  # our own frame looped back
        # SETUP_SIGNING is never forwarded (MAVLink signing spec), even for the camera
        (mavlink2.MAVLink_setup_signing_message(1, 100, [7] * 32, 1), (255, 190), False),
    ],
)
def test_what_is_forwarded(msg, src, expected):
    assert should_forward(_message(msg, src), sysid=1, compid=1) is expected


@pytest.mark.parametrize(
    ("msg", "src", "expected"),
    [
        (HEARTBEAT, (1, 100), None),  # our camera: every link
        (command_long(2000, target_component=100), (245, 190), None),  # for our camera
        (HEARTBEAT, (255, 190), (0, 0)),  # broadcast: links that heard anyone
        (command_long(2000, target_system=2, target_component=100), (245, 190), (2, 100)),
    ],
)
def test_which_links_get_a_forwarded_frame(msg, src, expected):
    assert required_target(_message(msg, src), sysid=1) == expected


def test_a_link_gets_other_systems_frames_once_it_heard_from_their_target():
    """PX4's component_was_seen: system 0 = anyone heard; component 0 = any of the system's."""
    group = ForwardingGroup()
    got: list[list[bytes]] = [[], [], []]
    members = [group.join(got[k].append) for k in range(3)]
    assert group.forward(members[0], b"hb", (0, 0)) == 0  # nobody heard from anyone yet
    group.heard(members[1], 245, 190)
    assert group.forward(members[0], b"hb", (0, 0)) == 1
    assert group.forward(members[0], b"cmd", (245, 0)) == 1
    assert group.forward(members[0], b"cmd", (245, 1)) == 0
    assert group.forward(members[0], b"cmd", (246, 0)) == 0
    assert group.forward(members[1], b"own", None) == 2  # our system's: every other link
    assert got == [[b"own"], [b"hb", b"cmd"], [b"own"]]


def _vehicle_links(rates):
    """(vehicle, (onboard, gcs, payload) endpoints, a client on each) with ``rates``."""
    vehicle = FakeVehicle()
    hub = LinkHub(vehicle)
    clients = [MavClient(), MavClient(255, 190), MavClient(1, 100)]
    endpoints = [
        make_endpoint(vehicle, peers=(c.address,), hub=hub, stream_rates_hz=rates) for c in clients
    ]
    return vehicle, endpoints, clients


@pytest.fixture
def links():
    """(onboard, gcs, payload) endpoints of one vehicle and a client on each."""
    vehicle, endpoints, clients = _vehicle_links(QUIET)
    yield vehicle, endpoints, clients
    for item in (*endpoints, *clients):
        item.close()


def _poll_all(endpoints, clients, now_s=0.0, rounds=5):
    for _ in range(rounds):
        for ep in endpoints:
            ep.poll(now_s)
        time.sleep(0.002)
    for c in clients:
        c.drain()


def test_a_command_for_the_camera_goes_out_of_the_other_links_verbatim(links):
    """MAVSDK's IMAGE_START_CAPTURE for compid 100 on the onboard link leaves the payload and
    GCS links byte for byte (same seq, same source ids); the autopilot does not ACK it."""
    _, (onboard, ground, payload), (sdk, gcs, camera) = links
    frame = sdk.send(onboard, command_long(2000, 0, 0, 1, 7, target_component=100))
    _poll_all((onboard, ground, payload), (sdk, gcs, camera))
    for client in (camera, gcs):
        got = [m for m in client.inbox if m.get_type() == "COMMAND_LONG"]
        assert len(got) == 1
        assert bytes(got[0].get_msgbuf()) == frame
        assert (got[0].get_srcSystem(), got[0].get_srcComponent()) == (245, 190)
    assert not sdk.take("COMMAND_ACK") and not sdk.take("COMMAND_LONG")
    assert onboard.stats.frames_forwarded == 1
    assert onboard.stats.commands_ignored == 0
    assert payload.stats.frames_relayed == ground.stats.frames_relayed == 1


def test_the_cameras_broadcasts_and_replies_reach_the_onboard_and_gcs_links(links):
    _, (onboard, ground, payload), (sdk, gcs, camera) = links
    camera.send(payload, HEARTBEAT)
    camera.send(payload, mavlink2.MAVLink_command_ack_message(2000, 0, 0, 0, 245, 190))
    _poll_all((onboard, ground, payload), (sdk, gcs, camera))
    for client in (sdk, gcs):
        beats = [m for m in client.take("HEARTBEAT") if m.get_srcComponent() == 100]
        assert len(beats) == 1 and beats[0].type == mavlink2.MAV_TYPE_CAMERA
        assert [a.get_srcComponent() for a in client.take("COMMAND_ACK")] == [100]
    assert not [m for m in camera.inbox if m.get_srcComponent() == 100]  # not echoed back


def test_a_cameras_heartbeat_follows_an_autopilot_frame_on_every_link():
    """The first frame a client that starts listening gets from our system is the autopilot's:
    mavsdk_server 4.0 takes a system whose first HEARTBEAT came from the camera for one without
    an autopilot, for good. So a relayed camera HEARTBEAT waits for the link's next own frame
    (here the 1 Hz HEARTBEAT at t = 1 s, the other streams being off) and goes right after it."""
    _, (onboard, ground, payload), (sdk, gcs, camera) = _vehicle_links({**QUIET, "HEARTBEAT": 1.0})
    try:
        _poll_all((onboard, ground, payload), (sdk, gcs, camera))  # the t = 0 HEARTBEATs
        for client in (sdk, gcs):
            client.inbox.clear()
        camera.send(payload, HEARTBEAT)
        _poll_all((onboard, ground, payload), (sdk, gcs, camera), now_s=0.5)
        assert not [m for c in (sdk, gcs) for m in c.inbox if m.get_srcComponent() == 100]
        _poll_all((onboard, ground, payload), (sdk, gcs, camera), now_s=1.0)
        for client in (sdk, gcs):
            beats = [m.get_srcComponent() for m in client.inbox if m.get_type() == "HEARTBEAT"]
            assert beats == [1, 100]
        assert onboard.stats.frames_relayed == ground.stats.frames_relayed == 1
    finally:
        for item in (onboard, ground, payload, sdk, gcs, camera):
            item.close()


def test_other_systems_broadcasts_reach_the_links_that_heard_someone(links):
    """As PX4's -f: the ground station's HEARTBEAT reaches the SDK's link (which heard the SDK),
    not the payload link (which heard nobody); commands for the autopilot alone stay put; the
    SDK's heartbeat reaches the ground station, never back to the SDK."""
    _, (onboard, ground, payload), (sdk, gcs, camera) = links
    sdk.send(onboard, mavlink2.MAVLink_heartbeat_message(18, 8, 0, 0, 4, 3))
    _poll_all((onboard, ground, payload), (sdk, gcs, camera))
    assert onboard.stats.frames_forwarded == 0  # no other link heard anyone yet
    gcs.send(ground, mavlink2.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3))
    gcs.send(ground, command_long(31000, target_component=1))
    _poll_all((onboard, ground, payload), (sdk, gcs, camera))
    sdk.send(onboard, mavlink2.MAVLink_heartbeat_message(18, 8, 0, 0, 4, 3))
    _poll_all((onboard, ground, payload), (sdk, gcs, camera))
    from_gcs = [m.get_type() for m in sdk.inbox if m.get_srcSystem() == 255]
    assert from_gcs == ["HEARTBEAT"]
    assert [m.get_type() for m in gcs.inbox if m.get_srcSystem() == 245] == ["HEARTBEAT"]
    assert not [m for m in camera.inbox if m.get_srcSystem() in (245, 255)]
    assert not [m for m in sdk.inbox if m.get_srcSystem() == 245]
    assert ground.stats.frames_forwarded == onboard.stats.frames_forwarded == 1


def test_forwarding_off_and_closed_links(links):
    """A closed link gets nothing; with forwarding off a link neither relays nor is relayed to."""
    vehicle, (onboard, ground, payload), (sdk, gcs, camera) = links
    payload.close()
    lone = make_endpoint(vehicle, peers=(camera.address,), hub=ground._hub, forwarding=False)
    try:
        sdk.send(onboard, command_long(2000, target_component=100))
        sdk.send(lone, command_long(2000, target_component=100))
        _poll_all((onboard, ground, lone), (sdk, gcs, camera))
        assert len(gcs.take("COMMAND_LONG")) == 1  # from the onboard link only
        assert not camera.take("COMMAND_LONG")
        assert lone.stats.commands_ignored == 1
    finally:
        lone.close()


def test_forwarded_frames_are_in_the_tlogs_of_both_links(tmp_path):
    """The receiving link logs the frame as received, the other link as sent (what a client
    recording on each link would see)."""
    vehicle = FakeVehicle()
    hub = LinkHub(vehicle)
    sdk, camera = MavClient(), MavClient(1, 100)
    onboard = make_endpoint(
        vehicle, (sdk.address,), hub=hub, stream_rates_hz=QUIET, tlog_path=tmp_path / "a.tlog"
    )
    payload = make_endpoint(
        vehicle, (camera.address,), hub=hub, stream_rates_hz=QUIET, tlog_path=tmp_path / "b.tlog"
    )
    try:
        camera.send(payload, HEARTBEAT)
        _poll_all((onboard, payload), (sdk, camera))
    finally:
        for item in (onboard, payload, sdk, camera):
            item.close()
    for name in ("a.tlog", "b.tlog"):
        log = mavutil.mavlink_connection(str(tmp_path / name))
        beats = []
        while (m := log.recv_match(type="HEARTBEAT")) is not None:
            beats.append(m.get_srcComponent())
        log.close()
        assert beats == [100]


def test_component_commands_go_out_once_on_every_link(links):
    """A mission's camera item: COMMAND_LONG from the autopilot to compid 100 on each link."""
    vehicle, endpoints, clients = links
    vehicle.component_commands.append(
        ComponentCommand(2000, (0.0, 0.0, 1.0, 1.0, 0.0, 0.0, math.nan), 100)
    )
    _poll_all(endpoints, clients, rounds=2)
    _poll_all(endpoints, clients, now_s=1.0, rounds=2)
    for client in clients:
        cmds = client.take("COMMAND_LONG")
        assert len(cmds) == 1
        cmd = cmds[0]
        assert (cmd.get_srcSystem(), cmd.get_srcComponent()) == (1, 1)
        assert (cmd.target_system, cmd.target_component, cmd.command) == (1, 100, 2000)
        assert (cmd.param3, cmd.param4) == (1.0, 1.0)


def test_a_single_link_forwards_nothing(client, endpoint):
    client.send(endpoint, command_long(2000, target_component=100))
    client.exchange(endpoint, 0.0, lambda inbox: endpoint.stats.commands_ignored == 1)
    assert endpoint.stats.frames_forwarded == 0
    assert not has("COMMAND_LONG")(client.inbox)
