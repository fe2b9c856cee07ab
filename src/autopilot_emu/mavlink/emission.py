"""What one MAVLink link sends of its own accord: telemetry streams and the vehicle's announcements.

The streams go out at their profile's rates (:mod:`autopilot_emu.mavlink.streams`), each message
built from the poll's telemetry snapshot only when due; the hot ones are packed from their field
values without pymavlink objects (``messages.FIELDS``). With a data-rate limit the rates are
scaled down together to fit it, as PX4 does on a serial link. The announcements are what the
vehicle says once and every link forwards (:class:`~autopilot_emu.mavlink.link_hub.LinkHub`):
status texts, mission items reached and the current item, commands for the vehicle's other
components, and parameters another link changed.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable

from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink import framing, messages
from autopilot_emu.mavlink.distance_sensor import DistanceSensorForwarder
from autopilot_emu.mavlink.endpoint_config import EndpointStats
from autopilot_emu.mavlink.link_clock import LinkClock
from autopilot_emu.mavlink.link_hub import LinkHub
from autopilot_emu.mavlink.streams import STREAMABLE, StreamScheduler, StreamSpec
from autopilot_emu.mavlink.transmit import Transmitter
from autopilot_emu.mavlink.vehicle_port import TelemetrySnapshot
from autopilot_emu.mission.camera_items import ComponentCommand

logger = logging.getLogger(__name__)

MAVLINK2_NON_PAYLOAD_BYTES = 12
"""Header (10) and checksum (2) of an unsigned MAVLink 2 frame."""

_MAX_FRAME_BYTES: dict[int, float] = {
    msg_id: float(mavlink2.mavlink_map[msg_id].unpacker.size + MAVLINK2_NON_PAYLOAD_BYTES)
    for msg_id in (getattr(mavlink2, f"MAVLINK_MSG_ID_{name}") for name in STREAMABLE)
}
"""Bytes of each stream's frame with its full payload (PX4's size before it has averages)."""

_FAST_STREAMS: dict[int, tuple[messages.FieldsBuilder, framing.FieldsFormat]] = {
    msg_id: (fields, framing.fields_format(msg_id)) for msg_id, fields in messages.FIELDS.items()
}
"""The hot streams: packed from their field values, without pymavlink objects."""

_HEARTBEAT = mavlink2.MAVLINK_MSG_ID_HEARTBEAT
_MISSION_CURRENT = mavlink2.MAVLINK_MSG_ID_MISSION_CURRENT
_DISTANCE_SENSOR = mavlink2.MAVLINK_MSG_ID_DISTANCE_SENSOR


class Emitter:
    """Builds and sends one link's streams and forwards the vehicle's announcements.

    Args:
        hub: the vehicle's shared side (telemetry snapshot, announcements).
        cursor: this link's cursor in the hub.
        streams: the link's stream schedule.
        tx: where frames go.
        context: what message builders need besides the snapshot.
        param_value: PARAM_VALUE of a parameter (for those another link changed).
        datarate_bytes_s: the link's data-rate limit, B/s (0: none).
        stats: the link's counters.
        clock: simulation time of the poll.
        wall_clock_s: monotonic wall clock (time of the last own HEARTBEAT).
    """

    def __init__(
        self,
        hub: LinkHub,
        cursor: int,
        streams: StreamScheduler,
        tx: Transmitter,
        context: messages.MessageContext,
        param_value: Callable[[str], mavlink2.MAVLink_message],
        datarate_bytes_s: float,
        stats: EndpointStats,
        clock: LinkClock,
        wall_clock_s: Callable[[], float],
    ) -> None:
        self._hub = hub
        self._vehicle = hub.vehicle
        self._cursor = cursor
        self._streams = streams
        self._tx = tx
        self._context = context
        self._param_value = param_value
        self._datarate_bytes_s = datarate_bytes_s
        self._stats = stats
        self._clock = clock
        self._wall_clock_s = wall_clock_s
        self._distance_sensors = DistanceSensorForwarder()
        self._emission_bytes: dict[int, float] = {}
        """Running average of the bytes one emission of each stream took."""
        self._statustext_id = 0
        self._mission_status: tuple[int, int, int] | None = None
        self.heartbeat_wall_s = -float("inf")
        """Wall time of this link's last own HEARTBEAT (``MavlinkEndpoint.keep_alive``)."""

    def telemetry(self) -> TelemetrySnapshot:
        """The vehicle's snapshot for this poll (read once per poll for all its links)."""
        return self._hub.telemetry(self._clock.now_us)

    # --- streams -----------------------------------------------------------------------------

    def emit_streams(self, due: list[StreamSpec]) -> None:
        """Send the due streams in order; the hot ones packed from one snapshot read for all."""
        if self._datarate_bytes_s > 0:  # every emission's bytes are averaged
            for spec in due:
                self.emit(spec.msg_id)
            return
        snapshot = None
        context = self._context
        send_fields = self._tx.send_fields
        for spec in due:
            msg_id = spec.msg_id
            fast = _FAST_STREAMS.get(msg_id)
            if fast is None or msg_id == _HEARTBEAT:
                self.emit(msg_id)
                continue
            if snapshot is None:
                snapshot = self.telemetry()
            fields, fmt = fast
            try:
                values = fields(snapshot, context)
            except Exception:
                self._stats.encode_errors += 1
                logger.exception("cannot build message %d", msg_id)
                continue
            if values is not None:
                send_fields(msg_id, fmt, values)

    def emit(self, msg_id: int) -> None:
        """Build and send one emission of stream ``msg_id`` (its bytes averaged under a limit)."""
        tx = self._tx
        before = tx.bytes_out
        if msg_id == _HEARTBEAT:
            self.heartbeat_wall_s = self._wall_clock_s()
        fast = _FAST_STREAMS.get(msg_id)
        if fast is not None:
            fields, fmt = fast
            try:
                values = fields(self.telemetry(), self._context)
            except Exception:
                self._stats.encode_errors += 1
                logger.exception("cannot build message %d", msg_id)
                values = None
            if values is not None:
                tx.send_fields(msg_id, fmt, values)
        elif msg_id == _DISTANCE_SENSOR:
            for reading in self._distance_sensors.new_messages(self.telemetry().distance_sensors):
                tx.send(reading)
        else:
            message = self.build(msg_id)
            if message is not None:
                tx.send(message)
        sent = tx.bytes_out - before
        if sent > 0 and self._datarate_bytes_s > 0:
            average = self._emission_bytes.get(msg_id)
            self._emission_bytes[msg_id] = sent if average is None else 0.9 * average + 0.1 * sent

    def build(self, msg_id: int) -> mavlink2.MAVLink_message | None:
        """Build message ``msg_id`` from this poll's snapshot (None: nothing to report).

        An exception from ``vehicle.telemetry()`` propagates (a flight-stack bug); one from
        building the message is counted in ``stats.encode_errors`` and logged.
        """
        if msg_id == _MISSION_CURRENT:
            return messages.mission_current(*self._vehicle.mission_status())
        snapshot = self.telemetry()
        try:
            return messages.BUILDERS[msg_id](snapshot, self._context)
        except Exception:
            self._stats.encode_errors += 1
            logger.exception("cannot build message %d", msg_id)
            return None

    def update_rate_mult(self, now_us: int) -> None:
        """Fit the streams into the data-rate limit (PX4's ``Mavlink::update_rate_mult``).

        A stream's load is its bytes per emission (a running average of what was sent; before
        its first emission the largest frame of its message) times its configured rate.
        """
        sizes = _MAX_FRAME_BYTES | self._emission_bytes
        const, scaled = self._streams.bytes_per_s(sizes)
        if scaled > 0:
            mult = (self._datarate_bytes_s - const) / scaled
            self._streams.set_rate_mult(mult, now_us)

    # --- announcements -----------------------------------------------------------------------

    def announce(self, severity: int, text: str) -> None:
        """Send ``text`` as STATUSTEXT (chunked when longer than 50 bytes)."""
        self._statustext_id = self._statustext_id % 0xFFFF + 1
        for chunk in messages.statustext_chunks(severity, text, self._statustext_id):
            self._tx.send(chunk)

    def forward_announcements(self) -> None:
        """Send what the vehicle announced and other links changed since this link last looked.

        Status texts, mission progress, commands for other components, changed parameters.
        """
        hub, cursor, send = self._hub, self._cursor, self._tx.send
        texts, reached = hub.announcements(cursor)
        for severity, text in texts:
            self.announce(severity, text)
        self.mission_events(reached)
        for command in hub.component_commands(cursor):
            send(self._component_command(command))
        for name in hub.changed_params(cursor):
            send(self._param_value(name))

    def mission_events(self, reached: Iterable[int], force_current: bool = False) -> None:
        """MISSION_ITEM_REACHED for completed items; MISSION_CURRENT when it changed."""
        for seq in reached:
            self._tx.send(mavlink2.MAVLink_mission_item_reached_message(seq & 0xFFFF))
        status = self._vehicle.mission_status()
        if force_current or status != self._mission_status:
            self._mission_status = status
            self.emit(_MISSION_CURRENT)

    def _component_command(self, command: ComponentCommand) -> mavlink2.MAVLink_message:
        """A COMMAND_LONG from the autopilot to another component of its system.

        PX4 sends a vehicle command addressed elsewhere on every link; the camera ACKs it.
        """
        p = command.params
        return mavlink2.MAVLink_command_long_message(
            target_system=self._context.sysid,
            target_component=command.target_component,
            command=command.command,
            confirmation=0,
            param1=p[0],
            param2=p[1],
            param3=p[2],
            param4=p[3],
            param5=p[4],
            param6=p[5],
            param7=p[6],
        )
