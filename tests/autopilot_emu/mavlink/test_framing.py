"""MAVLink 2 framing: byte for byte what pymavlink's own ``pack`` produces."""

from __future__ import annotations

import pytest
from mavlink_fakes import EPOCH_START_S, make_snapshot
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink import framing, messages
from autopilot_emu.params import ParamStore

CONTEXT = messages.MessageContext(
    sysid=7, params=ParamStore(), epoch_start_us=round(EPOCH_START_S * 1e6)
)


def _pymavlink_frame(message, seq: int, sysid: int, compid: int) -> bytes:
    mav = mavlink2.MAVLink(None, srcSystem=sysid, srcComponent=compid)
    mav.seq = seq
    return message.pack(mav)


def _every_message():
    snapshot = make_snapshot()
    built = [build(snapshot, CONTEXT) for build in messages.BUILDERS.values()]
    built += messages.statustext_chunks(4, "a text of more than fifty bytes, sent in chunks", 3)
    built += [
        messages.mission_current(2, 5, mavlink2.MISSION_STATE_ACTIVE),
        mavlink2.MAVLink_command_ack_message(400, 0, 0, 0, 245, 190),
        mavlink2.MAVLink_param_value_message(b"MPC_XY_CRUISE", 5.0, 9, 900, 12),
        mavlink2.MAVLink_attitude_target_message(5, 0, (1.0, 0.0, 0.0, 0.0), 0.0, 0.0, 0.0, 0.5),
        mavlink2.MAVLink_heartbeat_message(0, 0, 0, 0, 0, 0),  # all-zero payload: one byte kept
        mavlink2.MAVLink_file_transfer_protocol_message(0, 255, 190, bytes(range(251))),
    ]
    return built


@pytest.mark.parametrize("message", _every_message(), ids=lambda m: m.get_type())
@pytest.mark.parametrize(("seq", "sysid", "compid"), [(0, 1, 1), (255, 7, 1), (13, 255, 190)])
def test_frame_matches_pymavlink(message, seq, sysid, compid):
    frame = framing.encode(message, seq, sysid, compid)
    assert frame == _pymavlink_frame(message, seq, sysid, compid)
    (parsed,) = mavlink2.MAVLink(None).parse_buffer(frame)
    assert parsed.get_type() == message.get_type()
    assert (parsed.get_seq(), parsed.get_srcSystem()) == (seq, sysid)
