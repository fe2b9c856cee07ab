"""``swarmsitl up --link uart --gcs-link sik``: real clients through the modelled links.

The onboard link runs behind the 921600-baud UART model and the ground-station link behind the
57600-baud SiK model. pymavlink (raw, on the onboard link; mavutil, on the ground-station link)
and classic MAVSDK-Python (``mavsdk_grpc`` with its bundled ``mavsdk_server``) must connect,
get telemetry and have their commands acknowledged; MAVSDK arms and takes off. In lockstep, at
most :data:`e2e_support.SPEED` x real time; only states are asserted, never timings.
"""

from __future__ import annotations

import pytest
from e2e_support import (
    RawLink,
    command_long,
    module_ports,
    require_free_udp,
    run_client,
    start_swarm,
    stop_swarm,
    wait_sim,
)
from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink2

pytestmark = pytest.mark.e2e

PORTS = module_ports()
"""Ports of this module, from the suite's allocator (the GCS port is the block's PORTS.gcs)."""


@pytest.fixture(scope="module")
def swarm(tmp_path_factory):
    require_free_udp([PORTS.sdk, PORTS.listen, PORTS.gcs, PORTS.gcs_listen])
    out = tmp_path_factory.mktemp("links") / "run"
    # As PX4, the ground-station link scales its streams to the radio's data rate (baud/20 =
    # 2880 B/s): its 140 DISTANCE_SENSOR/s and the rest fit without shedding a stream by hand.
    extra = ("--link", "uart", "--gcs-link", "sik")
    s = start_swarm(1, PORTS, out, extra, gcs_port=PORTS.gcs)
    try:
        yield s
    finally:
        stop_swarm(s)


def test_the_endpoint_table_names_the_link_models(swarm):
    """The table printed by ``up`` says which model each path runs through."""
    table = swarm.output()
    assert "uart 921600 Bd 8N1 / sik 57600 Bd 8N1" in table, table


def test_raw_pymavlink_gets_telemetry_and_a_command_ack_over_the_uart(swarm):
    """A raw client on the onboard link: HEARTBEATs, then AUTOPILOT_VERSION on request."""
    link = RawLink(PORTS.listen, swarm.clock)
    try:
        link.send(mavlink2.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3))
        link.heartbeats(2)
        request = command_long(
            mavlink2.MAV_CMD_REQUEST_MESSAGE, (mavlink2.MAVLINK_MSG_ID_AUTOPILOT_VERSION,)
        )
        ack = None
        for _ in range(3):  # as MAVSDK: retry a command that got no ACK
            link.send(request)
            ack = link.wait_for(
                lambda m: (
                    m.get_type() == "COMMAND_ACK" and m.command == mavlink2.MAV_CMD_REQUEST_MESSAGE
                ),
                10.0,
            )
            if ack is not None:
                break
        version = link.wait_for(lambda m: m.get_type() == "AUTOPILOT_VERSION", 10.0)
    finally:
        link.close()
    assert ack is not None and ack.result == mavlink2.MAV_RESULT_ACCEPTED
    assert version is not None or any(m.get_type() == "AUTOPILOT_VERSION" for m in link.inbox)


def test_a_ground_station_hears_the_vehicle_over_the_sik_radio(swarm):
    """mavutil (as MAVProxy) on the GCS port gets HEARTBEAT and SYS_STATUS through the radio."""
    gcs = mavutil.mavlink_connection(f"udpin:127.0.0.1:{PORTS.gcs}", source_system=255)
    try:
        heartbeat = wait_sim(
            lambda: gcs.recv_match(type="HEARTBEAT", blocking=True, timeout=0.05),
            30, swarm.clock, "HEARTBEAT", poll_wall_s=0,
        )  # fmt: skip
        status = wait_sim(
            lambda: gcs.recv_match(type="SYS_STATUS", blocking=True, timeout=0.05),
            30, swarm.clock, "SYS_STATUS", poll_wall_s=0,
        )  # fmt: skip
    finally:
        gcs.close()
    assert heartbeat is not None and heartbeat.get_srcSystem() == 1
    assert status is not None


def test_classic_mavsdk_arms_and_takes_off_through_the_uart(swarm, client_logs):
    """mavsdk_grpc: connect, identity, parameters, arm, take off to 3 m, all over the UART."""
    result = run_client(
        "classic_takeoff.py",
        ["--url", PORTS.url(), "--grpc-port", str(PORTS.grpc), "--alt", "3"],
        client_logs,
        clock=swarm.clock,
        grpc_port=PORTS.grpc,
    )
    assert result.ok, result.describe()
    assert result.data["mav_sys_id"] == 1
    assert result.data["rel_alt_reached_m"] >= 2.7
    assert result.data["in_air"] is True
