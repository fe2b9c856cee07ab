"""The edge role: report status and camera images to the fog coordinator, talk to neighbours.

Traffic (seed 000, Sec. 3: edge UAVs send camera images to their fog node and share state with
their neighbours over WiFi): a ``status`` message to the coordinator every ``status_period_s``,
an ``image`` of ``image_bytes`` every ``image_period_s`` (the size of a compressed camera frame;
the autoencoder of issue 11 will produce real ones), a ``ping`` request to each neighbouring edge
every ``ping_period_s``. It first asks the coordinator to ``join`` (request/reply, retried, and
asked again until it answers: the coordinator may start later).
"""

from __future__ import annotations

import asyncio
from dataclasses import dataclass

import numpy as np

from companion import clock
from companion.net import AsyncNode
from companion.roles.asking import ask, ask_until_answered
from companion.roles.cluster import coordinator_of, nodes_with_role
from companion.roles.periodic import every


@dataclass(frozen=True)
class EdgeParams:
    """Traffic of an edge node, simulated seconds and bytes."""

    status_period_s: float = 1.0
    image_period_s: float = 5.0
    image_bytes: int = 12_000
    """A 320x240 JPEG frame is of this order (assumption; issue 11 brings real codec sizes)."""
    ping_period_s: float = 2.0
    request_timeout_s: float = 1.0
    retries: int = 3


async def run_edge(
    node: AsyncNode,
    duration_s: float,
    params: EdgeParams,
    rng: np.random.Generator,
    counts: dict[str, int] | None = None,
) -> dict[str, int]:
    """Run the edge role for ``duration_s`` simulated seconds; return its counters.

    ``counts`` (filled in place) lets a caller that cancels the role still read them.
    """
    config = node.node.config
    fog = coordinator_of(config, node.node_id)
    peers = [e for e in nodes_with_role(config, "edge") if e != node.node_id]
    counts = {} if counts is None else counts
    counts.update(joined=0, status=0, images=0, pings_answered=0, timeouts=0)
    node.on("ping", lambda env: {"from": node.node_id})
    end_s = clock.now_s() + duration_s

    async def request(dst: str, topic: str, body: dict) -> bool:
        answered = await ask(node, dst, topic, body, params.request_timeout_s, params.retries)
        counts["timeouts"] += not answered
        return answered

    async def status() -> None:
        node.send(fog, "status", {"seq": counts["status"], "t_s": clock.now_s()})
        counts["status"] += 1

    async def image() -> None:
        with node.task("T_data"):
            frame = rng.bytes(params.image_bytes)
            node.send(fog, "image", {"seq": counts["images"], "jpeg": frame})
        counts["images"] += 1

    async def ping() -> None:
        answered = await asyncio.gather(*(request(p, "ping", {}) for p in peers))
        counts["pings_answered"] += sum(answered)

    jobs = []
    if fog is not None:
        with node.task("T_conn"):
            joined, timeouts = await ask_until_answered(
                node, fog, "join", {"role": "edge"}, params.request_timeout_s, params.retries, end_s
            )
            counts["joined"] = int(joined)
            counts["timeouts"] += timeouts
        jobs += [every(params.status_period_s, end_s, status)]
        jobs += [every(params.image_period_s, end_s, image)]
    if peers:
        jobs.append(every(params.ping_period_s, end_s, ping))
    await asyncio.gather(*jobs)
    await clock.sleep(max(0.0, end_s - clock.now_s()))
    return counts
