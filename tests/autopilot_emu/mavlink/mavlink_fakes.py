"""Test doubles for the MAVLink endpoint tests: a fake vehicle and a raw-UDP MAVLink client."""

from __future__ import annotations

import math
import select
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink.endpoint import EndpointConfig, MavlinkEndpoint
from autopilot_emu.mavlink.link_hub import LinkHub
from autopilot_emu.mavlink.vehicle_port import (
    EstimatorSnapshot,
    HomeSnapshot,
    ImuSample,
    SetpointSnapshot,
    TelemetrySnapshot,
)
from autopilot_emu.params import ParamStore

HOME = HomeSnapshot(lat_deg=47.397742, lon_deg=8.545594, alt_amsl_m=488.0, local_ned_m=(0, 0, 0))
EPOCH_START_S = 1_700_000_000.0


def make_snapshot(**overrides: object) -> TelemetrySnapshot:
    """A plausible hovering-on-the-ground snapshot at the PX4 SITL Zurich home."""
    base = TelemetrySnapshot(
        time_usec=1_000_000,
        armed=False,
        main_mode=4,
        sub_mode=3,
        landed_state=1,
        system_status=3,
        sensors_present=0x1000002F,
        sensors_health=0x1000002F,
        lat_deg=HOME.lat_deg,
        lon_deg=HOME.lon_deg,
        alt_amsl_m=HOME.alt_amsl_m,
        relative_alt_m=0.0,
        position_ned_m=(0.0, 0.0, 0.0),
        velocity_ned_m_s=(0.0, 0.0, 0.0),
        quaternion_wxyz=(1.0, 0.0, 0.0, 0.0),
        euler_rad=(0.0, 0.0, 0.0),
        body_rates_rad_s=(0.0, 0.0, 0.0),
        throttle=0.0,
        gps_fix_type=3,
        gps_lat_deg=HOME.lat_deg,
        gps_lon_deg=HOME.lon_deg,
        gps_alt_amsl_m=HOME.alt_amsl_m,
        gps_eph_m=0.5,
        gps_epv_m=0.8,
        gps_satellites=12,
        gps_velocity_ned_m_s=(0.0, 0.0, 0.0),
        battery_voltage_v=16.4,
        battery_current_a=0.5,
        battery_remaining_pct=95,
        battery_consumed_mah=12.0,
        home=HOME,
        setpoint=SetpointSnapshot(
            position_ned_m=(0.0, 0.0, -2.5),
            velocity_ned_m_s=(0.0, 0.0, 0.0),
            acceleration_ned_m_s2=(math.nan, math.nan, math.nan),
            yaw_rad=0.0,
            yaw_rate_rad_s=math.nan,
            global_position=(HOME.lat_deg, HOME.lon_deg, HOME.alt_amsl_m + 2.5),
            attitude_wxyz=(1.0, 0.0, 0.0, 0.0),
            body_rates_rad_s=(0.0, 0.0, 0.0),
            thrust=0.5,
        ),
        imu=ImuSample(
            time_usec=1_000_000,
            accel_m_s2=(0.0, 0.0, -9.81),
            gyro_rad_s=(0.0, 0.0, 0.0),
            mag_gauss=(0.21, 0.01, 0.42),
            abs_pressure_hpa=955.0,
            diff_pressure_hpa=0.0,
            pressure_alt_m=488.0,
            temperature_degc=20.0,
            fields_updated=0x1FFF,
        ),
        estimator=EstimatorSnapshot(
            flags=mavlink2.ESTIMATOR_ATTITUDE | mavlink2.ESTIMATOR_POS_HORIZ_ABS,
            pos_horiz_accuracy_m=0.4,
            pos_vert_accuracy_m=0.6,
            position_variance_m2=(0.08, 0.08, 0.36),
            velocity_variance_m2_s2=(0.01, 0.01, 0.02),
            origin_lla=(HOME.lat_deg, HOME.lon_deg, HOME.alt_amsl_m),
            origin_time_usec=500_000,
        ),
    )
    return replace(base, **overrides)


@dataclass
class FakeVehicle:
    """Implements VehiclePort; records every call and answers with ``result``."""

    params: ParamStore = field(default_factory=ParamStore)
    snapshot: TelemetrySnapshot = field(default_factory=make_snapshot)
    result: int = mavlink2.MAV_RESULT_ACCEPTED
    calls: list[tuple] = field(default_factory=list)
    status_texts: list[tuple[int, str]] = field(default_factory=list)
    telemetry_calls: int = 0
    plans: dict[int, tuple] = field(default_factory=dict)
    mission_result: int = mavlink2.MAV_MISSION_ACCEPTED
    current_seq: int = 0
    reached: list[int] = field(default_factory=list)
    component_commands: list = field(default_factory=list)

    def telemetry(self) -> TelemetrySnapshot:
        self.telemetry_calls += 1
        return self.snapshot

    def _record(self, *call: object) -> int:
        self.calls.append(call)
        return self.result

    def arm(self, force: bool) -> int:
        return self._record("arm", force)

    def disarm(self, force: bool) -> int:
        return self._record("disarm", force)

    def takeoff(self, alt_amsl_m: float | None) -> int:
        return self._record("takeoff", alt_amsl_m)

    def land(self) -> int:
        return self._record("land")

    def set_mode(self, main_mode: int, sub_mode: int) -> int:
        return self._record("set_mode", main_mode, sub_mode)

    def reposition(
        self, lat_deg: float, lon_deg: float, alt_amsl_m: float, yaw_rad: float, speed_m_s: float
    ) -> int:
        return self._record("reposition", lat_deg, lon_deg, alt_amsl_m, yaw_rad, speed_m_s)

    def change_speed(self, speed_m_s: float) -> int:
        return self._record("change_speed", speed_m_s)

    def set_home(self, use_current: bool, lat_deg: float, lon_deg: float, alt_amsl_m: float) -> int:
        return self._record("set_home", use_current, lat_deg, lon_deg, alt_amsl_m)

    def terminate(self) -> int:
        return self._record("terminate")

    def pop_status_texts(self) -> list[tuple[int, str]]:
        texts, self.status_texts = self.status_texts, []
        return texts

    def mission_items(self, kind: int) -> tuple:
        return self.plans.get(int(kind), ())

    def upload_mission(self, kind: int, items: tuple) -> int:
        self.calls.append(("upload_mission", int(kind), items))
        self.plans[int(kind)] = items
        return self.mission_result

    def set_mission_current(self, seq: int) -> bool:
        self.calls.append(("set_mission_current", seq))
        items = self.plans.get(0, ())
        if 0 <= seq < len(items):
            self.current_seq = seq
            return True
        return False

    def mission_status(self) -> tuple[int, int, int]:
        items = self.plans.get(0, ())
        return (self.current_seq, len(items) if items else 0xFFFF, 2 if items else 1)

    def pop_mission_reached(self) -> list[int]:
        reached, self.reached = self.reached, []
        return reached

    def pop_component_commands(self) -> list:
        commands, self.component_commands = self.component_commands, []
        return commands

    def gcs_heartbeat(self) -> None:
        self.calls.append(("gcs_heartbeat",))

    def start_mission(self, first_seq: int) -> int:
        return self._record("start_mission", first_seq)

    def inject_failure(self, unit: int, failure_type: int, instance: int) -> int:
        return self._record("inject_failure", unit, failure_type, instance)

    def vision_measurement(self, *args: object) -> None:
        self.calls.append(("vision_measurement", *args))


def make_endpoint(
    vehicle: FakeVehicle,
    peers: tuple[tuple[str, int], ...] = (),
    wall_clock_s: Callable[[], float] = time.monotonic,
    hub: LinkHub | None = None,
    **config: object,
) -> MavlinkEndpoint:
    """An endpoint on a free loopback port that sends only to ``peers`` and learned addresses."""
    return MavlinkEndpoint(
        vehicle,
        EndpointConfig(listen_port=0, peers=peers, epoch_start_s=EPOCH_START_S, **config),
        wall_clock_s,
        hub=hub,
    )


class MavClient:
    """A GCS-like MAVLink 2 client on its own UDP socket (MAVSDK's ids by default)."""

    def __init__(self, sysid: int = 245, compid: int = 190) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.setblocking(False)
        self.mav = mavlink2.MAVLink(None, srcSystem=sysid, srcComponent=compid)
        self.mav.robust_parsing = True
        self.inbox: list[mavlink2.MAVLink_message] = []

    @property
    def address(self) -> tuple[str, int]:
        return self.sock.getsockname()

    def close(self) -> None:
        self.sock.close()

    def send(self, endpoint: MavlinkEndpoint, msg: mavlink2.MAVLink_message) -> bytes:
        frame = msg.pack(self.mav)
        self.mav.seq = (self.mav.seq + 1) & 0xFF
        self.sock.sendto(frame, endpoint.local_address)
        return frame

    def send_raw(self, endpoint: MavlinkEndpoint, data: bytes) -> None:
        self.sock.sendto(data, endpoint.local_address)

    def drain(self) -> list[mavlink2.MAVLink_message]:
        """Read everything already queued on the socket into ``inbox``; return the new ones."""
        new: list[mavlink2.MAVLink_message] = []
        while True:
            try:
                data = self.sock.recv(65535)
            except BlockingIOError:
                break
            new.extend(self.mav.parse_buffer(data) or [])
        self.inbox.extend(new)
        return new

    def take(self, type_name: str) -> list[mavlink2.MAVLink_message]:
        """Remove and return the inbox messages of one type."""
        matching = [m for m in self.inbox if m.get_type() == type_name]
        self.inbox = [m for m in self.inbox if m.get_type() != type_name]
        return matching

    def exchange(
        self,
        endpoint: MavlinkEndpoint,
        now_s: float,
        until: Callable[[list[mavlink2.MAVLink_message]], bool],
        max_wait_s: float = 5.0,
    ) -> list[mavlink2.MAVLink_message]:
        """Empty the inbox, then poll at ``now_s`` until ``until(inbox)`` holds; return the inbox.

        Loopback delivery is normally immediate, so this returns after one poll; the wait only
        guards against a scheduler hiccup and is never part of an assertion.
        """
        self.inbox.clear()
        deadline = time.monotonic() + max_wait_s
        while True:
            endpoint.poll(now_s)
            self.drain()
            if until(self.inbox):
                return self.inbox
            if time.monotonic() > deadline:
                types = sorted({m.get_type() for m in self.inbox})
                raise AssertionError(f"condition not met; inbox holds {types}")
            select.select([self.sock], [], [], 0.01)


def has(type_name: str, count: int = 1) -> Callable[[list[mavlink2.MAVLink_message]], bool]:
    """Condition for :meth:`MavClient.exchange`: at least ``count`` messages of a type."""
    return lambda inbox: sum(m.get_type() == type_name for m in inbox) >= count


def command_long(
    command: int,
    *params: float,
    target_system: int = 1,
    target_component: int = 1,
    confirmation: int = 0,
) -> mavlink2.MAVLink_command_long_message:
    """COMMAND_LONG with params padded by NaN, as MAVSDK sends unset params."""
    padded = list(params) + [math.nan] * (7 - len(params))
    return mavlink2.MAVLink_command_long_message(
        target_system, target_component, command, confirmation, *padded
    )


INT_RANGES = {
    "int8_t": (-(2**7), 2**7 - 1),
    "uint8_t": (0, 2**8 - 1),
    "int16_t": (-(2**15), 2**15 - 1),
    "uint16_t": (0, 2**16 - 1),
    "int32_t": (-(2**31), 2**31 - 1),
    "uint32_t": (0, 2**32 - 1),
    "int64_t": (-(2**63), 2**63 - 1),
    "uint64_t": (0, 2**64 - 1),
}
"""Lowest and highest value of each MAVLink integer wire type (for property tests)."""
