"""The autopilot side of a physics step: the emulated fleet in memory or PX4 across TCP.

A simulation step hands what the world measured to the vehicles' autopilots and takes back
their actuator commands. Two sides do that: the in-process PX4 emulator
(``autopilot_emu.fleet.AutopilotFleet``, called directly) and external autopilots behind the
HIL server (``sitl.hil_server``, MAVLink HIL messages over TCP). Both implement
:class:`AutopilotSide`, so ``Simulation.step`` is written once.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    from autopilot_emu.fleet import AutopilotFleet
    from sitl.hil_server import HilServer


@dataclass(slots=True)
class Readings:
    """What the world measured on one physics step, as HIL messages (None: nothing due)."""

    sensors: list[Any] | None
    """HIL_SENSOR, one per vehicle."""
    gps: list[Any] | None
    """HIL_GPS, one per vehicle."""
    battery: list[Any] | None
    """BATTERY_STATUS, one per vehicle."""
    ranges: list[Any] | None
    """DISTANCE_SENSOR messages of the rangefinders."""


class AutopilotSide(Protocol):
    """Where a physics step's readings go and its actuator commands come from."""

    def deliver(self, readings: Readings, now_s: float, truth: Callable[[], Any]) -> None:
        """Hand the readings to the autopilots (in the order PX4 receives them)."""
        ...

    def actuators(self) -> list[Any] | None:
        """The actuator commands answering the last readings (None: keep the previous ones)."""
        ...


class FleetSide:
    """The emulated autopilots, in memory: each reading is handled as it is delivered."""

    def __init__(self, fleet: AutopilotFleet) -> None:
        self.fleet = fleet
        self._actuators: list[Any] | None = None

    def deliver(self, readings: Readings, now_s: float, truth: Callable[[], Any]) -> None:
        """GPS, then the IMU (which runs the estimator and controllers), battery, rangefinders."""
        fleet = self.fleet
        if readings.gps is not None:
            fleet.handle_gps(readings.gps)
        if readings.sensors is not None:
            self._actuators = fleet.handle_sensors(readings.sensors)
        if readings.battery is not None:
            fleet.handle_battery(readings.battery)
        if readings.ranges is not None:
            fleet.handle_distance_sensors(readings.ranges)

    def actuators(self) -> list[Any] | None:
        """The commands of the last HIL_SENSOR handled this step (None if none was)."""
        out, self._actuators = self._actuators, None
        return out


class HilSide:
    """External autopilots (PX4 SITL) across the HIL server's TCP links, in lockstep."""

    def __init__(self, hil: HilServer) -> None:
        self.hil = hil

    def deliver(self, readings: Readings, now_s: float, truth: Callable[[], Any]) -> None:
        """Send the readings and the ground truth (HIL_STATE_QUATERNION) to every autopilot."""
        hil = self.hil
        if readings.gps is not None:
            hil.send_gps(readings.gps)
        if readings.sensors is not None:
            hil.send_sensors(readings.sensors)
        if readings.battery is not None:
            hil.send_battery(readings.battery)
        if readings.ranges is not None:
            hil.send_distance_sensors(readings.ranges)
        hil.send_state(now_s, truth)

    def actuators(self) -> list[Any] | None:
        """Wait for the replies to HIL_SENSOR (lockstep) and return them."""
        return self.hil.actuators()
