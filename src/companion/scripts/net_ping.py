"""Ping every other node of the network and print the round-trip times.

Runs unchanged on a Raspberry Pi over real UDP and under swarmsitl (through the link
emulator): the network comes from ``SWARMSITL_NET`` (YAML path) and ``SWARMSITL_NODE`` (this
node's id). Every node running it also answers the others' pings, and keeps answering for
``--linger-s`` after its own pings so slower peers can finish. Times are simulated seconds
(``SWARMSITL_SPEED``), 1:1 with wall time on real hardware.

Example, three terminals (or three Pis, each with its own id)::

    SWARMSITL_NET=net.yaml SWARMSITL_NODE=cloud python -m companion.scripts.net_ping
    SWARMSITL_NET=net.yaml SWARMSITL_NODE=fog1  python -m companion.scripts.net_ping --count 5

Output: one line per ping (``fog1 -> cloud seq 0 rtt_ms 0.41 attempt 1`` or ``... timeout``;
the RTT is that of the answered copy, ``attempt`` > 1 when earlier copies got no reply in
time) and a ``SUMMARY`` line per peer. Exit status 0 if every peer answered at least once.
"""

from __future__ import annotations

import argparse
import asyncio
import statistics
import sys

from companion import clock
from companion.net import AsyncNode, Envelope, RequestTimeout


async def ping_peer(node: AsyncNode, peer: str, args: argparse.Namespace) -> list[float]:
    """Ping ``peer`` ``args.count`` times; print and return the RTTs of the answered pings, s."""
    rtts: list[float] = []
    for seq in range(args.count):
        try:
            reply = await node.request(peer, "ping", {"seq": seq}, args.timeout_s, args.retries)
        except RequestTimeout:
            print(f"{node.node_id} -> {peer} seq {seq} timeout", flush=True)
        else:
            rtt_s = node.stats.peers[peer].rtt_s[-1]  # of the answered copy
            rtts.append(rtt_s)
            print(
                f"{node.node_id} -> {peer} seq {seq} rtt_ms {rtt_s * 1e3:.2f} "
                f"attempt {reply.attempt}",
                flush=True,
            )
        await clock.sleep(args.interval_s)
    return rtts


async def main_async(args: argparse.Namespace) -> int:
    """Answer pings, ping every other node, linger, print the summary; return the exit code."""
    node = AsyncNode.from_env()
    async with node:
        node.on("ping", lambda env: _pong(node, env))
        peers = [n for n in node.node.config.nodes if n != node.node_id]
        results = await asyncio.gather(*(ping_peer(node, p, args) for p in peers))
        await clock.sleep(args.linger_s)
        if args.records:
            node.write_records(args.records)
    for peer, rtts in zip(peers, results, strict=True):
        mean_ms = f"{statistics.fmean(rtts) * 1e3:.2f}" if rtts else "nan"
        print(
            f"SUMMARY {node.node_id} -> {peer} replies {len(rtts)}/{args.count} "
            f"rtt_mean_ms {mean_ms}",
            flush=True,
        )
    return 0 if all(results) else 1


def _pong(node: AsyncNode, env: Envelope) -> dict[str, object]:
    return {
        "seq": env.body.get("seq") if isinstance(env.body, dict) else None,
        "from": node.node_id,
    }


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--count", type=int, default=3, help="pings per peer (default 3), e.g. --count 10"
    )
    parser.add_argument(
        "--interval-s",
        type=float,
        default=0.5,
        help="pause between pings, simulated s (default 0.5), e.g. --interval-s 1",
    )
    parser.add_argument(
        "--timeout-s",
        type=float,
        default=1.0,
        help="wait per copy before a retry, simulated s (default 1), e.g. --timeout-s 0.2",
    )
    parser.add_argument(
        "--retries",
        type=int,
        default=2,
        help="retransmissions per ping (default 2), e.g. --retries 0",
    )
    parser.add_argument(
        "--linger-s",
        type=float,
        default=2.0,
        help="keep answering after the last ping, simulated s (default 2), e.g. --linger-s 5",
    )
    parser.add_argument(
        "--records",
        default=None,
        help="write the node's message records (JSON) here, e.g. --records edge1.json",
    )
    args = parser.parse_args(argv)
    return asyncio.run(main_async(args))


if __name__ == "__main__":
    sys.exit(main())
