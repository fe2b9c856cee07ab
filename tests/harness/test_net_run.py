"""The run's messaging network inside the simulation: real UDP nodes, the router on the
simulation clock, the vehicles' positions driving WiFi range, records and energy."""

from __future__ import annotations

import numpy as np
import pytest

from companion.net import NetConfig, Node, UdpTransport
from harness.net.plan import NetPlan, NetRun
from harness.net.roles import attach
from harness.run.ports import free_ports
from harness.sim.link_models import links_config
from harness.sim.simulation import Simulation, SimulationConfig
from sitl.links.inprocess import InProcessPort
from sitl.links.network import LinkNetwork

pytestmark = pytest.mark.sockets


def _sim(net: NetRun, n: int, spacing_m: float = 5.0) -> Simulation:
    return Simulation(
        SimulationConfig(
            n_vehicles=n, seed=2, mavlink=False, record_hz=0, mocap_port=0,
            spacing_m=spacing_m, router=net.router,
        )
    )  # fmt: skip


def _nodes(net: NetRun, sim: Simulation, ids: list[str]) -> dict[str, Node]:
    config = NetConfig.from_dict(net.plan.net_file())
    return {i: Node(i, config, UdpTransport(config, i), lambda: sim.time_s) for i in ids}


def test_datagrams_cross_the_router_in_simulation_time(tmp_path):
    """Every message edge1 sends to fog1 arrives after its modelled delay (simulated time),
    or is dropped by the link model; the receiver's count equals the model's."""
    ports = free_ports()
    plan = NetPlan(("edge", "fog"), cloud=True, node_base=ports.net, proxy_base=ports.net_proxy)
    net = NetRun(plan, seed=5, out_dir=tmp_path)
    sim = _sim(net, 2)
    nodes = _nodes(net, sim, ["edge1", "fog1", "cloud"])
    try:
        attach(net, sim)
        received = []
        sent_at = {}
        for k in range(300):
            sent_at[k] = sim.time_s
            nodes["edge1"].send("fog1", "status", {"k": k, "pad": b"x" * 400})
            for _ in range(10):  # 20 ms of simulated time between messages
                sim.step()
                received += [(env.body["k"], sim.time_s) for env in nodes["fog1"].poll()]
        sim.run_lockstep(0.5)
        received += [(env.body["k"], sim.time_s) for env in nodes["fog1"].poll()]
        records = net.network.records(sim.time_s)
        edge_fog = records["directions"]["edge->fog"]
        assert len(received) == edge_fog["datagrams_delivered"] < 300  # 0.75 % loss
        assert edge_fog["datagrams_submitted"] == 300
        delays = np.array([t - sent_at[k] for k, t in received])
        # WiFi: 1 ms fixed + exponential jitter; the router polls every 4 ms of sim time.
        assert delays.min() >= 0.001 and np.median(delays) < 0.02
        # The same message crosses at once over plain UDP: the delay is the model's, in sim time.
        report = net.report(0.0, sim.time_s)
        assert report["link_classes"]["edge-fog"]["datagrams_submitted"] == 300
        energy = report["energy"]["nodes"]
        assert energy["cloud"]["total_j"] == pytest.approx(65.0 * sim.time_s)
        assert energy["edge1"]["airtime_s"]["wifi"] > 0
    finally:
        for node in nodes.values():
            node.close()
        sim.close()


def test_vehicles_beyond_wifi_range_lose_everything(tmp_path):
    """The vehicles' positions reach the network: 300 m apart, WiFi (range 100 m) drops all."""
    ports = free_ports()
    plan = NetPlan(("edge", "edge"), cloud=False, node_base=ports.net, proxy_base=ports.net_proxy)
    net = NetRun(plan, seed=5, out_dir=tmp_path)
    sim = _sim(net, 2, spacing_m=300.0)
    nodes = _nodes(net, sim, ["edge1", "edge2"])
    try:
        attach(net, sim)
        sim.run_lockstep(0.2)  # positions known
        for _ in range(50):
            nodes["edge1"].send("edge2", "status", {})
            sim.run_lockstep(0.02)
        assert nodes["edge2"].poll() == []
        drops = net.network.records(sim.time_s)["classes"]["edge-edge"]["drops"]
        assert drops == {"range": 50}
    finally:
        for node in nodes.values():
            node.close()
        sim.close()


def test_paced_router_and_lockstep_port_agree(tmp_path):
    """The same traffic through the UDP router (polled on a simulated clock) and through the
    lockstep in-process port gives the same deliveries, at the same poll, and the same drops."""
    ports = free_ports()
    plan = NetPlan(("edge", "fog"), cloud=True, node_base=ports.net, proxy_base=ports.net_proxy)
    paced = NetRun(plan, seed=9, out_dir=tmp_path)
    lockstep = LinkNetwork(links_config(), seed=9)
    for node in plan.nodes():
        lockstep.add_node(node.node_id, node.role)
    now = [0.0]
    port = InProcessPort(lockstep, lambda: now[0])
    config = NetConfig.from_dict(plan.net_file())
    senders = {i: UdpTransport(config, i) for i in ("edge1", "fog1", "cloud")}
    traffic = [("edge1", "fog1"), ("fog1", "cloud"), ("cloud", "fog1"), ("fog1", "edge1")]
    got_paced: dict[str, list] = {i: [] for i in senders}
    got_lockstep: dict[str, list] = {i: [] for i in senders}
    try:
        for tick in range(2000):  # 4 ms polls, 8 s
            now[0] = tick * 0.004
            for src, dst in traffic if tick % 3 == 0 else ():
                data = f"{src}>{dst}#{tick}".encode() + bytes(300)
                senders[src].send(dst, data)
                port.send(src, dst, data)
            if tick % 3 == 0:
                _wait_readable(paced)
            paced.router.poll(now[0])
            for node_id, transport in senders.items():
                got_paced[node_id] += [(tick, d[:40]) for d in transport.receive()]
                got_lockstep[node_id] += [(tick, d[:40]) for d in port.receive(node_id)]
        assert got_paced == got_lockstep
        assert sum(map(len, got_paced.values())) > 0.9 * 4 * 667
        assert paced.network.records(8.0)["classes"] == lockstep.records(8.0)["classes"]
    finally:
        for transport in senders.values():
            transport.close()
        paced.router.close()


def _wait_readable(net: NetRun) -> None:
    """Let the kernel hand the datagrams just sent to the router's sockets (loopback)."""
    import select

    select.select(net.router.filenos(), [], [], 0.01)
