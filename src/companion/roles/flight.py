"""Take off, hover and land a role's own vehicle over MAVLink (pymavlink), as a Pi would.

Seed 000's nodes fly while they talk (its code takes off to 10 m). A role given a MAVLink URL
(``--mavlink udpin:0.0.0.0:14540``) arms its vehicle, takes off to ``altitude_m`` above home
(MAV_CMD_NAV_TAKEOFF with an AMSL altitude, as PX4 expects), hovers while the role runs, and lands
at the end (MAV_CMD_NAV_LAND). Blocking pymavlink calls run in a worker thread.
"""

from __future__ import annotations

import asyncio
import logging
import math
import time
from dataclasses import dataclass

from pymavlink import mavutil

log = logging.getLogger(__name__)


class FlightError(RuntimeError):
    """The vehicle did not answer or refused a command."""


@dataclass(frozen=True)
class FlightParams:
    """Where and how long to wait, wall seconds for the link (a real vehicle's pace)."""

    url: str
    """pymavlink connection string, e.g. ``udpin:0.0.0.0:14540`` (PX4's offboard port)."""
    altitude_m: float = 10.0
    """Take-off height above home, m (seed 000's code: 10 m)."""
    timeout_s: float = 30.0
    """Wall seconds to wait for a heartbeat, a position or an ACK."""
    land_timeout_s: float = 120.0
    """Wall seconds to wait for the vehicle to land and disarm."""


class VehicleLink:
    """The blocking pymavlink side: one connection to one autopilot."""

    def __init__(self, params: FlightParams) -> None:
        self.params = params
        self.mav = mavutil.mavlink_connection(params.url, source_system=245, source_component=191)

    def _command(self, command: int, *args: float) -> None:
        values = list(args) + [0.0] * (7 - len(args))
        deadline = time.monotonic() + self.params.timeout_s
        while time.monotonic() < deadline:
            self.mav.mav.command_long_send(
                self.mav.target_system, self.mav.target_component, command, 0, *values
            )
            ack = self.mav.recv_match(type="COMMAND_ACK", blocking=True, timeout=1.0)
            if ack is not None and ack.command == command:
                if ack.result != mavutil.mavlink.MAV_RESULT_ACCEPTED:
                    raise FlightError(f"command {command} refused: result {ack.result}")
                return
        raise FlightError(f"no COMMAND_ACK for command {command} in {self.params.timeout_s} s")

    def take_off(self) -> None:
        """Wait for the vehicle, arm, take off to ``altitude_m`` above home."""
        if self.mav.wait_heartbeat(timeout=self.params.timeout_s) is None:
            raise FlightError(f"no HEARTBEAT on {self.params.url}")
        position = self.mav.recv_match(
            type="GLOBAL_POSITION_INT", blocking=True, timeout=self.params.timeout_s
        )
        if position is None:
            raise FlightError("no GLOBAL_POSITION_INT")
        home_amsl_m = (position.alt - position.relative_alt) / 1000.0
        deadline = time.monotonic() + self.params.timeout_s
        while True:  # the estimator needs a few seconds before arming is allowed
            try:
                self._command(mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0)
                break
            except FlightError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(1.0)
        self._command(
            mavutil.mavlink.MAV_CMD_NAV_TAKEOFF,
            -1.0, 0.0, 0.0, math.nan, math.nan, math.nan,
            home_amsl_m + self.params.altitude_m,
        )  # fmt: skip

    def land(self) -> None:
        """Land where the vehicle is; return once it disarmed on the ground (PX4 auto-disarm)."""
        self._command(mavutil.mavlink.MAV_CMD_NAV_LAND, 0.0, 0.0, 0.0, math.nan, math.nan,
                      math.nan, math.nan)  # fmt: skip
        deadline = time.monotonic() + self.params.land_timeout_s
        armed = mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED
        while time.monotonic() < deadline:
            beat = self.mav.recv_match(type="HEARTBEAT", blocking=True, timeout=1.0)
            if beat is not None and beat.get_srcComponent() == 1 and not beat.base_mode & armed:
                return
        raise FlightError(f"still armed {self.params.land_timeout_s} s after the land command")

    def close(self) -> None:
        """Close the connection."""
        self.mav.close()


async def fly_during(params: FlightParams, role: asyncio.Future) -> str:
    """Take off, wait for ``role`` to finish, land; returns what happened (never raises)."""
    link = await asyncio.to_thread(VehicleLink, params)
    try:
        await asyncio.to_thread(link.take_off)
    except FlightError as exc:
        log.warning("take-off failed: %s", exc)
        await asyncio.to_thread(link.close)
        return f"take-off failed: {exc}"
    await asyncio.wait({role})
    try:
        await asyncio.to_thread(link.land)
    except FlightError as exc:
        return f"landing failed: {exc}"
    finally:
        await asyncio.to_thread(link.close)
    return "landed"
