"""The handler table of one MAVLink link: which part answers each message id it receives.

One protocol, one small object: commands (:mod:`~autopilot_emu.mavlink.command_handler`),
parameters, missions and FTP (behind :class:`ProtocolHandlers`, which adds PX4's target check and
tells the endpoint when it has work), offboard setpoints, external vision, and HEARTBEAT / PING /
TIMESYNC (:mod:`~autopilot_emu.mavlink.presence`).
"""

from __future__ import annotations

from collections.abc import Callable

from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink.command_handler import CommandHandler
from autopilot_emu.mavlink.emission import Emitter
from autopilot_emu.mavlink.forwarding import addressed_to
from autopilot_emu.mavlink.ftp import FtpServer
from autopilot_emu.mavlink.inbound import Handler
from autopilot_emu.mavlink.link_hub import LinkHub
from autopilot_emu.mavlink.mission_protocol import MissionProtocol
from autopilot_emu.mavlink.param_protocol import ParamProtocol
from autopilot_emu.mavlink.presence import PresenceHandler
from autopilot_emu.mavlink.vehicle_port import VehiclePort

MissionHandler = Callable[[mavlink2.MAVLink_message, tuple[int, int]], None]


class ProtocolHandlers:
    """The parameter, mission and FTP protocols of one link, for messages addressed to us.

    Args:
        sysid: our system id.
        compid: our component id.
        vehicle: whose parameters a PARAM_SET changes (announced on the other links too).
        hub: the vehicle's shared side; ``cursor`` is this link's.
        param_protocol: answers the parameter messages.
        missions: answers the mission messages.
        ftp: answers FILE_TRANSFER_PROTOCOL; None: not served.
        emitter: sends MISSION_CURRENT after MISSION_SET_CURRENT.
        wake: the endpoint works at every poll until it reschedules (a parameter list is sent).
        reschedule: the endpoint recomputes when it next has work.
    """

    def __init__(
        self,
        sysid: int,
        compid: int,
        vehicle: VehiclePort,
        hub: LinkHub,
        cursor: int,
        param_protocol: ParamProtocol,
        missions: MissionProtocol,
        ftp: FtpServer | None,
        emitter: Emitter,
        wake: Callable[[], None],
        reschedule: Callable[[], None],
    ) -> None:
        self._sysid = sysid
        self._compid = compid
        self._vehicle = vehicle
        self._hub = hub
        self._cursor = cursor
        self._params = param_protocol
        self._missions = missions
        self._ftp = ftp
        self._emitter = emitter
        self._wake = wake
        self._reschedule = reschedule

    def _targets_us(self, target_system: int, target_component: int) -> bool:
        return addressed_to(target_system, target_component, self._sysid, self._compid)

    def on_param_request_list(self, msg: mavlink2.MAVLink_message) -> None:
        """PARAM_REQUEST_LIST: start the list (a batch per poll from now)."""
        if self._targets_us(msg.target_system, msg.target_component):
            self._params.handle_request_list()
            self._wake()

    def on_param_request_read(self, msg: mavlink2.MAVLink_message) -> None:
        """PARAM_REQUEST_READ."""
        if self._targets_us(msg.target_system, msg.target_component):
            self._params.handle_request_read(msg)

    def on_param_set(self, msg: mavlink2.MAVLink_message) -> None:
        """PARAM_SET; a parameter it changed is announced on the vehicle's other links too."""
        if self._targets_us(msg.target_system, msg.target_component):
            version = self._vehicle.params.version
            self._params.handle_set(msg)
            if self._vehicle.params.version != version:
                self._hub.param_changed(self._cursor, msg.param_id)

    def on_mission(self, handler: MissionHandler) -> Handler:
        """Wrap a MissionProtocol handler: check the target, pass the sender's ids."""

        def handle(msg: mavlink2.MAVLink_message) -> None:
            if self._targets_us(msg.target_system, msg.target_component):
                handler(msg, (msg.get_srcSystem(), msg.get_srcComponent()))
                self._reschedule()

        return handle

    def on_mission_set_current(self, msg: mavlink2.MAVLink_message) -> None:
        """MISSION_SET_CURRENT, then MISSION_CURRENT whether or not it changed."""
        if self._targets_us(msg.target_system, msg.target_component):
            self._missions.handle_set_current(msg)
            self._emitter.mission_events((), force_current=True)

    def on_ftp(self, msg: mavlink2.MAVLink_message) -> None:
        """FILE_TRANSFER_PROTOCOL, when FTP is served."""
        if self._ftp is not None and self._targets_us(msg.target_system, msg.target_component):
            self._ftp.handle(msg)


def handler_table(
    protocols: ProtocolHandlers,
    missions: MissionProtocol,
    commands: CommandHandler,
    presence: PresenceHandler,
    setpoint: Handler,
    vision: Handler,
) -> dict[int, Handler]:
    """Message id -> what handles it on one link."""
    m, on_mission = mavlink2, protocols.on_mission
    return {
        m.MAVLINK_MSG_ID_HEARTBEAT: presence.on_heartbeat,
        m.MAVLINK_MSG_ID_MISSION_COUNT: on_mission(missions.handle_count),
        m.MAVLINK_MSG_ID_MISSION_ITEM_INT: on_mission(missions.handle_item),
        m.MAVLINK_MSG_ID_MISSION_ITEM: on_mission(missions.handle_item),
        m.MAVLINK_MSG_ID_MISSION_REQUEST_LIST: on_mission(missions.handle_request_list),
        m.MAVLINK_MSG_ID_MISSION_REQUEST_INT: on_mission(missions.handle_request),
        m.MAVLINK_MSG_ID_MISSION_REQUEST: on_mission(missions.handle_request),
        m.MAVLINK_MSG_ID_MISSION_CLEAR_ALL: on_mission(missions.handle_clear_all),
        m.MAVLINK_MSG_ID_MISSION_SET_CURRENT: protocols.on_mission_set_current,
        m.MAVLINK_MSG_ID_COMMAND_LONG: commands.handle,
        m.MAVLINK_MSG_ID_COMMAND_INT: commands.handle,
        m.MAVLINK_MSG_ID_PARAM_REQUEST_LIST: protocols.on_param_request_list,
        m.MAVLINK_MSG_ID_PARAM_REQUEST_READ: protocols.on_param_request_read,
        m.MAVLINK_MSG_ID_PARAM_SET: protocols.on_param_set,
        m.MAVLINK_MSG_ID_PING: presence.on_ping,
        m.MAVLINK_MSG_ID_TIMESYNC: presence.on_timesync,
        m.MAVLINK_MSG_ID_SET_POSITION_TARGET_LOCAL_NED: setpoint,
        m.MAVLINK_MSG_ID_SET_POSITION_TARGET_GLOBAL_INT: setpoint,
        m.MAVLINK_MSG_ID_SET_ATTITUDE_TARGET: setpoint,
        m.MAVLINK_MSG_ID_FILE_TRANSFER_PROTOCOL: protocols.on_ftp,
        m.MAVLINK_MSG_ID_VISION_POSITION_ESTIMATE: vision,
        m.MAVLINK_MSG_ID_ODOMETRY: vision,
    }
