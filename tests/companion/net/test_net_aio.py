"""AsyncNode: request/reply between tasks and between processes over real UDP, simulated-time
timeouts, message iteration, and polling of a descriptor-less transport."""

from __future__ import annotations

import asyncio
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from netfakes import CONFIG, FakePort

from companion import clock
from companion.net import AsyncNode, NetConfig, Node, PortTransport, RequestTimeout, UdpTransport
from harness.run.ports import free_port_block

pytestmark = pytest.mark.process

BASE = free_port_block(3)
"""Ports of the nodes below, from the suite's allocator (this xdist worker's own slice)."""

SRC = Path(__file__).resolve().parents[3] / "src"
NET = {
    "nodes": {
        "cloud": {"role": "cloud", "address": f"127.0.0.1:{BASE}"},
        "fog1": {"role": "fog", "address": f"127.0.0.1:{BASE + 1}", "groups": ["cluster1"]},
        "edge1": {"role": "edge", "address": f"127.0.0.1:{BASE + 2}", "groups": ["cluster1"]},
    }
}
UDP_CONFIG = NetConfig.from_dict(NET)


def udp_node(node_id: str) -> AsyncNode:
    return AsyncNode(Node(node_id, UDP_CONFIG, UdpTransport(UDP_CONFIG, node_id), clock.now_s))


def test_request_reply_and_messages_between_tasks_over_udp():
    async def scenario():
        async with udp_node("cloud") as cloud, udp_node("edge1") as edge:
            cloud.on("area", lambda env: {"m2": env.body["w"] * env.body["h"]})
            reply = await edge.request("cloud", "area", {"w": 3, "h": 4}, timeout_s=2.0)
            edge.send("cloud", "telemetry", {"alt_m": 10.0})
            note = await cloud.recv(timeout_s=5.0)
            return reply, note, edge.stats.to_dict()

    reply, note, stats = asyncio.run(scenario())
    assert reply.body == {"m2": 12} and reply.src == "cloud"
    assert (note.topic, note.body) == ("telemetry", {"alt_m": 10.0})
    link = stats["link_classes"]["edge-cloud"]
    assert link["sent"]["control"]["messages"] == 1 and link["sent"]["data"]["messages"] == 1
    assert len(link["rtt_s"]) == 1


def test_deferred_reply_from_the_message_iterator():
    async def scenario():
        async with udp_node("fog1") as fog, udp_node("edge1") as edge:

            async def serve():
                async for env in fog.messages():
                    fog.reply(env, env.body + 1)

            server = asyncio.create_task(serve())
            try:
                return [await edge.request("fog1", "inc", i, timeout_s=2.0) for i in range(3)]
            finally:
                server.cancel()

    assert [r.body for r in asyncio.run(scenario())] == [1, 2, 3]


def test_request_times_out_in_simulated_seconds(monkeypatch):
    """At 50x, 3 copies of 1 simulated second each; nobody listens on fog1's port."""
    monkeypatch.setenv("SWARMSITL_SPEED", "50")

    async def scenario():
        async with udp_node("edge1") as edge:
            with pytest.raises(RequestTimeout, match="3 copies"):
                await edge.request("fog1", "ping", None, timeout_s=1.0, retries=2)
            return edge.stats.peers["fog1"]

    link = asyncio.run(scenario())
    assert link.sent["control"].messages == 3 and (link.retries, link.timeouts) == (2, 1)


def test_cancelled_request_stops_retrying(monkeypatch):
    monkeypatch.setenv("SWARMSITL_SPEED", "50")

    async def scenario():
        async with udp_node("edge1") as edge:
            with pytest.raises(TimeoutError):
                await asyncio.wait_for(edge.request("fog1", "q", None, timeout_s=100.0), 0.05)
            return edge.node.next_deadline_s()

    assert asyncio.run(scenario()) is None


def test_recv_timeout_raises_timeout_error(monkeypatch):
    monkeypatch.setenv("SWARMSITL_SPEED", "50")

    async def scenario():
        async with udp_node("edge1") as edge:
            await edge.recv(timeout_s=1.0)

    with pytest.raises(TimeoutError):
        asyncio.run(scenario())


def test_async_node_survives_a_handler_exception(caplog):
    async def scenario():
        async with udp_node("fog1") as fog, udp_node("edge1") as edge:
            fog.on("div", lambda env: 1 / env.body)
            with pytest.raises(RequestTimeout):
                await edge.request("fog1", "div", 0, timeout_s=0.2, retries=0)
            return await edge.request("fog1", "div", 4, timeout_s=2.0)

    assert asyncio.run(scenario()).body == 0.25
    assert "message handler of node fog1 failed" in caplog.text


def test_port_transport_is_polled_on_a_timer():
    port = FakePort()

    def make(node_id):
        return AsyncNode(
            Node(node_id, CONFIG, PortTransport(port, node_id), clock.now_s), poll_interval_s=0.01
        )

    async def scenario():
        async with make("fog1") as fog, make("edge1") as edge:
            fog.on("echo", lambda env: env.body)
            return await edge.request("fog1", "echo", "hi", timeout_s=5.0)

    assert asyncio.run(scenario()).body == "hi"


def test_from_env_and_net_ping_between_two_processes(tmp_path):
    """Two net_ping processes (edge1, cloud) ping each other over UDP; fog1 is absent."""
    net = tmp_path / "net.yaml"
    net.write_text(json.dumps(NET))  # JSON is YAML
    procs = {}
    for node_id in ("cloud", "edge1"):
        env = dict(
            os.environ,
            PYTHONPATH=str(SRC),
            SWARMSITL_NET=str(net),
            SWARMSITL_NODE=node_id,
            SWARMSITL_SPEED="5",
        )
        procs[node_id] = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "companion.scripts.net_ping",
                "--count",
                "2",
                "--interval-s",
                "0.2",
                "--timeout-s",
                "2",
                "--retries",
                "5",  # 2.4 s of wall time at 5x for the peer process to start on a loaded machine
                "--linger-s",
                "3",
                "--records",
                str(tmp_path / f"{node_id}.json"),
            ],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
    outputs = {}
    try:
        for node_id, proc in procs.items():
            outputs[node_id] = proc.communicate(timeout=60)
    finally:
        for proc in procs.values():
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    for node_id, (out, err) in outputs.items():
        peer = "edge1" if node_id == "cloud" else "cloud"
        assert f"SUMMARY {node_id} -> {peer} replies 2/2" in out, err
        assert f"SUMMARY {node_id} -> fog1 replies 0/2" in out
        assert procs[node_id].returncode == 1  # fog1 never answered
    records = json.loads((tmp_path / "edge1.json").read_text())
    assert len(records["peers"]["cloud"]["rtt_s"]) == 2
    assert records["peers"]["fog1"]["timeouts"] == 2
