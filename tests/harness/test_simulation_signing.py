"""A running simulation with MAVLink 2 signing, flown by pymavlink clients that sign too.

Real UDP on loopback: the onboard link streams to an OS-picked client port; the camera test
takes a block of ports from the suite's allocator, since the camera's port must be known.
"""

from __future__ import annotations

import struct

import pytest
from pymavlink.dialects.v20 import common as mavlink2
from udp_client import UdpClient

from harness.run.ports import free_port_block
from harness.sim.simulation import PortPlan, Simulation, SimulationConfig
from sitl.world import WorldConfig

pytestmark = pytest.mark.sockets

KEY = bytes.fromhex("5a" * 16 + "c3" * 16)
OTHER_KEY = bytes.fromhex("11" * 32)
AUTOPILOT = (1, 1)
ARM = mavlink2.MAV_CMD_COMPONENT_ARM_DISARM


def _arm() -> mavlink2.MAVLink_command_long_message:
    return mavlink2.MAVLink_command_long_message(1, 1, ARM, 0, 1, 0, 0, 0, 0, 0, 0)


def _run(sim: Simulation, clients, seconds: float, until=None) -> None:
    """``seconds`` of simulation time in 20 ms slices, reading the clients between them."""
    for _ in range(round(seconds / 0.02)):
        sim.run_lockstep(0.02)
        for client in clients:
            client.drain()
        if until is not None and until():
            return


def test_signed_client_flies_the_vehicle_and_others_are_ignored_and_counted():
    """Same key: signed telemetry, parameters, arming. Unsigned and wrong-key clients: nothing."""
    sdk = UdpClient(245, key=KEY)
    unsigned = UdpClient(246)
    wrong = UdpClient(247, key=OTHER_KEY)
    clients = (sdk, unsigned, wrong)
    config = SimulationConfig(
        record_hz=0,
        ports=PortPlan(listen_base=0, sdk_base=sdk.port, gcs_port=0, payload_base=0),
        signing_key=KEY,
    )
    try:
        with Simulation(config) as sim:
            (link,) = sim.endpoints
            for client in clients:
                client.to = link.local_address
            _run(sim, clients, 1.0)
            telemetry = list(sdk.inbox)
            assert {"HEARTBEAT", "ATTITUDE", "LOCAL_POSITION_NED"} <= {
                m.get_type() for m in telemetry
            }
            assert all(m._signed for m in telemetry)
            # The intruders speak first; the vehicle must ignore them.
            unsigned.send(_arm())
            wrong.send(_arm())
            wrong.send(mavlink2.MAVLink_param_request_read_message(1, 1, b"MAV_SYS_ID", -1))
            _run(sim, clients, 0.5)
            assert link.stats.frames_unsigned_rejected == 1
            assert link.stats.frames_bad_signature == 2
            assert not sdk.of("COMMAND_ACK", AUTOPILOT) and not sim.fleet.commanders[0].armed
            sdk.send(mavlink2.MAVLink_param_request_read_message(1, 1, b"MAV_SYS_ID", -1))
            _run(sim, clients, 0.5, until=lambda: sdk.of("PARAM_VALUE", AUTOPILOT))
            value = sdk.of("PARAM_VALUE", AUTOPILOT)[0]  # an INT32, sent bytewise as PX4 does
            assert value.param_id == "MAV_SYS_ID"
            assert struct.unpack("<i", struct.pack("<f", value.param_value)) == (1,)
            for _ in range(20):  # the estimator needs a few seconds before arming is allowed
                sdk.send(_arm())
                _run(sim, clients, 0.5, until=lambda: sdk.of("COMMAND_ACK", AUTOPILOT))
                acks = sdk.of("COMMAND_ACK", AUTOPILOT)
                if acks and acks[-1].result == mavlink2.MAV_RESULT_ACCEPTED:
                    break
                sdk.inbox.clear()
            assert sdk.of("COMMAND_ACK", AUTOPILOT)[-1].result == mavlink2.MAV_RESULT_ACCEPTED
            assert sim.fleet.commanders[0].armed
            assert link.stats.frames_bad_signature == 2 and link.stats.frames_replay_rejected == 0
        signing = sdk.mav.signing
        assert signing.goodsig_count == signing.sig_count > 100
        assert signing.badsig_count == signing.reject_count == 0
        # Neither intruder became a peer: nothing was ever sent to them.
        assert unsigned.inbox == [] and wrong.inbox == []
    finally:
        for client in clients:
            client.close()


def test_the_camera_signs_too_and_its_heartbeat_reaches_a_signed_client(tmp_path):
    """The MAVLink camera (component 100) signs with the vehicle's key on its payload link."""
    base = free_port_block(7)
    ports = PortPlan(
        sdk_base=base,
        listen_base=base + 1,
        gcs_port=0,
        video_base=base + 4,
        payload_listen_base=base + 5,
        payload_base=base + 6,
    )
    sdk = UdpClient(245, port=base, key=KEY)
    sdk.to = ("127.0.0.1", base + 1)
    config = SimulationConfig(
        ports=ports,
        record_hz=0,
        out_dir=tmp_path / "run",
        world=WorldConfig(cameras=True),
        signing_key=KEY,
    )
    try:
        with Simulation(config) as sim:
            _run(sim, (sdk,), 2.5, until=lambda: len(sdk.of("HEARTBEAT", (1, 100))) >= 2)
            sdk.send(
                mavlink2.MAVLink_command_long_message(
                    1, 100, mavlink2.MAV_CMD_REQUEST_MESSAGE, 0, 259, 0, 0, 0, 0, 0, 0
                )
            )
            _run(sim, (sdk,), 1.0, until=lambda: sdk.of("CAMERA_INFORMATION", (1, 100)))
            payload = next(ep for ep in sim.endpoints if ep.local_address[1] == base + 5)
            assert payload.stats.frames_unsigned_rejected == 0
            assert payload.stats.frames_bad_signature == 0
        beats = sdk.of("HEARTBEAT", (1, 100))
        assert len(beats) >= 2 and beats[0].type == mavlink2.MAV_TYPE_CAMERA
        assert sdk.of("CAMERA_INFORMATION", (1, 100))
        assert all(m._signed for m in sdk.inbox)
        assert sdk.mav.signing.badsig_count == sdk.mav.signing.reject_count == 0
    finally:
        sdk.close()


@pytest.mark.parametrize("key", [b"", b"x" * 31])
def test_a_key_of_the_wrong_length_is_refused(key):
    with pytest.raises(ValueError, match="32 bytes"):
        SimulationConfig(signing_key=key)
