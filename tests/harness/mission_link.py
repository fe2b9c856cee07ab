"""A pymavlink client for lockstep tests: talks to one vehicle of an in-process Simulation.

Waits are measured in simulation time: the client steps the simulation until a reply arrives or
the simulated deadline passes, so a loaded machine cannot change the outcome.
"""

from __future__ import annotations

import math
import socket
from collections.abc import Callable

import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

from harness.run.ports import free_port_block
from harness.sim.simulation import PortPlan, Simulation, SimulationConfig

HOME_LAT, HOME_LON = 47.397742, 8.545594


def free_udp_port() -> int:
    """A port for a client to listen on, from the suite's allocator (this xdist worker's slice)."""
    return free_port_block()


def offset_deg(north_m: float, east_m: float) -> tuple[float, float]:
    """Latitude/longitude of a point north/east of the default home (small offsets)."""
    lat = HOME_LAT + north_m / 111_195.0
    lon = HOME_LON + east_m / (111_195.0 * math.cos(math.radians(HOME_LAT)))
    return lat, lon


class SimLink:
    """A MAVLink 2 client (sysid 245, compid 190) and the simulation it steps."""

    def __init__(self, sim: Simulation, client_port: int) -> None:
        self.sim = sim
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", client_port))
        self.sock.setblocking(False)
        self.mav = mavlink2.MAVLink(None, srcSystem=245, srcComponent=190)
        self.mav.robust_parsing = True
        self.inbox: list[mavlink2.MAVLink_message] = []
        self.texts: list[str] = []
        self.vehicle = sim.endpoints[0].local_address

    @classmethod
    def open(cls, seed: int = 3, **config: object) -> SimLink:
        port = free_udp_port()
        sim = Simulation(
            SimulationConfig(
                n_vehicles=1,
                seed=seed,
                record_hz=0,
                ports=PortPlan(listen_base=0, sdk_base=port, gcs_port=0),
                **config,
            )
        )
        return cls(sim, port)

    def close(self) -> None:
        self.sock.close()
        self.sim.close()

    def send(self, msg: mavlink2.MAVLink_message) -> None:
        self.sock.sendto(msg.pack(self.mav), self.vehicle)
        self.mav.seq = (self.mav.seq + 1) & 0xFF

    def _drain(self) -> list[mavlink2.MAVLink_message]:
        new = []
        while True:
            try:
                data = self.sock.recv(65535)
            except BlockingIOError:
                break
            new.extend(self.mav.parse_buffer(data) or [])
        for m in new:
            if m.get_type() == "STATUSTEXT":
                self.texts.append(m.text)
        self.inbox.extend(new)
        return new

    def run(self, seconds: float) -> None:
        """Advance the simulation by ``seconds`` of simulated time, reading replies as they come.

        Reading every 50 steps keeps the socket's receive buffer from overflowing (lockstep
        produces telemetry far faster than real time).
        """
        end = self.sim.time_s + seconds
        steps = 0
        while self.sim.time_s < end:
            self.sim.step()
            steps += 1
            if steps % 50 == 0:
                self._drain()
        self._drain()

    def wait(
        self, pred: Callable[[mavlink2.MAVLink_message], bool], timeout_s: float = 5.0
    ) -> mavlink2.MAVLink_message:
        """Step until a received message satisfies ``pred`` (simulated timeout)."""
        end = self.sim.time_s + timeout_s
        while True:
            for m in self._drain():
                if pred(m):
                    return m
            if self.sim.time_s > end:
                raise AssertionError(f"no matching message within {timeout_s} simulated s")
            for _ in range(10):
                self.sim.step()

    def wait_type(
        self, name: str, timeout_s: float = 5.0, **fields: object
    ) -> mavlink2.MAVLink_message:
        return self.wait(
            lambda m: m.get_type() == name and all(getattr(m, k) == v for k, v in fields.items()),
            timeout_s,
        )

    def until(self, condition: Callable[[], bool], timeout_s: float, every_s: float = 0.1) -> float:
        """Step until ``condition()``; return the simulated time it took."""
        start = self.sim.time_s
        while not condition():
            if self.sim.time_s - start > timeout_s:
                raise AssertionError(f"condition not met within {timeout_s} simulated s")
            self.run(every_s)
        return self.sim.time_s - start

    def command(self, command: int, *params: float, timeout_s: float = 2.0) -> int:
        p = [*params, *[math.nan] * (7 - len(params))]
        self.send(mavlink2.MAVLink_command_long_message(1, 1, command, 0, *p))
        return self.wait_type("COMMAND_ACK", timeout_s, command=command).result

    def arm(self) -> int:
        return self.command(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 1)

    def set_mode(self, main: int, sub: int = 0) -> int:
        return self.command(mavlink2.MAV_CMD_DO_SET_MODE, 1, main, sub)

    def set_param(self, name: str, value: float, int32: bool = False) -> None:
        from autopilot_emu.params import encode_param_value

        kind = mavlink2.MAV_PARAM_TYPE_INT32 if int32 else mavlink2.MAV_PARAM_TYPE_REAL32
        raw = encode_param_value(int(value) if int32 else float(value), kind)
        self.send(mavlink2.MAVLink_param_set_message(1, 1, name.encode(), raw, kind))
        self.wait(lambda m: m.get_type() == "PARAM_VALUE" and m.param_id == name)

    def upload(self, items: list[mavlink2.MAVLink_message], mission_type: int = 0) -> int:
        """Upload MISSION_ITEM_INTs (seq and mission_type filled in); return the ACK type."""
        self.send(mavlink2.MAVLink_mission_count_message(1, 1, len(items), mission_type))
        while True:
            m = self.wait(
                lambda m: m.get_type() in ("MISSION_REQUEST_INT", "MISSION_ACK"), timeout_s=2.0
            )
            if m.get_type() == "MISSION_ACK":
                return m.type
            item = items[m.seq]
            item.seq, item.mission_type = m.seq, mission_type
            item.target_system, item.target_component = 1, 1
            self.send(item)

    def wait_ready(self) -> None:
        ready = mavlink2.MAV_SYS_STATUS_SENSOR_GPS | mavlink2.MAV_SYS_STATUS_PREARM_CHECK
        self.wait(
            lambda m: (
                m.get_type() == "SYS_STATUS"
                and m.onboard_control_sensors_health & ready == ready
                and self.sim.fleet.commanders[0].home is not None
            ),
            timeout_s=60.0,
        )

    @property
    def commander(self):
        return self.sim.fleet.commanders[0]

    def truth_ned(self) -> tuple[float, float, float]:
        """Estimated NED position of the vehicle, m (the autopilot's own estimate)."""
        return tuple(float(v) for v in self.sim.fleet.estimator.position_ned_m[0])

    def ned_of(self, north_m: float, east_m: float) -> tuple[float, float]:
        """Where the point ``north_m``/``east_m`` of the default home lies in the vehicle's
        own NED frame (its EKF origin is its first, noisy, GPS fix)."""
        from autopilot_emu import geodesy

        lat, lon = offset_deg(north_m, east_m)
        origin = self.sim.fleet.estimator.origin_lla[0]
        ned = geodesy.geodetic_to_ned(np.array([lat, lon, origin[2]]), origin)
        return float(ned[0]), float(ned[1])


def waypoint(
    north_m: float,
    east_m: float,
    rel_alt_m: float,
    hold_s: float = 0.0,
    radius_m: float = 1.0,
    command: int = mavlink2.MAV_CMD_NAV_WAYPOINT,
) -> mavlink2.MAVLink_message:
    lat, lon = offset_deg(north_m, east_m)
    return mavlink2.MAVLink_mission_item_int_message(
        1, 1, 0, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, command, 0, 1,
        hold_s, radius_m, 0.0, math.nan, round(lat * 1e7), round(lon * 1e7), rel_alt_m, 0,
    )  # fmt: skip


def mission_cmd(command: int, *params: float) -> mavlink2.MAVLink_message:
    p = [*params, *[0.0] * (4 - len(params))]
    return mavlink2.MAVLink_mission_item_int_message(
        1, 1, 0, mavlink2.MAV_FRAME_MISSION, command, 0, 1, *p, 0, 0, math.nan, 0
    )
