"""DISTANCE_SENSOR on one MAVLink link: each range finder reading forwarded once.

PX4's DISTANCE_SENSOR stream (src/modules/mavlink/streams/DISTANCE_SENSOR.hpp) sends, each time
it is due, one message per distance_sensor instance updated since its last send. A link here
does the same with the vehicle's latest readings (``TelemetrySnapshot.distance_sensors``): a
reading newer than the last one this link forwarded goes out, older ones do not go out twice.
A stream interval longer than the sensors' period sends only each sensor's latest reading.
"""

from __future__ import annotations

from collections.abc import Iterable

from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.rangefinder import RangeReading


class DistanceSensorForwarder:
    """What one link has forwarded of a vehicle's range finder readings."""

    def __init__(self) -> None:
        self._last_seq = 0

    def new_messages(
        self, readings: Iterable[RangeReading]
    ) -> list[mavlink2.MAVLink_distance_sensor_message]:
        """DISTANCE_SENSOR of every reading this link has not sent yet (sensor id order)."""
        last = self._last_seq
        out = []
        for reading in readings:
            if reading.seq > last:
                out.append(reading.message())
                self._last_seq = max(self._last_seq, reading.seq)
        return out


def latest_messages(
    readings: Iterable[RangeReading],
) -> list[mavlink2.MAVLink_distance_sensor_message]:
    """DISTANCE_SENSOR of each sensor's latest reading (MAV_CMD_REQUEST_MESSAGE 132)."""
    return [reading.message() for reading in readings]
