"""Raw pymavlink conformance of the mission, parameter and command protocols over real UDP.

The NACK and retry rules MAVSDK's transfer clients rely on (MAVSDK_CONTRACT.md sections 3, 7
and 9), checked against a real ``swarmsitl up`` (port slot 14) with a raw client that speaks as
MAVSDK does (sysid 245, compid 190). Rules already covered end to end are not repeated here:
command retransmissions, unknown and misaddressed commands, NaN parameters, malformed frames and
out-of-range or unknown PARAM_SETs are in ``tests/e2e/test_e2e_raw_pymavlink.py``; the same
mission rules with a fake wall clock are in
``tests/autopilot_emu/mavlink/test_mission_protocol.py``. docs/conformance.md maps every rule to
its test. Absence of a reply is judged by ordering (a later answer proves the earlier datagram
was handled), never by a wall-clock timing.
"""

from __future__ import annotations

import struct

import pytest
from e2e_support import RawLink, command_long, download_items, module_ports, running_swarm
from pymavlink.dialects.v20 import common as mavlink2

pytestmark = [pytest.mark.e2e, pytest.mark.conformance]

PORTS = module_ports()
MISSION = mavlink2.MAV_MISSION_TYPE_MISSION
FENCE = mavlink2.MAV_MISSION_TYPE_FENCE
RALLY = mavlink2.MAV_MISSION_TYPE_RALLY
HOME_DEG_E7 = (473977420, 85455940)
PARAM_ERROR_TYPE_MISMATCH = getattr(mavlink2, "MAV_PARAM_ERROR_TYPE_MISMATCH", 7)
"""7 in current common.xml; older pymavlink releases lack the name."""


@pytest.fixture(scope="module")
def swarm(tmp_path_factory):
    with running_swarm(1, PORTS, tmp_path_factory.mktemp("raw-protocols") / "run") as s:
        yield s


@pytest.fixture
def link(swarm):
    """A MAVSDK-like client (245/190), drained; a second one (246/190) is ``other_link``."""
    lk = RawLink(PORTS.listen, swarm.clock)
    lk.send(mavlink2.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3))
    assert lk.heartbeats(1)
    lk.drain()
    yield lk
    lk.close()


@pytest.fixture
def other_link(swarm):
    lk = RawLink(PORTS.listen, swarm.clock, sysid=246)
    yield lk
    lk.close()


def waypoint(seq: int, mission_type: int = MISSION, frame: int = 6, north_e7: int = 0):
    """A MISSION_ITEM_INT waypoint (or rally point) near home, 10 m up."""
    command = mavlink2.MAV_CMD_NAV_RALLY_POINT if mission_type == RALLY else 16
    return mavlink2.MAVLink_mission_item_int_message(
        1, 1, seq, frame, command, int(seq == 0), 1, 0, 1.0, 0, float("nan"),
        HOME_DEG_E7[0] + north_e7 + 200 * seq, HOME_DEG_E7[1], 10.0, mission_type,
    )  # fmt: skip


def is_request(seq: int, mission_type: int = MISSION):
    def pred(m) -> bool:
        return (
            m.get_type() == "MISSION_REQUEST_INT"
            and m.seq == seq
            and m.mission_type == mission_type
            and (m.target_system, m.target_component) == (245, 190)
        )

    return pred


def mission_ack(lk: RawLink, mission_type: int = MISSION, timeout_s: float = 10.0):
    ack = lk.wait_for(
        lambda m: (
            m.get_type() == "MISSION_ACK"
            and m.mission_type == mission_type
            and (m.target_system, m.target_component) == (lk.mav.srcSystem, lk.mav.srcComponent)
        ),
        timeout_s,
    )
    assert ack is not None, "no MISSION_ACK"
    return ack


def upload(lk: RawLink, items: list, mission_type: int = MISSION):
    """Full upload as MAVSDK does it; returns the final MISSION_ACK."""
    lk.send(mavlink2.MAVLink_mission_count_message(1, 1, len(items), mission_type))
    for item in items:
        assert lk.wait_for(is_request(item.seq, mission_type), 10) is not None, item.seq
        lk.send(item)
    return mission_ack(lk, mission_type)


# --- mission protocol --------------------------------------------------------------------------


def test_upload_requests_items_in_order_with_request_int_and_acks(link):
    """COUNT -> REQUEST_INT 0..n-1 (to the sender, its mission_type) -> ACK ACCEPTED; reads back."""
    ack = upload(link, [waypoint(i) for i in range(3)])
    assert ack.type == mavlink2.MAV_MISSION_ACCEPTED
    assert (ack.target_system, ack.target_component) == (245, 190)
    assert [i.x for i in download_items(link, MISSION)] == [waypoint(i).x for i in range(3)]


def test_silent_uploader_is_re_asked_then_abandoned_without_ack(link):
    """No item after COUNT: REQUEST_INT 0 is repeated, then "Operation timeout", no MISSION_ACK."""
    link.send(mavlink2.MAVLink_mission_count_message(1, 1, 2, MISSION))
    first = link.wait_for(is_request(0), 10)
    again = link.wait_for(is_request(0), 10)
    assert first is not None and again is not None, "REQUEST_INT 0 not repeated"
    # The protocol's timeout is PX4's 5 wall seconds (20 simulated s at SPEED 4, fewer when the
    # simulation runs slower): 60 simulated s cover it at any pace up to SPEED.
    timeout = link.wait_for(
        lambda m: m.get_type() == "STATUSTEXT" and "Operation timeout" in m.text, 60
    )
    assert timeout is not None
    assert not [m for m in link.inbox if m.get_type() == "MISSION_ACK"]
    # The vehicle is free again: a new upload goes through.
    assert upload(link, [waypoint(0)]).type == mavlink2.MAV_MISSION_ACCEPTED


def test_out_of_sequence_item_is_ignored_and_the_expected_one_asked_again(link):
    """Item 1 sent when 0 is expected: no ACK, REQUEST_INT 0 again; the transfer then completes."""
    link.send(mavlink2.MAVLink_mission_count_message(1, 1, 2, MISSION))
    assert link.wait_for(is_request(0), 10) is not None
    link.send(waypoint(1))
    assert link.wait_for(is_request(0), 10) is not None
    link.send(waypoint(0))
    assert link.wait_for(is_request(1), 10) is not None
    link.send(waypoint(1))
    assert mission_ack(link).type == mavlink2.MAV_MISSION_ACCEPTED


def test_second_uploader_is_refused_while_busy_and_the_first_completes(link, other_link):
    """Another GCS's COUNT during a transfer: MISSION_ACK ERROR to it; the first one finishes."""
    link.send(mavlink2.MAVLink_mission_count_message(1, 1, 1, MISSION))
    assert link.wait_for(is_request(0), 10) is not None
    other_link.send(mavlink2.MAVLink_mission_count_message(1, 1, 1, MISSION))
    nack = other_link.wait_for(lambda m: m.get_type() == "MISSION_ACK", 10)
    assert nack is not None and nack.type == mavlink2.MAV_MISSION_ERROR
    assert (nack.target_system, nack.target_component) == (246, 190)
    link.send(waypoint(0))
    assert mission_ack(link).type == mavlink2.MAV_MISSION_ACCEPTED


def test_final_item_sent_again_after_a_lost_ack_is_acked_again(link):
    """MAVSDK resends the last item when the ACK is lost: the vehicle ACKs it again."""
    assert upload(link, [waypoint(0)]).type == mavlink2.MAV_MISSION_ACCEPTED
    link.send(waypoint(0))
    assert mission_ack(link).type == mavlink2.MAV_MISSION_ACCEPTED


@pytest.mark.parametrize(
    ("message", "result"),
    [
        (mavlink2.MAVLink_mission_count_message(1, 1, 1, 7), mavlink2.MAV_MISSION_INVALID),
        (mavlink2.MAVLink_mission_count_message(1, 1, 60000, MISSION),
         mavlink2.MAV_MISSION_NO_SPACE),
        (mavlink2.MAVLink_mission_request_int_message(1, 1, 999, MISSION),
         mavlink2.MAV_MISSION_ERROR),
        (mavlink2.MAVLink_mission_request_list_message(1, 1, 7), mavlink2.MAV_MISSION_INVALID),
    ],
    ids=["count-unknown-type", "count-no-space", "request-past-the-end", "list-unknown-type"],
)  # fmt: skip
def test_refusals_are_nacked_with_px4_results(link, message, result):
    link.send(message)
    ack = link.wait_for(lambda m: m.get_type() == "MISSION_ACK", 10)
    assert ack is not None, "no MISSION_ACK"
    assert ack.type == result
    assert (ack.target_system, ack.target_component) == (245, 190)


def test_bad_item_aborts_the_upload_and_keeps_the_stored_plan(link):
    """A waypoint in a local frame: NACK UNSUPPORTED_FRAME; the previous mission is still there."""
    assert upload(link, [waypoint(0), waypoint(1)]).type == mavlink2.MAV_MISSION_ACCEPTED
    link.send(mavlink2.MAVLink_mission_count_message(1, 1, 2, MISSION))
    assert link.wait_for(is_request(0), 10) is not None
    link.send(waypoint(0, frame=mavlink2.MAV_FRAME_LOCAL_NED))
    assert mission_ack(link).type == mavlink2.MAV_MISSION_UNSUPPORTED_FRAME
    assert len(download_items(link, MISSION)) == 2


def test_count_zero_clears_and_clear_all_of_type_all_clears_every_plan(link):
    """COUNT 0 empties one plan; MISSION_CLEAR_ALL with type ALL empties mission, fence, rally."""
    assert upload(link, [waypoint(0)]).type == mavlink2.MAV_MISSION_ACCEPTED
    link.send(mavlink2.MAVLink_mission_count_message(1, 1, 0, MISSION))
    assert mission_ack(link).type == mavlink2.MAV_MISSION_ACCEPTED
    assert download_items(link, MISSION) == []
    assert upload(link, [waypoint(0)]).type == mavlink2.MAV_MISSION_ACCEPTED
    assert upload(link, [waypoint(0, RALLY)], RALLY).type == mavlink2.MAV_MISSION_ACCEPTED
    link.send(mavlink2.MAVLink_mission_clear_all_message(1, 1, mavlink2.MAV_MISSION_TYPE_ALL))
    assert mission_ack(link, mavlink2.MAV_MISSION_TYPE_ALL).type == mavlink2.MAV_MISSION_ACCEPTED
    assert [len(download_items(link, t)) for t in (MISSION, FENCE, RALLY)] == [0, 0, 0]


def test_set_current_reports_mission_current_and_out_of_range_says_not_in_list(link):
    """MISSION_SET_CURRENT 1 -> MISSION_CURRENT seq 1; seq 9 -> STATUSTEXT only (as PX4)."""
    assert upload(link, [waypoint(i) for i in range(3)]).type == mavlink2.MAV_MISSION_ACCEPTED
    mark = len(link.inbox)
    link.send(mavlink2.MAVLink_mission_set_current_message(1, 1, 1))
    current = link.wait_for(lambda m: m.get_type() == "MISSION_CURRENT" and m.seq == 1, 10)
    assert current is not None and current.total == 3
    link.send(mavlink2.MAVLink_mission_set_current_message(1, 1, 9))
    text = link.wait_for(lambda m: m.get_type() == "STATUSTEXT" and "Not in list" in m.text, 10)
    assert text is not None
    assert not [m for m in link.inbox[mark:] if m.get_type() == "MISSION_ACK"]


# --- parameter protocol ------------------------------------------------------------------------


def test_param_read_by_index_and_unknown_index(link):
    """PARAM_REQUEST_READ by index (MAVSDK's re-request in get_all_params); past the end: error."""
    link.send(mavlink2.MAVLink_param_request_read_message(1, 1, b"", 3))
    value = link.wait_for(lambda m: m.get_type() == "PARAM_VALUE" and m.param_index == 3, 10)
    assert value is not None
    link.send(mavlink2.MAVLink_param_request_read_message(1, 1, b"", value.param_count))
    error = link.wait_for(lambda m: m.get_type() == "PARAM_ERROR", 10)
    assert error is not None and error.error == mavlink2.MAV_PARAM_ERROR_DOES_NOT_EXIST


def test_param_request_list_sends_every_index_once_with_the_count(link):
    link.send(mavlink2.MAVLink_param_request_list_message(1, 1))
    first = link.wait_for(lambda m: m.get_type() == "PARAM_VALUE", 10)
    assert first is not None
    seen = {first.param_index}
    while len(seen) < first.param_count:
        msg = link.wait_for(lambda m: m.get_type() == "PARAM_VALUE", 10)
        assert msg is not None, f"list stopped at {len(seen)} of {first.param_count}"
        assert msg.param_count == first.param_count
        seen.add(msg.param_index)
    assert seen == set(range(first.param_count))


def test_param_set_with_the_wrong_type_is_a_type_mismatch(link):
    """PARAM_SET of INT32 NAV_RCL_ACT as REAL32: PARAM_ERROR TYPE_MISMATCH, value unchanged."""
    real32 = mavlink2.MAV_PARAM_TYPE_REAL32
    link.send(mavlink2.MAVLink_param_set_message(1, 1, b"NAV_RCL_ACT", 3.0, real32))
    error = link.wait_for(lambda m: m.get_type() == "PARAM_ERROR", 10)
    assert error is not None and error.error == PARAM_ERROR_TYPE_MISMATCH
    link.send(mavlink2.MAVLink_param_request_read_message(1, 1, b"NAV_RCL_ACT", -1))
    value = link.wait_for(lambda m: m.get_type() == "PARAM_VALUE", 10)
    assert struct.unpack("<i", struct.pack("<f", value.param_value))[0] == 2


# --- command protocol --------------------------------------------------------------------------


def test_refused_command_is_executed_again_when_repeated(link):
    """TAKEOFF while disarmed twice: DENIED twice, each with its own refusal (no cached ACK)."""
    frame = link.pack(command_long(mavlink2.MAV_CMD_NAV_TAKEOFF))
    for _ in range(2):
        link.send_raw(frame)
        ack = link.wait_for(
            lambda m: m.get_type() == "COMMAND_ACK" and m.command == mavlink2.MAV_CMD_NAV_TAKEOFF,
            10,
        )
        assert ack is not None and ack.result == mavlink2.MAV_RESULT_DENIED
    link.heartbeats(2)
    texts = [m.text for m in link.inbox if m.get_type() == "STATUSTEXT" and "Takeoff" in m.text]
    assert len(texts) == 2, texts


def test_command_int_unknown_is_unsupported(link):
    """COMMAND_INT of an undefined command: UNSUPPORTED, like COMMAND_LONG."""
    link.send(mavlink2.MAVLink_command_int_message(1, 1, 0, 40150, 0, 0, 0, 0, 0, 0, 0, 0, 0))
    ack = link.wait_for(lambda m: m.get_type() == "COMMAND_ACK" and m.command == 40150, 10)
    assert ack is not None and ack.result == mavlink2.MAV_RESULT_UNSUPPORTED
