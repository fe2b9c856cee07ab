"""Many short-lived raw clients (each from a new UDP source port) against one vehicle.

A pymavlink script run with ``udpout:127.0.0.1:<listen port>`` sends from a new ephemeral port
every time it starts. The vehicle must keep answering the sender of each command (contract
section 1: reply to the source address of the packets), however many came before.
"""

from __future__ import annotations

import pytest
from e2e_support import RawLink, command_long, module_ports, running_swarm
from pymavlink.dialects.v20 import common as mavlink2

pytestmark = pytest.mark.e2e

PORTS = module_ports()
CLIENTS = 18
COMMAND = 40150  # not defined in common.xml -> UNSUPPORTED, no side effect


@pytest.fixture(scope="module")
def swarm(tmp_path_factory):
    with running_swarm(1, PORTS, tmp_path_factory.mktemp("peers") / "run") as s:
        yield s


def test_every_new_client_address_gets_its_ack(swarm):
    """Client after client, each on a fresh socket, gets the ACK of its command."""
    answered = []
    for _ in range(CLIENTS):
        link = RawLink(PORTS.listen, swarm.clock)
        try:
            link.send(command_long(COMMAND, (1,)))
            ack = link.wait_for(lambda m: m.get_type() == "COMMAND_ACK" and m.command == COMMAND, 3)
            answered.append(ack is not None and ack.result == mavlink2.MAV_RESULT_UNSUPPORTED)
        finally:
            link.close()
    assert all(answered), f"clients answered: {answered}"
