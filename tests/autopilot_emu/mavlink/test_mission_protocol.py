"""Mission protocol server against a raw pymavlink client: PX4's NACK, retry and timeout rules.

The endpoint's wall clock is a fake advanced by the test, so retry and timeout rules are
checked without waiting; every message goes over a real loopback UDP socket.
"""

from __future__ import annotations

import math

import pytest
from mavlink_fakes import MavClient, has, make_endpoint
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mission.items import MAX_ITEMS, MissionItem, MissionType

pytestmark = pytest.mark.sockets

LAT, LON = 473977420, 85455940
REL = mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT


class FakeClock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def clock():
    return FakeClock()


@pytest.fixture
def ep(vehicle, clock):
    with make_endpoint(vehicle, wall_clock_s=clock, stream_rates_hz={"HEARTBEAT": 0}) as e:
        yield e


def item_int(
    seq,
    command=mavlink2.MAV_CMD_NAV_WAYPOINT,
    frame=REL,
    x=LAT,
    y=LON,
    z=10.0,
    kind=0,
    params=(0.0, 1.0, 0.0, math.nan),
):
    return mavlink2.MAVLink_mission_item_int_message(
        1, 1, seq, frame, command, 0, 1, *params, x, y, z, kind
    )


def acks(inbox):
    return [m for m in inbox if m.get_type() == "MISSION_ACK"]


def requests(inbox):
    return [m for m in inbox if m.get_type() == "MISSION_REQUEST_INT"]


def start_upload(client, ep, count, kind=0):
    return (
        client.exchange(
            ep,
            0.0,
            lambda inbox: requests(inbox) or acks(inbox),
            max_wait_s=2.0,
        )
        if client.send(ep, mavlink2.MAVLink_mission_count_message(1, 1, count, kind))
        else None
    )


def send_and_wait(client, ep, msg, until):
    client.send(ep, msg)
    return client.exchange(ep, 0.0, until, max_wait_s=2.0)


def upload(client, ep, items, kind=0):
    inbox = start_upload(client, ep, len(items), kind)
    while not acks(inbox):
        seq = requests(inbox)[-1].seq
        inbox = send_and_wait(client, ep, items[seq], lambda i: requests(i) or acks(i))
    return acks(inbox)[-1]


def test_upload_requests_each_item_with_request_int_then_acks_and_stores(client, ep, vehicle):
    items = [item_int(s, z=10.0 + s) for s in range(3)]
    inbox = start_upload(client, ep, 3)
    seen = []
    while not acks(inbox):
        req = requests(inbox)[-1]
        assert (req.target_system, req.target_component) == (245, 190)
        assert req.mission_type == 0
        seen.append(req.seq)
        inbox = send_and_wait(client, ep, items[req.seq], lambda i: requests(i) or acks(i))
    ack = acks(inbox)[-1]
    assert seen == [0, 1, 2]
    assert (ack.type, ack.mission_type, ack.target_system) == (0, 0, 245)
    stored = vehicle.plans[0]
    assert [it.z for it in stored] == [10.0, 11.0, 12.0]
    assert stored[0] == MissionItem(16, REL, (0.0, 1.0, 0.0, stored[0].params[3]), LAT, LON, 10.0)


@pytest.mark.parametrize("kind", [MissionType.FENCE, MissionType.RALLY])
def test_fence_and_rally_plans_upload_with_their_mission_type(client, ep, vehicle, kind):
    if kind == MissionType.FENCE:
        square = [(LAT, LON), (LAT + 3000, LON), (LAT + 3000, LON + 4000), (LAT, LON + 4000)]
        items = [
            item_int(
                s,
                mavlink2.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                x=x,
                y=y,
                z=0.0,
                kind=1,
                params=(4.0, 0.0, 0.0, 0.0),
            )
            for s, (x, y) in enumerate(square)
        ]
    else:
        items = [item_int(0, mavlink2.MAV_CMD_NAV_RALLY_POINT, kind=2, params=(0, 0, 0, 0))]
    ack = upload(client, ep, items, kind)
    assert (ack.type, ack.mission_type) == (mavlink2.MAV_MISSION_ACCEPTED, kind)
    assert len(vehicle.plans[kind]) == len(items)


def test_download_returns_items_exactly_as_uploaded(client, ep):
    items = [item_int(s, z=5.0 + s, x=LAT + 100 * s) for s in range(2)]
    upload(client, ep, items)
    inbox = send_and_wait(
        client, ep, mavlink2.MAVLink_mission_request_list_message(1, 1, 0), has("MISSION_COUNT")
    )
    assert inbox[-1].count == 2
    for seq in range(2):
        inbox = send_and_wait(
            client,
            ep,
            mavlink2.MAVLink_mission_request_int_message(1, 1, seq, 0),
            has("MISSION_ITEM_INT"),
        )
        got = [m for m in inbox if m.get_type() == "MISSION_ITEM_INT"][-1]
        assert (got.seq, got.x, got.y, got.z, got.frame, got.command) == (
            seq,
            LAT + 100 * seq,
            LON,
            5.0 + seq,
            REL,
            16,
        )
    # The legacy float request gets a float MISSION_ITEM.
    inbox = send_and_wait(
        client, ep, mavlink2.MAVLink_mission_request_message(1, 1, 1, 0), has("MISSION_ITEM")
    )
    legacy = [m for m in inbox if m.get_type() == "MISSION_ITEM"][-1]
    assert legacy.x == pytest.approx((LAT + 100) * 1e-7)


def test_request_past_the_end_is_nacked_with_error(client, ep):
    upload(client, ep, [item_int(0)])
    inbox = send_and_wait(
        client, ep, mavlink2.MAVLink_mission_request_int_message(1, 1, 5, 0), has("MISSION_ACK")
    )
    assert acks(inbox)[-1].type == mavlink2.MAV_MISSION_ERROR


def test_unknown_mission_type_is_nacked_invalid(client, ep):
    inbox = send_and_wait(
        client, ep, mavlink2.MAVLink_mission_count_message(1, 1, 2, 7), has("MISSION_ACK")
    )
    assert acks(inbox)[-1].type == mavlink2.MAV_MISSION_INVALID
    inbox = send_and_wait(
        client, ep, mavlink2.MAVLink_mission_request_list_message(1, 1, 9), has("MISSION_ACK")
    )
    assert acks(inbox)[-1].type == mavlink2.MAV_MISSION_INVALID


def test_too_many_items_is_no_space(client, ep):
    inbox = start_upload(client, ep, MAX_ITEMS[MissionType.RALLY] + 1, kind=2)
    assert acks(inbox)[-1].type == mavlink2.MAV_MISSION_NO_SPACE


def test_count_zero_clears_the_plan(client, ep, vehicle):
    upload(client, ep, [item_int(0)])
    inbox = start_upload(client, ep, 0)
    assert acks(inbox)[-1].type == mavlink2.MAV_MISSION_ACCEPTED
    assert vehicle.plans[0] == ()


@pytest.mark.parametrize(
    ("item", "result"),
    [
        (item_int(0, frame=mavlink2.MAV_FRAME_LOCAL_NED), mavlink2.MAV_MISSION_UNSUPPORTED_FRAME),
        (item_int(0, command=40123), mavlink2.MAV_MISSION_UNSUPPORTED),
        (item_int(0, command=mavlink2.MAV_CMD_NAV_RALLY_POINT), mavlink2.MAV_MISSION_ERROR),
        (item_int(0, x=950_000_000), mavlink2.MAV_MISSION_INVALID_PARAM5_X),
        (item_int(0, y=-1_850_000_000), mavlink2.MAV_MISSION_INVALID_PARAM6_Y),
        (item_int(0, z=math.nan), mavlink2.MAV_MISSION_INVALID_PARAM7),
    ],
    ids=["frame", "command", "rally-in-mission", "lat", "lon", "alt"],
)
def test_bad_items_abort_the_upload_with_px4_result(client, ep, vehicle, item, result):
    start_upload(client, ep, 1)
    inbox = send_and_wait(client, ep, item, has("MISSION_ACK"))
    assert acks(inbox)[-1].type == result
    assert 0 not in vehicle.plans
    # The transfer is over: a new one starts cleanly.
    assert upload(client, ep, [item_int(0)]).type == mavlink2.MAV_MISSION_ACCEPTED


def test_polygon_with_two_vertices_is_an_error(client, ep):
    start_upload(client, ep, 2, kind=1)
    bad = item_int(
        0, mavlink2.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, kind=1, params=(2.0, 0, 0, 0)
    )
    inbox = send_and_wait(client, ep, bad, has("MISSION_ACK"))
    assert acks(inbox)[-1].type == mavlink2.MAV_MISSION_ERROR


def test_out_of_sequence_item_is_ignored_and_the_request_repeated(client, ep, clock):
    start_upload(client, ep, 2)
    client.send(ep, item_int(1))  # skips seq 0: PX4 ignores it
    clock.now += 0.6  # past the 0.5 s retry timeout
    inbox = client.exchange(ep, 0.0, lambda i: requests(i))
    assert [r.seq for r in requests(inbox)] == [0]
    assert not acks(inbox)


def test_lost_item_is_re_requested_after_the_retry_timeout(client, ep, clock):
    start_upload(client, ep, 2)
    client.drain()
    clock.now += 0.3
    ep.poll(0.0)
    assert not requests(client.drain())  # not yet
    clock.now += 0.3
    inbox = client.exchange(ep, 0.0, lambda i: requests(i))
    assert requests(inbox)[-1].seq == 0


def test_silent_partner_times_out_without_ack(client, ep, clock, vehicle):
    start_upload(client, ep, 2)
    client.drain()
    clock.now += 5.1
    inbox = client.exchange(ep, 0.0, has("STATUSTEXT"))
    assert any(m.text == "Operation timeout" for m in inbox if m.get_type() == "STATUSTEXT")
    assert not acks(inbox)
    # An item arriving now belongs to no transfer.
    inbox = send_and_wait(client, ep, item_int(0), has("MISSION_ACK"))
    assert acks(inbox)[-1].type == mavlink2.MAV_MISSION_ERROR
    assert 0 not in vehicle.plans


def test_repeated_count_before_the_first_item_repeats_the_request(client, ep):
    start_upload(client, ep, 2)
    inbox = start_upload(client, ep, 2)
    assert requests(inbox)[-1].seq == 0 and not acks(inbox)


def test_second_uploader_is_told_error_while_busy(client, ep):
    start_upload(client, ep, 2)
    other = MavClient(sysid=255, compid=190)
    try:
        inbox = send_and_wait(
            other, ep, mavlink2.MAVLink_mission_count_message(1, 1, 1, 0), has("MISSION_ACK")
        )
        assert acks(inbox)[-1].type == mavlink2.MAV_MISSION_ERROR
        assert acks(inbox)[-1].target_system == 255
    finally:
        other.close()


def test_final_item_retransmitted_after_a_lost_ack_is_acked_again(client, ep):
    upload(client, ep, [item_int(0)])
    inbox = send_and_wait(client, ep, item_int(0), has("MISSION_ACK"))
    assert acks(inbox)[-1].type == mavlink2.MAV_MISSION_ACCEPTED


def test_clear_all_clears_one_type_or_all(client, ep, vehicle):
    upload(client, ep, [item_int(0)])
    upload(client, ep, [item_int(0, mavlink2.MAV_CMD_NAV_RALLY_POINT, kind=2, params=(0,) * 4)], 2)
    inbox = send_and_wait(
        client, ep, mavlink2.MAVLink_mission_clear_all_message(1, 1, 2), has("MISSION_ACK")
    )
    assert acks(inbox)[-1].type == 0 and vehicle.plans[2] == () and vehicle.plans[0]
    inbox = send_and_wait(
        client, ep, mavlink2.MAVLink_mission_clear_all_message(1, 1, 255), has("MISSION_ACK")
    )
    assert acks(inbox)[-1].mission_type == 255
    assert vehicle.plans[0] == () and vehicle.plans[1] == ()


def test_set_current_reports_mission_current_or_says_not_in_list(client, ep):
    upload(client, ep, [item_int(s) for s in range(3)])
    inbox = send_and_wait(
        client, ep, mavlink2.MAVLink_mission_set_current_message(1, 1, 2), has("MISSION_CURRENT")
    )
    current = [m for m in inbox if m.get_type() == "MISSION_CURRENT"][-1]
    assert (current.seq, current.total) == (2, 3)
    inbox = send_and_wait(
        client, ep, mavlink2.MAVLink_mission_set_current_message(1, 1, 9), has("STATUSTEXT")
    )
    assert any(
        m.text == "WPM: WP CURR CMD: Not in list" for m in inbox if m.get_type() == "STATUSTEXT"
    )
    assert not acks(inbox)


def introduce(client, ep):
    """A GCS HEARTBEAT, so that the endpoint learns the client's address."""
    client.send(ep, mavlink2.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3))


def test_mission_current_streams_and_reports_no_mission_as_px4(client, ep):
    introduce(client, ep)
    inbox = client.exchange(ep, 2.0, has("MISSION_CURRENT"))
    current = [m for m in inbox if m.get_type() == "MISSION_CURRENT"][-1]
    assert current.total == 0xFFFF and current.mission_state == mavlink2.MISSION_STATE_NO_MISSION


def test_gcs_heartbeat_reaches_the_vehicle_and_other_heartbeats_do_not(client, ep, vehicle):
    client.send(ep, mavlink2.MAVLink_heartbeat_message(18, 8, 0, 0, 4, 3))  # onboard computer
    introduce(client, ep)
    client.exchange(ep, 0.0, lambda inbox: ("gcs_heartbeat",) in vehicle.calls)
    assert vehicle.calls.count(("gcs_heartbeat",)) == 1


def test_reached_items_are_reported(client, ep, vehicle):
    introduce(client, ep)
    vehicle.reached = [0, 1]
    inbox = client.exchange(ep, 1.0, has("MISSION_ITEM_REACHED", 2))
    assert [m.seq for m in inbox if m.get_type() == "MISSION_ITEM_REACHED"] == [0, 1]


def test_mission_messages_for_another_system_are_ignored(client, ep, vehicle):
    client.send(ep, mavlink2.MAVLink_mission_clear_all_message(7, 1, 0))
    inbox = send_and_wait(
        client, ep, mavlink2.MAVLink_mission_request_list_message(1, 1, 0), has("MISSION_COUNT")
    )
    assert not acks(inbox)
    assert ("upload_mission", 0, ()) not in vehicle.calls
