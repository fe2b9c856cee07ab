"""Two links of one vehicle (PX4 SITL's onboard and ground-station instances) over loopback UDP.

What the vehicle announces once must reach every link; the telemetry snapshot is read once per
poll however many links stream from it; TIMESYNC requests are answered on the link they came in.
"""

from __future__ import annotations

import pytest
from mavlink_fakes import MavClient, has, make_endpoint
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink.link_hub import MAX_PENDING_ANNOUNCEMENTS, LinkHub
from autopilot_emu.mavlink.streams import StreamProfile

pytestmark = pytest.mark.sockets


@pytest.fixture
def gcs():
    """A second client, posing as the ground station on the vehicle's GCS link."""
    c = MavClient(sysid=255, compid=190)
    yield c
    c.close()


@pytest.fixture
def links(vehicle, client, gcs):
    """(onboard, gcs) endpoints of one vehicle sharing a hub, each streaming to its client."""
    hub = LinkHub(vehicle)
    onboard = make_endpoint(vehicle, peers=(client.address,), hub=hub)
    ground = make_endpoint(vehicle, peers=(gcs.address,), hub=hub, profile=StreamProfile.NORMAL)
    yield onboard, ground
    onboard.close()
    ground.close()


def _poll_both(links, now_s):
    for link in links:
        link.poll(now_s)


def _texts(inbox):
    return [m.text for m in inbox if m.get_type() == "STATUSTEXT"]


def test_status_texts_and_mission_items_reached_go_out_on_both_links(links, vehicle, client, gcs):
    """Each announcement once per link: the first link to read must not consume it."""
    vehicle.status_texts = [(6, "Armed by external command"), (6, "Takeoff detected")]
    vehicle.reached = [0, 1]
    _poll_both(links, 0.0)
    vehicle.status_texts = [(4, "Landing at current position")]
    _poll_both(links, 0.1)
    _poll_both(links, 0.2)
    expected = ["Armed by external command", "Takeoff detected", "Landing at current position"]
    for inbox in (client.drain(), gcs.drain()):
        assert _texts(inbox) == expected
        reached = [m.seq for m in inbox if m.get_type() == "MISSION_ITEM_REACHED"]
        assert reached == [0, 1]


def test_one_snapshot_per_poll_for_both_links(links, vehicle):
    """Both links stream at t = 0 (every stream is due at start); the vehicle is read once."""
    _poll_both(links, 0.0)
    assert vehicle.telemetry_calls == 1
    _poll_both(links, 0.01)  # ATTITUDE (100 Hz, onboard) is due again
    assert vehicle.telemetry_calls == 2


def test_a_command_on_one_link_refreshes_the_snapshot_for_the_other(links, vehicle, client):
    """Input handled by a link may change the vehicle: the next build reads it afresh."""
    onboard, ground = links
    _poll_both(links, 0.0)
    client.send(onboard, mavlink2.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3))
    client.exchange(onboard, 0.01, has("ATTITUDE"))
    calls = vehicle.telemetry_calls
    ground.poll(0.01)
    assert vehicle.telemetry_calls == calls  # nothing handled since: same snapshot


def test_links_stream_their_own_profiles(links, client, gcs):
    _poll_both(links, 0.0)
    onboard_types = {m.get_type() for m in client.drain()}
    gcs_types = {m.get_type() for m in gcs.drain()}
    assert {"HIGHRES_IMU", "ODOMETRY", "TIMESYNC", "SYSTEM_TIME"} <= onboard_types
    assert not {"HIGHRES_IMU", "ODOMETRY", "TIMESYNC", "SYSTEM_TIME"} & gcs_types
    assert {"HEARTBEAT", "SYS_STATUS", "ATTITUDE", "ESTIMATOR_STATUS"} <= gcs_types


def test_gcs_heartbeat_counts_on_either_link(links, vehicle, client, gcs):
    """Data-link-loss failsafe: a ground station's HEARTBEAT on either link keeps it alive."""
    onboard, ground = links
    gcs_heartbeat = mavlink2.MAVLink_heartbeat_message(mavlink2.MAV_TYPE_GCS, 8, 0, 0, 4, 3)
    client.send(onboard, gcs_heartbeat)
    gcs.send(ground, gcs_heartbeat)
    _poll_both(links, 0.0)
    assert vehicle.calls.count(("gcs_heartbeat",)) == 2


def test_timesync_request_is_answered_with_our_boot_time_in_ns(vehicle, client):
    """PX4: tc1 == 0 is a request; the reply carries tc1 = boot time (ns) and ts1 echoed."""
    with make_endpoint(vehicle, stream_rates_hz={"HEARTBEAT": 0, "TIMESYNC": 0}) as endpoint:
        client.send(endpoint, mavlink2.MAVLink_timesync_message(tc1=0, ts1=123_456_789))
        inbox = list(client.exchange(endpoint, 2.5, has("TIMESYNC")))
        client.send(endpoint, mavlink2.MAVLink_timesync_message(tc1=42, ts1=123_456_789))
        client.send(endpoint, mavlink2.MAVLink_ping_message(1, 1, 0, 0))  # answered: a marker
        later = client.exchange(endpoint, 2.6, has("PING"))
    reply = next(m for m in inbox if m.get_type() == "TIMESYNC")
    assert (reply.tc1, reply.ts1) == (2_500_000_000, 123_456_789)
    assert not any(m.get_type() == "TIMESYNC" for m in later)  # an answer is not answered


def test_timesync_stream_requests_with_our_boot_time(vehicle, client):
    """The onboard profile's TIMESYNC stream: tc1 = 0 (request), ts1 = boot time in ns."""
    with make_endpoint(vehicle, peers=(client.address,)) as endpoint:
        inbox = client.exchange(endpoint, 0.0, has("TIMESYNC"))
    request = next(m for m in inbox if m.get_type() == "TIMESYNC")
    assert (request.tc1, request.ts1) == (0, vehicle.snapshot.time_usec * 1000)


def test_a_link_that_never_reads_does_not_grow_the_log_without_bound(vehicle):
    hub = LinkHub(vehicle)
    reader, idle = hub.subscribe(), hub.subscribe()
    for k in range(3 * MAX_PENDING_ANNOUNCEMENTS):
        vehicle.status_texts = [(6, f"text {k}")]
        texts, _ = hub.announcements(reader)
        assert texts == [(6, f"text {k}")]
    texts, _ = hub.announcements(idle)
    assert len(texts) == MAX_PENDING_ANNOUNCEMENTS
    assert texts[-1] == (6, f"text {3 * MAX_PENDING_ANNOUNCEMENTS - 1}")


def test_a_hub_serves_one_vehicle(vehicle):
    from mavlink_fakes import FakeVehicle

    with pytest.raises(ValueError, match="another vehicle"):
        make_endpoint(FakeVehicle(), hub=LinkHub(vehicle))


def test_a_telemetry_source_given_to_the_hub_replaces_the_vehicles(vehicle, client):
    """The simulation hands the hub its fleet's lazy snapshots: the links read only that."""
    reads = []

    def source():
        reads.append(1)
        return vehicle.snapshot

    hub = LinkHub(vehicle, source)
    with make_endpoint(vehicle, peers=(client.address,), hub=hub) as onboard:
        client.exchange(onboard, 0.0, has("ATTITUDE"))
    assert len(reads) == 1
    assert vehicle.telemetry_calls == 0
