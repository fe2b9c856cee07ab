"""Node messaging at swarm fidelity: CPU per delivered message of broadcast + poll among N nodes.

N edge nodes (``--sizes``, default 10, 40, 80) on the shipped link models (WiFi edge-edge:
1.25 % loss, exponential jitter, range edge at 100 m; the nodes within 60 m of each other) in
lockstep over an ``InProcessPort``, as the swarm engine drives them: every 0.1 s of simulated
time each node polls (decode, records, dispatch) and broadcasts a small dict (seed 001's ACO
position message) to the N - 1 others. The figure is process CPU time per message a node's
``poll`` returned (send, link model, delivery queue and receive together), after one untimed
round that creates the links. Three paths, each in its own process, alternated ``--repeats``
times (the minimum is kept, so other load on the machine matters less):

* ``broadcast``: ``Node.broadcast``, this checkout;
* ``unicast``: the same traffic as N - 1 ``Node.send`` calls per node (the plain path, one
  envelope encoded per recipient), this checkout;
* ``reference``: ``Node.broadcast`` of the implementation at ``--against`` (default
  ``REFERENCE_REV``, the last commit before the broadcast fast path), its ``src/`` taken with
  ``git archive``; skipped with a note when the revision is not in this repository.

Every path delivers the same messages (the same seed and traffic: the count is checked).

    python benchmarks/net_broadcast.py
    python benchmarks/net_broadcast.py --sizes 80 --repeats 5
    python benchmarks/net_broadcast.py --against ""          # no reference implementation

The last line is ``RESULT us_per_msg_10=... us_per_msg_40=... us_per_msg_80=...
vs_unicast_80=... vs_reference_80=...`` (per size; ``vs_*``: that path's CPU per message over
the broadcast's).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tarfile
import tempfile
import time
from io import BytesIO
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
REFERENCE_REV = "184c30f"
"""The commit before the broadcast fast path (per-recipient encode, heap delivery queue)."""
BODY = {"k": 3, "t": 12.3456, "prio": 4, "s": [1.0, 2.0, 3.0], "p": [4.0, 5.5, 6.25], "v": [0.1]}
"""A message as seed 001's ACO role broadcasts it (index, time, priority, start, position,
velocity; here with a one-element velocity)."""
STEP_S = 0.1
"""Simulated time between two decisions, s."""


def measure(n: int, messages: int, mode: str, seed: int) -> dict:
    """CPU and wall seconds and messages delivered for about ``messages`` deliveries."""
    import numpy as np

    from companion.net.config import NetConfig, NodeSpec
    from companion.net.node import Node
    from companion.net.transport import PortTransport
    from sitl.links.config import LinksConfig
    from sitl.links.inprocess import InProcessPort
    from sitl.links.network import LinkNetwork

    network = LinkNetwork(LinksConfig.load(), seed)
    ids = [f"vehicle{k + 1}" for k in range(n)]
    place = np.random.default_rng(seed)
    for node_id in ids:
        network.add_node(node_id, "edge")
        network.set_position(node_id, (*place.uniform(0.0, 42.0, 2), 20.0))
    now = [0.0]
    port = InProcessPort(network, lambda: now[0])
    config = NetConfig({i: NodeSpec(i, "edge", ("127.0.0.1", 1 + k)) for k, i in enumerate(ids)})
    nodes = [Node(i, config, PortTransport(port, i), lambda: now[0]) for i in ids]
    rounds = max(3, messages // max(1, n * (n - 1)))
    delivered = 0
    cpu0 = wall0 = 0.0
    for r in range(-1, rounds + 1):  # round -1 creates the links; the last one only polls
        if r == 0:
            delivered = 0
            cpu0, wall0 = time.process_time(), time.perf_counter()
        now[0] = (r + 1) * STEP_S
        for node in nodes:
            delivered += len(node.poll())
            if r == rounds:
                continue
            if mode == "unicast":
                for dst in ids:
                    if dst != node.node_id:
                        node.send(dst, "pos", BODY)
            else:
                node.broadcast("pos", BODY)
    return {
        "cpu_s": time.process_time() - cpu0,
        "wall_s": time.perf_counter() - wall0,
        "delivered": delivered,
        "rounds": rounds,
    }


def reference_src(rev: str, into: Path) -> Path | None:
    """``src/`` of ``rev`` unpacked under ``into`` (None if git does not know the revision)."""
    try:
        archive = subprocess.run(
            ["git", "-C", str(REPO), "archive", rev, "src"], capture_output=True, check=True
        ).stdout
    except (OSError, subprocess.CalledProcessError):
        return None
    with tarfile.open(fileobj=BytesIO(archive)) as tar:
        tar.extractall(into, filter="data")
    return into / "src"


def run_worker(src: Path, n: int, messages: int, mode: str, seed: int) -> dict:
    """``measure`` in a fresh process importing the project from ``src``."""
    env = {**os.environ, "PYTHONPATH": str(src)}
    args = [sys.executable, __file__, "--worker", f"{n},{messages},{mode},{seed}"]
    out = subprocess.run(args, env=env, capture_output=True, text=True, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main() -> None:
    """Alternate the paths per size, print the table and the RESULT line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="10,40,80", help="node counts (e.g. --sizes 80)")
    parser.add_argument(
        "--messages", type=int, default=60_000, help="deliveries per measurement (e.g. 20000)"
    )
    parser.add_argument("--repeats", type=int, default=3, help="runs of each path (e.g. 5)")
    parser.add_argument("--seed", type=int, default=1, help="link and placement seed")
    parser.add_argument("--against", default=REFERENCE_REV, help='reference revision ("" for none)')
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        n, messages, mode, seed = args.worker.split(",")
        print(json.dumps(measure(int(n), int(messages), mode, int(seed))))
        return

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from realtime_factor import machine

    print(f"machine: {machine()}")
    sizes = [int(s) for s in args.sizes.split(",") if s]
    with tempfile.TemporaryDirectory() as tmp:
        paths = {"broadcast": REPO / "src", "unicast": REPO / "src"}
        if args.against:
            ref = reference_src(args.against, Path(tmp))
            if ref is None:
                print(f"reference {args.against!r}: not in this repository, skipped")
            else:
                paths["reference"] = ref
                print(f"reference: Node.broadcast at {args.against}")
        result: dict[str, float] = {}
        print(f"{'N':>4} {'path':>10} {'us/msg CPU':>11} {'us/msg wall':>12} {'messages':>9}")
        for n in sizes:
            best: dict[str, dict] = {}
            for _ in range(args.repeats):
                for path, src in paths.items():
                    mode = "unicast" if path == "unicast" else "broadcast"
                    got = run_worker(src, n, args.messages, mode, args.seed)
                    if path not in best or got["cpu_s"] < best[path]["cpu_s"]:
                        best[path] = got
            counts = {path: got["delivered"] for path, got in best.items()}
            if len(set(counts.values())) != 1:
                raise SystemExit(f"N={n}: the paths delivered different counts {counts}")
            us = {path: 1e6 * got["cpu_s"] / got["delivered"] for path, got in best.items()}
            for path, got in best.items():
                wall_us = 1e6 * got["wall_s"] / got["delivered"]
                print(f"{n:>4} {path:>10} {us[path]:>11.2f} {wall_us:>12.2f} {got['delivered']:>9}")
            result[f"us_per_msg_{n}"] = us["broadcast"]
            for path in ("unicast", "reference"):
                if path in us:
                    result[f"vs_{path}_{n}"] = us[path] / us["broadcast"]
    print("RESULT " + " ".join(f"{k}={v:.2f}" for k, v in result.items()))


if __name__ == "__main__":
    main()
