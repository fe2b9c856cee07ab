"""Raw pymavlink client (sysid 245, compid 190, as MAVSDK) against a vehicle's listen port.

Checks the command and parameter protocols at the byte level: retransmissions, unknown and
misaddressed commands, NaN and infinite parameters, malformed frames, out-of-range PARAM_SET.
The simulation runs in lockstep, at most :data:`e2e_support.SPEED` x real time. Absence of a reply
is judged
by ordering, not by timing: a later command's ACK proves the earlier datagram was processed.
"""

from __future__ import annotations

import math
import random
import struct

import pytest
from e2e_support import RawLink, command_long, module_ports, running_swarm
from pymavlink.dialects.v20 import common as mavlink2

pytestmark = pytest.mark.e2e

PORTS = module_ports()
ARM = mavlink2.MAV_CMD_COMPONENT_ARM_DISARM
ARMED_FLAG = mavlink2.MAV_MODE_FLAG_SAFETY_ARMED
_KNOWN_COMMANDS = set(mavlink2.enums["MAV_CMD"])
UNKNOWN_COMMANDS = [c for c in range(40100, 40200) if c not in _KNOWN_COMMANDS]
"""Command ids that common.xml does not define."""


@pytest.fixture(scope="module")
def swarm(tmp_path_factory):
    with running_swarm(1, PORTS, tmp_path_factory.mktemp("raw") / "run") as s:
        yield s


@pytest.fixture(scope="module")
def raw(swarm):
    """One raw client socket for the module (the vehicle learns its address once)."""
    lk = RawLink(PORTS.listen, swarm.clock)
    lk.send(mavlink2.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3))  # a GCS heartbeat, as MAVSDK
    yield lk
    lk.close()


@pytest.fixture
def link(raw):
    """The raw client; the vehicle is disarmed and ready to arm when the test starts."""
    raw.drain()
    wait_ready(raw)
    if is_armed(raw):
        disarm(raw)
    raw.drain()
    yield raw
    if is_armed(raw):
        disarm(raw)


def is_ack(command: int):
    def pred(m) -> bool:
        return m.get_type() == "COMMAND_ACK" and m.command == command

    return pred


def acks(msgs: list, command: int) -> list:
    return [m for m in msgs if is_ack(command)(m)]


def is_armed(lk: RawLink) -> bool:
    return bool(lk.heartbeats(1)[0].base_mode & ARMED_FLAG)


def wait_ready(lk: RawLink) -> None:
    """Wait until SYS_STATUS reports GPS and pre-arm checks healthy (MAVSDK's is_armable)."""
    ready = mavlink2.MAV_SYS_STATUS_SENSOR_GPS | mavlink2.MAV_SYS_STATUS_PREARM_CHECK
    msg = lk.wait_for(
        lambda m: (
            m.get_type() == "SYS_STATUS" and m.onboard_control_sensors_health & ready == ready
        ),
        timeout_s=60,
    )
    assert msg is not None, "vehicle never became ready to arm"


def disarm(lk: RawLink) -> None:
    lk.send(command_long(ARM, (0,)))
    ack = lk.wait_for(is_ack(ARM), 10)
    assert ack is not None and ack.result == mavlink2.MAV_RESULT_ACCEPTED, ack
    # Disarmed once a HEARTBEAT says so (the ACK may come before the next HEARTBEAT).
    for _ in range(5):
        if not is_armed(lk):
            return
    pytest.fail("vehicle still armed after an accepted disarm")


def marker(lk: RawLink, command: int):
    """Send an unknown command and return everything received up to and including its ACK."""
    before = len(lk.inbox)
    lk.send(command_long(command, (1, 2, 3)))
    ack = lk.wait_for(is_ack(command), 10)
    assert ack is not None, f"no ACK for marker command {command}"
    return lk.inbox[before:]


def test_duplicate_command_is_acked_twice_but_executed_once(link):
    """The same ARM COMMAND_LONG bytes twice: two ACCEPTED ACKs, one 'Armed by external command'."""
    frame = link.pack(command_long(ARM, (1,)))
    link.send_raw(frame)
    link.send_raw(frame)
    received = marker(link, UNKNOWN_COMMANDS[0])
    arm_acks = acks(received, ARM)
    assert len(arm_acks) == 2, [str(m) for m in arm_acks]
    for ack in arm_acks:
        assert ack.result == mavlink2.MAV_RESULT_ACCEPTED
        # ACK addressed to the sender, sent by the autopilot (MAVSDK's acceptance rules).
        assert (ack.target_system, ack.target_component) == (245, 190)
        assert (ack.get_srcSystem(), ack.get_srcComponent()) == (1, 1)
    beats = link.heartbeats(3)  # three more simulated seconds for the STATUSTEXT to go out
    assert beats[-1].base_mode & ARMED_FLAG
    texts = [
        m.text for m in link.inbox if m.get_type() == "STATUSTEXT" and "Armed by external" in m.text
    ]
    assert len(texts) == 1, texts


def _set_param_float(lk: RawLink, name: str, value: float) -> None:
    lk.send(
        mavlink2.MAVLink_param_set_message(
            1, 1, name.encode(), value, mavlink2.MAV_PARAM_TYPE_REAL32
        )
    )
    reply = _param_reply(lk, name)
    assert reply is not None and reply.get_type() == "PARAM_VALUE", reply
    assert reply.param_value == pytest.approx(value)


def test_identical_command_after_a_state_change_is_executed_again(link):
    """ARM, auto-disarm on the ground, the same ARM bytes again: ACCEPTED means armed again.

    A retransmission must not re-trigger side effects, but once the vehicle has disarmed by
    itself a new ARM is a new request: PX4 arms again; an ACCEPTED ACK without arming would
    make MAVSDK's ``arm()`` succeed on a disarmed vehicle.
    """
    prflt = _param_value(link, "COM_DISARM_PRFLT").param_value
    _set_param_float(link, "COM_DISARM_PRFLT", 0.5)  # auto-disarm 0.5 simulated s after arming
    frame = link.pack(command_long(ARM, (1,)))
    link.send_raw(frame)
    ack = link.wait_for(is_ack(ARM), 10)
    assert ack is not None and ack.result == mavlink2.MAV_RESULT_ACCEPTED
    disarmed = link.wait_for(
        lambda m: m.get_type() == "STATUSTEXT" and m.text.startswith("Disarmed"), 30
    )
    assert disarmed is not None, "no auto-disarm STATUSTEXT"
    _set_param_float(link, "COM_DISARM_PRFLT", prflt)
    link.inbox.clear()
    link.send_raw(frame)
    ack = link.wait_for(is_ack(ARM), 10)
    assert ack is not None and ack.result == mavlink2.MAV_RESULT_ACCEPTED
    assert any(b.base_mode & ARMED_FLAG for b in link.heartbeats(2)), "ACCEPTED but not armed"


def test_unknown_command_is_unsupported(link):
    """A command id common.xml does not define gets MAV_RESULT_UNSUPPORTED (not silence)."""
    command = UNKNOWN_COMMANDS[1]
    link.send(command_long(command, (0, 0, 0, 0, 0, 0, 0)))
    ack = link.wait_for(is_ack(command), 10)
    assert ack is not None
    assert ack.result == mavlink2.MAV_RESULT_UNSUPPORTED


def test_command_for_another_system_is_ignored(link):
    """ARM addressed to system 2 gets no ACK from system 1 and does not arm it."""
    link.send(command_long(ARM, (1,), target_system=2))
    received = marker(link, UNKNOWN_COMMANDS[2])
    assert acks(received, ARM) == []
    assert not any(m.base_mode & ARMED_FLAG for m in link.heartbeats(2))
    texts = [m.text for m in link.inbox if m.get_type() == "STATUSTEXT"]
    assert not any("Armed" in t for t in texts), texts


def test_command_for_another_component_is_ignored(link):
    """ARM addressed to component 100 (a camera) of system 1 is not answered by the autopilot."""
    link.send(command_long(ARM, (1,), target_component=100))
    received = marker(link, UNKNOWN_COMMANDS[3])
    assert acks(received, ARM) == []
    assert not is_armed(link)


@pytest.mark.parametrize(
    ("command", "params"),
    [
        (ARM, (math.nan,)),  # arm flag required
        (ARM, (math.inf,)),
        (mavlink2.MAV_CMD_DO_SET_MODE, (1, math.nan, 3)),  # main mode required
        (mavlink2.MAV_CMD_DO_SET_MODE, (math.nan, 4, 3)),  # base mode required
        (mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL, (math.nan, 1e5)),  # message id required
        (mavlink2.MAV_CMD_REQUEST_MESSAGE, (math.nan,)),
    ],
    ids=["arm-nan", "arm-inf", "mode-main-nan", "mode-base-nan", "interval-nan", "request-nan"],
)
def test_nan_where_a_number_is_required_is_denied(link, command, params):
    """NaN/inf in a required parameter -> DENIED; the vehicle stays disarmed and keeps streaming."""
    link.send(command_long(command, params))
    ack = link.wait_for(is_ack(command), 10)
    assert ack is not None, "no ACK"
    assert ack.result == mavlink2.MAV_RESULT_DENIED
    beats = link.heartbeats(2)
    assert not any(b.base_mode & ARMED_FLAG for b in beats)
    assert [b.custom_mode for b in beats] == [beats[0].custom_mode] * 2  # mode unchanged


def test_nan_in_reposition_and_change_speed_is_answered(link):
    """DO_REPOSITION (COMMAND_INT) with NaN/inf and DO_CHANGE_SPEED NaN are ACKed; streams go on."""
    nan_speed = command_long(mavlink2.MAV_CMD_DO_CHANGE_SPEED, (1, math.nan, -1, 0))
    link.send(nan_speed)
    assert link.wait_for(is_ack(mavlink2.MAV_CMD_DO_CHANGE_SPEED), 10) is not None
    reposition = mavlink2.MAVLink_command_int_message(
        1, 1, mavlink2.MAV_FRAME_GLOBAL_INT, mavlink2.MAV_CMD_DO_REPOSITION, 0, 0,
        math.inf, 1, math.nan, math.nan, 473977420, 85455940, math.nan,
    )  # fmt: skip
    link.send(reposition)
    ack = link.wait_for(is_ack(mavlink2.MAV_CMD_DO_REPOSITION), 10)
    assert ack is not None
    assert ack.result == mavlink2.MAV_RESULT_DENIED  # speed = +inf is not "unset"
    assert len(link.heartbeats(3)) == 3


def test_malformed_frames_do_not_stop_the_vehicle(link):
    """Random bytes, a truncated frame and a bad-CRC frame are dropped; the next command works."""
    rng = random.Random(1234)
    link.send_raw(bytes(rng.randrange(256) for _ in range(200)))
    link.send_raw(b"\xfd")  # a lone start byte
    truncated_cmd, bad_crc_cmd, good_cmd, glued_cmd = UNKNOWN_COMMANDS[4:8]
    frame = link.pack(command_long(truncated_cmd, (1,)))
    link.send_raw(frame[: len(frame) // 2])
    frame = bytearray(link.pack(command_long(bad_crc_cmd, (1,))))
    frame[-1] ^= 0xFF
    link.send_raw(bytes(frame))
    received = marker(link, good_cmd)
    assert acks(received, truncated_cmd) == []
    assert acks(received, bad_crc_cmd) == []
    # Garbage before a valid frame in the same datagram: a MAVLink parser resynchronises.
    link.send_raw(bytes(rng.randrange(256) for _ in range(40)).replace(b"\xfd", b"\x00")
                  + link.pack(command_long(glued_cmd, (1,))))  # fmt: skip
    ack = link.wait_for(is_ack(glued_cmd), 10)
    assert ack is not None, "valid frame after garbage in one datagram was not answered"
    assert ack.result == mavlink2.MAV_RESULT_UNSUPPORTED
    assert len(link.heartbeats(2)) == 2


def _param_value(lk: RawLink, name: str):
    lk.send(mavlink2.MAVLink_param_request_read_message(1, 1, name.encode(), -1))
    msg = lk.wait_for(lambda m: m.get_type() == "PARAM_VALUE" and m.param_id == name, 10)
    assert msg is not None, f"no PARAM_VALUE for {name}"
    return msg


def _int_value(msg) -> int:
    return struct.unpack("<i", struct.pack("<f", msg.param_value))[0]


def _param_reply(lk: RawLink, name: str):
    return lk.wait_for(
        lambda m: m.get_type() in ("PARAM_VALUE", "PARAM_ERROR") and m.param_id == name, 10
    )


@pytest.mark.parametrize("bad", [1000.0, -5.0, math.nan, math.inf])
def test_param_set_out_of_range_float_is_rejected(link, bad):
    """PARAM_SET MIS_TAKEOFF_ALT out of its range (or non-finite) -> PARAM_ERROR or unchanged."""
    before = _param_value(link, "MIS_TAKEOFF_ALT").param_value
    link.send(
        mavlink2.MAVLink_param_set_message(
            1, 1, b"MIS_TAKEOFF_ALT", bad, mavlink2.MAV_PARAM_TYPE_REAL32
        )
    )
    reply = _param_reply(link, "MIS_TAKEOFF_ALT")
    assert reply is not None, "PARAM_SET got neither PARAM_VALUE nor PARAM_ERROR"
    if reply.get_type() == "PARAM_ERROR":
        assert reply.error == mavlink2.MAV_PARAM_ERROR_VALUE_OUT_OF_RANGE
        assert (reply.target_system, reply.target_component) == (245, 190)
    else:
        assert reply.param_value == before
    assert _param_value(link, "MIS_TAKEOFF_ALT").param_value == before


def test_param_set_out_of_range_int_is_rejected(link):
    """PARAM_SET NAV_RCL_ACT = 99 (INT32 bytewise, max 6) -> PARAM_ERROR or unchanged."""
    before = _int_value(_param_value(link, "NAV_RCL_ACT"))
    raw = struct.unpack("<f", struct.pack("<i", 99))[0]
    link.send(
        mavlink2.MAVLink_param_set_message(1, 1, b"NAV_RCL_ACT", raw, mavlink2.MAV_PARAM_TYPE_INT32)
    )
    reply = _param_reply(link, "NAV_RCL_ACT")
    assert reply is not None
    if reply.get_type() == "PARAM_ERROR":
        assert reply.error == mavlink2.MAV_PARAM_ERROR_VALUE_OUT_OF_RANGE
    else:
        assert _int_value(reply) == before
    assert _int_value(_param_value(link, "NAV_RCL_ACT")) == before


def test_param_set_unknown_name_is_an_error(link):
    """PARAM_SET of a name the vehicle does not have -> PARAM_ERROR DOES_NOT_EXIST (or silence)."""
    link.send(
        mavlink2.MAVLink_param_set_message(
            1, 1, b"NO_SUCH_PARAM", 1.0, mavlink2.MAV_PARAM_TYPE_REAL32
        )
    )
    reply = _param_reply(link, "NO_SUCH_PARAM")
    if reply is not None:
        assert reply.get_type() == "PARAM_ERROR"
        assert reply.error == mavlink2.MAV_PARAM_ERROR_DOES_NOT_EXIST
    # Still answering parameter reads.
    assert _param_value(link, "MIS_TAKEOFF_ALT") is not None
