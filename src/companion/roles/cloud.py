"""The cloud role: the ground server of seed 000 (Table I: 65 W) that fog nodes report to.

It answers ``register`` (a fog node announces its cluster; the reply lists every cluster the
cloud knows, as seed 000's cloud distributes cluster configurations), ``summary`` (a fog node's
report; acknowledged) and ``ping``, and receives and decodes the images the fog nodes relay
(``companion.imaging``). It serves until ``duration_s`` of simulated time has passed or
the process is told to stop.
"""

from __future__ import annotations

import asyncio
import contextlib

from companion import clock
from companion.imaging.relay import CodecApi, ImageReceiver, ImageRecord, project_codec
from companion.net import AsyncNode, Envelope


async def run_cloud(
    node: AsyncNode,
    duration_s: float,
    stop: asyncio.Event | None = None,
    counts: dict[str, object] | None = None,
    codec: CodecApi | None = None,
    images: list[ImageRecord] | None = None,
) -> dict[str, object]:
    """Serve for ``duration_s`` simulated seconds (or until ``stop`` is set); return counters.

    ``codec``: default the project's learned codec; ``images`` receives a record per image
    decoded (filled in place).
    """
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
    receiver = ImageReceiver(
        node.node,
        codec or project_codec(),
        on_image=lambda frame, image, record: counts.update(images=receiver.decoded),
        records=images,
    )
    counts.update(receiver.counts(), images=0)
    stop = stop or asyncio.Event()
    try:
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(stop.wait(), timeout=duration_s / clock.speed_factor())
    finally:
        counts.update(receiver.finish())
    return counts
