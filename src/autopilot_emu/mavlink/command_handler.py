"""COMMAND_LONG / COMMAND_INT on one MAVLink link: which to execute, the ACK, what follows it.

:class:`CommandHandler` decides, as PX4's ``evaluate_target_ok``, whether a command is this
autopilot's to answer; the :class:`~autopilot_emu.mavlink.commands.CommandDispatcher` executes
it; the COMMAND_ACK goes back to the address the command came from alone, and the messages a
request asked for follow it on every peer. It is also the dispatcher's view of the link
(:class:`~autopilot_emu.mavlink.commands.CommandServices`): message requests and stream
intervals.
"""

from __future__ import annotations

from collections.abc import Callable

from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink import messages
from autopilot_emu.mavlink.commands import (
    ACCEPTED,
    DENIED,
    CommandDispatcher,
    CommandRequest,
)
from autopilot_emu.mavlink.distance_sensor import latest_messages
from autopilot_emu.mavlink.emission import Emitter
from autopilot_emu.mavlink.endpoint_config import EndpointConfig, EndpointStats
from autopilot_emu.mavlink.inbound import Receiver
from autopilot_emu.mavlink.link_clock import LinkClock
from autopilot_emu.mavlink.streams import StreamScheduler
from autopilot_emu.mavlink.transmit import Transmitter
from autopilot_emu.mavlink.vehicle_port import VehiclePort

ANY_COMPONENT_COMMANDS = frozenset(
    {mavlink2.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, mavlink2.MAV_CMD_REQUEST_PROTOCOL_VERSION}
)
"""Commands PX4 answers whatever their target component (evaluate_target_ok)."""
_DISTANCE_SENSOR = mavlink2.MAVLINK_MSG_ID_DISTANCE_SENSOR
_MISSION_CURRENT = mavlink2.MAVLINK_MSG_ID_MISSION_CURRENT


class CommandHandler:
    """Answers the commands of one link.

    Args:
        vehicle: the flight stack the commands act on.
        config: the link's ids.
        wall_clock_s: monotonic clock of the retransmission window.
        rx: the receiver (the command's sender, whether the frame was forwarded).
        tx: where the ACK and the replies go.
        emitter: builds requested messages and sends STATUSTEXT.
        streams: the link's streams (SET/GET_MESSAGE_INTERVAL).
        reschedule: the endpoint recomputes when it next has work (a stream interval changed).
        stats: the link's counters.
        clock: simulation time of the poll.
    """

    def __init__(
        self,
        vehicle: VehiclePort,
        config: EndpointConfig,
        wall_clock_s: Callable[[], float],
        rx: Receiver,
        tx: Transmitter,
        emitter: Emitter,
        streams: StreamScheduler,
        reschedule: Callable[[], None],
        stats: EndpointStats,
        clock: LinkClock,
    ) -> None:
        self._sysid = config.sysid
        self._compid = config.compid
        self._rx = rx
        self._tx = tx
        self._emitter = emitter
        self._streams = streams
        self._reschedule = reschedule
        self._stats = stats
        self._clock = clock
        self._replies: list[mavlink2.MAVLink_message] = []
        """Messages a request asked for, sent after its ACK."""
        self._dispatcher = CommandDispatcher(vehicle, self, wall_clock_s)

    def _targets_us(self, msg: mavlink2.MAVLink_message) -> bool:
        """Whether to execute and ACK a COMMAND_LONG/INT, after PX4's evaluate_target_ok.

        PX4 (mavlink_receiver.cpp) answers the autopilot-capabilities and protocol-version
        requests for any component of its system, every other command only when addressed to
        its own component or to all (0). A command for another component that PX4 has never
        seen (e.g. a camera, compid 100, where none is connected) is logged ("Ignore command")
        and left unanswered, never ACKed: PX4 PR #23870 (2024-11) removed the FAILED ACK that
        v1.15 and earlier sent, since the addressed component may answer itself. An ACK from
        us would not help a client anyway: MAVSDK only accepts an ACK whose sender is the
        command's target. Unlike PX4, target_system 0 (broadcast) is accepted, as before.
        Commands for another system are ignored.
        """
        if msg.target_system not in (0, self._sysid):
            return False
        return msg.command in ANY_COMPONENT_COMMANDS or msg.target_component in (0, self._compid)

    def handle(self, msg: mavlink2.MAVLink_message) -> None:
        """A COMMAND_LONG or COMMAND_INT: execute it (or answer a retransmission), ACK it."""
        if not self._targets_us(msg):
            if not self._rx.forwarded:
                self._stats.commands_ignored += 1
            return
        self._replies.clear()
        reply = self._dispatcher.handle(CommandRequest.from_message(msg))
        if reply.duplicate:
            self._stats.commands_duplicate += 1
        else:
            self._stats.commands_handled += 1
        self._tx.send(
            mavlink2.MAVLink_command_ack_message(
                command=msg.command,
                result=reply.result,
                progress=0,
                result_param2=0,
                target_system=msg.get_srcSystem(),
                target_component=msg.get_srcComponent(),
            ),
            to=self._rx.sender,
        )
        replies, self._replies = self._replies, []
        for message in replies:
            self._tx.send(message)

    # --- CommandServices (called by the dispatcher) ------------------------------------------

    def request_message(self, msg_id: int) -> int:
        """MAV_CMD_REQUEST_MESSAGE: build ``msg_id`` now, send it after the ACK.

        DISTANCE_SENSOR: the latest reading of every range finder (denied without any).
        """
        if msg_id == _DISTANCE_SENSOR:
            readings = latest_messages(self._emitter.telemetry().distance_sensors)
            self._replies.extend(readings)
            return ACCEPTED if readings else DENIED
        if msg_id not in messages.BUILDERS and msg_id != _MISSION_CURRENT:
            return DENIED
        message = self._emitter.build(msg_id)
        if message is None:
            return DENIED
        self._replies.append(message)
        return ACCEPTED

    def announce(self, severity: int, text: str) -> None:
        """Send ``text`` as STATUSTEXT."""
        self._emitter.announce(severity, text)

    def set_message_interval(self, msg_id: int, interval_us: int) -> int:
        """MAV_CMD_SET_MESSAGE_INTERVAL on one of our streams."""
        now_us = round(self._clock.now_s * 1e6)
        if not self._streams.set_interval(msg_id, interval_us, now_us):
            return DENIED
        self._reschedule()
        return ACCEPTED

    def report_message_interval(self, msg_id: int) -> int:
        """MAV_CMD_GET_MESSAGE_INTERVAL: reply MESSAGE_INTERVAL (0 = not available)."""
        interval_us = self._streams.interval_us(msg_id) if self._streams.knows(msg_id) else 0
        self._replies.append(messages.message_interval(msg_id, interval_us))
        return ACCEPTED

    def home_alt_amsl_m(self) -> float | None:
        """Home altitude AMSL from this poll's snapshot; None without a home."""
        home = self._emitter.telemetry().home
        return None if home is None else home.alt_amsl_m
