"""Throughput of the link emulator in lockstep: datagrams per second through InProcessPort.

N nodes (edges, fogs and the cloud of seed 000's architecture) exchange datagrams through the
link models in simulation time: each 1 ms step every node sends to peers chosen at random (edge
to edge and fog, fog to fog and cloud, cloud to fog) and every node receives what has arrived.
Wall time and process CPU time cover ``send`` and ``receive`` only (the traffic is drawn
beforehand). It also prints the measured loss per seed-000 link class (``sitl.links.report``).

    python benchmarks/links.py
    python benchmarks/links.py --datagrams 50000 --nodes 20

The last line is ``RESULT datagrams_per_s=... us_per_datagram=...``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from realtime_factor import machine
from sitl.links.config import LinksConfig
from sitl.links.inprocess import InProcessPort
from sitl.links.network import LinkNetwork
from sitl.links.report import loss_table

STEP_S = 1e-3


def build(n_nodes: int, seed: int) -> tuple[LinkNetwork, list[str], dict[str, list[str]]]:
    """The network: a tenth fogs (at least one), one cloud, the rest edges; each node's peers."""
    n_fog = max(1, n_nodes // 10)
    roles = ["cloud"] + ["fog"] * n_fog + ["edge"] * (n_nodes - 1 - n_fog)
    network = LinkNetwork(LinksConfig.load(), seed)
    rng = np.random.default_rng(seed)
    ids = [f"{role}{k}" for k, role in enumerate(roles)]
    for node, role in zip(ids, roles, strict=True):
        network.add_node(node, role)
        if role != "cloud":  # UAVs within 60 m of each other (inside WiFi range)
            network.set_position(node, (*rng.uniform(-30.0, 30.0, 2), 10.0))
    allowed = {
        "edge": {"edge", "fog"},
        "fog": {"edge", "fog", "cloud"},
        "cloud": {"fog"},
    }
    role_of = dict(zip(ids, roles, strict=True))
    peers = {a: [b for b in ids if b != a and role_of[b] in allowed[role_of[a]]] for a in ids}
    return network, ids, peers


def run(n_nodes: int, n_datagrams: int, per_step: int, seed: int) -> tuple[float, float, int]:
    """Wall s, CPU s and datagrams received for ``n_datagrams`` sends in lockstep."""
    network, ids, peers = build(n_nodes, seed)
    rng = np.random.default_rng(seed + 1)
    steps = -(-n_datagrams // per_step)
    senders = rng.integers(0, len(ids), size=(steps, per_step))
    picks = rng.random((steps, per_step))
    sizes = rng.integers(50, 1200, size=(steps, per_step))
    plan = [
        [
            (ids[s], peers[ids[s]][int(p * len(peers[ids[s]]))], bytes(int(n)))
            for s, p, n in zip(senders[k], picks[k], sizes[k], strict=True)
        ]
        for k in range(steps)
    ]
    now = [0.0]
    port = InProcessPort(network, lambda: now[0])
    received = 0
    wall0, cpu0 = time.perf_counter(), time.process_time()
    for k, sends in enumerate(plan):
        now[0] = k * STEP_S
        send = port.send
        for src, dst, data in sends:
            send(src, dst, data)
        for node in ids:
            received += len(port.receive(node))
    now[0] = steps * STEP_S + 10.0
    for node in ids:
        received += len(port.receive(node))
    return time.perf_counter() - wall0, time.process_time() - cpu0, received


def main() -> None:
    """Run the lockstep benchmark, print the loss table and the RESULT line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, default=10, help="nodes (e.g. --nodes 20)")
    parser.add_argument(
        "--datagrams", type=int, default=200_000, help="datagrams sent (e.g. --datagrams 50000)"
    )
    parser.add_argument(
        "--per-step", type=int, default=20, help="datagrams per 1 ms step (e.g. --per-step 50)"
    )
    parser.add_argument("--seed", type=int, default=0, help="seed (e.g. --seed 3)")
    parser.add_argument(
        "--loss-datagrams",
        type=int,
        default=100_000,
        help="datagrams per class for the loss table (e.g. --loss-datagrams 0 to skip it)",
    )
    args = parser.parse_args()
    print(f"machine: {machine()}")
    wall, cpu, received = run(args.nodes, args.datagrams, args.per_step, args.seed)
    sim_s = -(-args.datagrams // args.per_step) * STEP_S
    rate = args.datagrams / wall
    us = cpu / args.datagrams * 1e6
    print(
        f"{args.nodes} nodes, {args.datagrams} datagrams in {sim_s:.1f} s simulated "
        f"({args.per_step} per 1 ms step), {received} received: wall {wall:.2f} s, "
        f"CPU {cpu:.2f} s; CPU per node {cpu / args.nodes / sim_s * 1e3:.1f} ms per "
        "simulated s"
    )
    if args.loss_datagrams > 0:
        print(loss_table(args.loss_datagrams, args.seed))
    print(f"RESULT datagrams_per_s={rate:.0f} us_per_datagram={us:.2f}")


if __name__ == "__main__":
    main()
