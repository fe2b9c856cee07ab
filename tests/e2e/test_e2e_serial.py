"""``swarmsitl up --serial --udp-out``: MAVSDK classic flies over the serial port (a pty, as a
Pi's TELEM2) while a pymavlink script on the extra UDP output watches the same vehicle.

Ports come from the suite's allocator (:func:`e2e_support.module_ports`), clear of every other
module's and of the other xdist worker's.
"""

from __future__ import annotations

import contextlib
import time

import pytest
from e2e_support import (
    WaitTimeout,
    check_tlog,
    module_ports,
    require_free_udp,
    start_client,
    start_swarm,
    stop_swarm,
    wait_sim,
)
from pymavlink import mavutil

from harness.run.ports import free_port_block

pytestmark = pytest.mark.e2e

PORTS = module_ports()
UDP_OUT = free_port_block()
"""Where the vehicle's extra link (``--udp-out``) sends; the pymavlink watcher listens here."""
ARMED = mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED
ONBOARD_CONTROLLER = mavutil.mavlink.MAV_TYPE_ONBOARD_CONTROLLER
INVALID_AUTOPILOT = mavutil.mavlink.MAV_AUTOPILOT_INVALID


def test_mavsdk_flies_over_the_serial_port_while_a_udp_out_client_watches(tmp_path, client_logs):
    """MAVSDK connects with serial://RUN/vehicle1.serial:921600, arms, takes off and lands; the
    pymavlink client on --udp-out sees the same vehicle arm and disarm, and sees MAVSDK's own
    HEARTBEAT (system 245), forwarded from the serial link as PX4's -f does (once the UDP link
    has heard from the watcher: PX4 forwards broadcasts only to links that heard someone)."""
    require_free_udp([PORTS.sdk, PORTS.listen, UDP_OUT])
    out = tmp_path / "run"
    watcher = mavutil.mavlink_connection(f"udpin:127.0.0.1:{UDP_OUT}", source_system=250)
    swarm = start_swarm(1, PORTS, out, extra=("--serial", "--udp-out", f"127.0.0.1:{UDP_OUT}"))
    serial = out / "vehicle1.serial"
    try:
        assert f"serial://{serial}:921600" in swarm.output(), swarm.output()
        assert serial.is_symlink()
        client = start_client(
            "classic_takeoff.py",
            [
                "--url",
                f"serial://{serial}:921600",
                "--grpc-port",
                str(PORTS.grpc),
                "--alt",
                "3",
                "--land",
            ],
            client_logs,
            clock=swarm.clock,
            grpc_port=PORTS.grpc,
        )
        armed_states: list[bool] = []
        seen_systems: set[int] = set()
        next_beat = [0.0]

        def watch_until_the_client_ends() -> bool:
            msg = watcher.recv_match(type="HEARTBEAT", blocking=True, timeout=0.5)
            if msg is not None:
                seen_systems.add(msg.get_srcSystem())
                if time.monotonic() >= next_beat[0]:  # heard from: PX4 forwards broadcasts to us
                    next_beat[0] = time.monotonic() + 1.0  # a send interval, not a limit
                    watcher.mav.heartbeat_send(ONBOARD_CONTROLLER, INVALID_AUTOPILOT, 0, 0, 0)
                if msg.get_srcSystem() == 1:
                    armed = bool(msg.base_mode & ARMED)
                    if not armed_states or armed_states[-1] != armed:
                        armed_states.append(armed)
            return client.finished()

        with contextlib.suppress(WaitTimeout):  # the client's result says it timed out
            wait_sim(
                watch_until_the_client_ends, client.sim_left_s(), swarm.clock, "the client's end",
                poll_wall_s=0,
            )  # fmt: skip
        result = client.result()
        assert result.ok, result.describe()
        assert result.data["rel_alt_reached_m"] >= 2.7
        assert result.data["landed"] is True
        assert armed_states[:3] == [False, True, False], armed_states
        assert 245 in seen_systems, seen_systems
    finally:
        watcher.close()
        stop_swarm(swarm)
    assert not serial.exists() and not serial.is_symlink()
    assert check_tlog(out / "vehicle1-serial.tlog", 1) > 0
    assert check_tlog(out / "vehicle1-udp1.tlog", 1) > 0
