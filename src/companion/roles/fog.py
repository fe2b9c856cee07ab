"""The fog role: coordinate a cluster of edge nodes and report to the cloud.

Seed 000 (Sec. 3): fog UAVs coordinate the edge agents of their cluster, receive their images,
and escalate to the cloud over 4G/LTE. Here the fog node registers with the cloud (request/reply),
answers its edges' ``join`` requests with the cluster, counts their ``status`` and ``image``
messages, and sends the cloud a ``summary`` request every ``summary_period_s``.
"""

from __future__ import annotations

from dataclasses import dataclass

from companion import clock
from companion.net import AsyncNode, Envelope
from companion.roles.asking import ask, ask_until_answered
from companion.roles.cluster import clusters, nodes_with_role
from companion.roles.periodic import every


@dataclass(frozen=True)
class FogParams:
    """Traffic of a fog node, simulated seconds."""

    summary_period_s: float = 5.0
    request_timeout_s: float = 2.0
    """LTE round trips are slower than WiFi ones: a longer timeout before a retry."""
    retries: int = 3


async def run_fog(
    node: AsyncNode,
    duration_s: float,
    params: FogParams,
    counts: dict[str, int] | None = None,
) -> dict[str, int]:
    """Run the fog role for ``duration_s`` simulated seconds; return its counters.

    ``counts`` (filled in place) lets a caller that cancels the role still read them.
    """
    config = node.node.config
    members = clusters(config).get(node.node_id, [])
    clouds = nodes_with_role(config, "cloud")
    cloud = clouds[0] if clouds else None
    counts = {} if counts is None else counts
    counts.update(
        registered=0,
        joins=0,
        status=0,
        images=0,
        image_bytes=0,
        summaries_acked=0,
        timeouts=0,
    )
    last_status: dict[str, float] = {}

    def on_status(env: Envelope) -> None:
        counts["status"] += 1
        last_status[env.src] = env.sent_s

    def on_image(env: Envelope) -> None:
        counts["images"] += 1
        body = env.body if isinstance(env.body, dict) else {}
        counts["image_bytes"] += len(body.get("jpeg", b""))

    def on_join(env: Envelope) -> dict[str, object]:
        counts["joins"] += 1
        return {"fog": node.node_id, "cluster": members}

    node.on("status", on_status)
    node.on("image", on_image)
    node.on("join", on_join)
    node.on("ping", lambda env: {"from": node.node_id})
    end_s = clock.now_s() + duration_s

    async def summary() -> None:
        with node.task("T_report"):
            body = {
                "edges": dict(last_status),
                "images": counts["images"],
                "image_bytes": counts["image_bytes"],
            }
            acked = await ask(
                node, cloud, "summary", body, params.request_timeout_s, params.retries, "data"
            )
            counts["summaries_acked"] += acked
            counts["timeouts"] += not acked

    if cloud is not None:
        with node.task("T_conn"):
            registered, timeouts = await ask_until_answered(
                node, cloud, "register", {"cluster": members},
                params.request_timeout_s, params.retries, end_s,
            )  # fmt: skip
            counts["registered"] = int(registered)
            counts["timeouts"] += timeouts
        await every(params.summary_period_s, end_s, summary)
    await clock.sleep(max(0.0, end_s - clock.now_s()))
    return counts
