"""Run this node's role (edge, fog or cloud) from ``SWARMSITL_NET`` / ``SWARMSITL_NODE``.

Example (three terminals, or three Raspberry Pis with their own ids)::

    SWARMSITL_NET=net.yaml SWARMSITL_NODE=cloud python -m companion.roles --duration-s 60
    SWARMSITL_NET=net.yaml SWARMSITL_NODE=fog1  python -m companion.roles --duration-s 60
    SWARMSITL_NET=net.yaml SWARMSITL_NODE=edge1 python -m companion.roles --duration-s 60

Each node runs for ``--duration-s`` simulated seconds (SIGTERM or Ctrl-C ends it early), then
writes its message records (``companion.net`` stats: messages, bytes, latency, RTTs, tasks) as
JSON to ``--records`` (default: ``$SWARMSITL_NET_RECORDS/<node>.json`` when that directory is
set) and prints its counters as one JSON line.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import signal
import sys
import zlib
from pathlib import Path

import numpy as np

from companion.net import AsyncNode
from companion.roles.cloud import run_cloud
from companion.roles.edge import EdgeParams, run_edge
from companion.roles.fog import FogParams, run_fog


async def main_async(args: argparse.Namespace) -> int:
    """Run the role until its duration ends or a stop signal; write the records."""
    node = AsyncNode.from_env()
    role = node.node.config.nodes[node.node_id].role
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    async with node:
        if role == "cloud":
            job = run_cloud(node, args.duration_s, stop)
        elif role == "fog":
            job = run_fog(node, args.duration_s, FogParams())
        elif role == "edge":
            rng = np.random.default_rng([args.seed, zlib.crc32(node.node_id.encode())])
            job = run_edge(node, args.duration_s, EdgeParams(), rng)
        else:
            print(f"role {role!r} has no program here (edge, fog, cloud)", file=sys.stderr)
            return 2
        task = asyncio.ensure_future(job)
        stopper = asyncio.ensure_future(stop.wait())
        await asyncio.wait({task, stopper}, return_when=asyncio.FIRST_COMPLETED)
        counts: object = {"stopped": True}
        if task.done():
            counts = task.result()
        else:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
        stopper.cancel()
        records = args.records or _default_records(node.node_id)
        if records is not None:
            records.parent.mkdir(parents=True, exist_ok=True)
            node.write_records(records)
    print(json.dumps({"node": node.node_id, "role": role, "counts": counts}), flush=True)
    return 0


def _default_records(node_id: str) -> Path | None:
    directory = os.environ.get("SWARMSITL_NET_RECORDS")
    return Path(directory) / f"{node_id}.json" if directory else None


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration-s", type=float, default=60.0, help="simulated seconds to run")
    parser.add_argument("--records", type=Path, default=None, help="JSON file for the records")
    parser.add_argument("--seed", type=int, default=0, help="seed of the payload generator")
    args = parser.parse_args(argv)
    if not args.duration_s > 0:
        parser.error("--duration-s must be > 0")
    return asyncio.run(main_async(args))


if __name__ == "__main__":
    sys.exit(main())
