"""The cloud role: the ground server of seed 000 (Table I: 65 W) that fog nodes report to.

It answers ``register`` (a fog node announces its cluster; the reply lists every cluster the
cloud knows, as seed 000's cloud distributes cluster configurations), ``summary`` (a fog node's
report; acknowledged) and ``ping``. It serves until ``duration_s`` of simulated time has passed or
the process is told to stop.
"""

from __future__ import annotations

import asyncio
import contextlib

from companion import clock
from companion.net import AsyncNode, Envelope


async def run_cloud(
    node: AsyncNode,
    duration_s: float,
    stop: asyncio.Event | None = None,
    counts: dict[str, object] | None = None,
) -> dict[str, object]:
    """Serve for ``duration_s`` simulated seconds (or until ``stop`` is set); return counters."""
    registered: dict[str, list[str]] = {}
    counts = {} if counts is None else counts
    counts.update(registrations=0, summaries=0, clusters=registered)

    def on_register(env: Envelope) -> dict[str, object]:
        body = env.body if isinstance(env.body, dict) else {}
        cluster = body.get("cluster", [])
        registered[env.src] = [str(m) for m in cluster] if isinstance(cluster, list) else []
        counts["registrations"] = int(counts["registrations"]) + 1
        return {"clusters": registered}

    def on_summary(env: Envelope) -> dict[str, object]:
        counts["summaries"] = int(counts["summaries"]) + 1
        return {"ack": True}

    node.on("register", on_register)
    node.on("summary", on_summary)
    node.on("ping", lambda env: {"from": node.node_id})
    stop = stop or asyncio.Event()
    with contextlib.suppress(TimeoutError):
        await asyncio.wait_for(stop.wait(), timeout=duration_s / clock.speed_factor())
    return counts
