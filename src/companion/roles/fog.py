"""The fog role: coordinate a cluster of edge nodes and report to the cloud.

Seed 000 (Sec. 3): fog UAVs coordinate the edge agents of their cluster, receive their images,
and escalate to the cloud over 4G/LTE. Here the fog node registers with the cloud (request/reply),
answers its edges' ``join`` requests with the cluster, counts their ``status`` messages, receives
and decodes their images (``companion.imaging``), sends each decoded image on to the cloud
compressed again at a level no higher than it came at (seed 000's successive compression; the
level from T_compress on the LTE link), and sends the cloud a ``summary`` request every
``summary_period_s``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from companion import clock
from companion.imaging.chunks import Frame
from companion.imaging.link_budget import LTE_UPLINK, LinkBudget
from companion.imaging.relay import (
    CodecApi,
    ImageReceiver,
    ImageRecord,
    ImageSender,
    ImagingParams,
    project_codec,
)
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
    relay_images: bool = True
    """Send the edges' images on to the cloud (re-compressed)."""
    edge_image_period_s: float = 5.0
    """Image period of each edge; the fog relays one image per period per edge, s."""
    imaging: ImagingParams = field(default_factory=ImagingParams)
    """Level (or the policy), chunking, energy budget of the images to the cloud."""
    link: LinkBudget = LTE_UPLINK
    """The fog-cloud link as T_compress sees it (bandwidth, J per byte)."""


async def run_fog(
    node: AsyncNode,
    duration_s: float,
    params: FogParams,
    counts: dict[str, int] | None = None,
    codec: CodecApi | None = None,
    images: list[ImageRecord] | None = None,
) -> dict[str, int]:
    """Run the fog role for ``duration_s`` simulated seconds; return its counters.

    ``counts`` (filled in place) lets a caller that cancels the role still read them.
    ``codec``: default the project's learned codec; ``images`` receives a record per image
    decoded and per image relayed (filled in place).
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
        images_relayed=0,
        summaries_acked=0,
        timeouts=0,
    )
    last_status: dict[str, float] = {}
    end_s = clock.now_s() + duration_s
    codec = codec or project_codec()
    images = [] if images is None else images
    to_cloud = None
    if cloud is not None and params.relay_images:
        period_s = params.edge_image_period_s / max(1, len(members))
        to_cloud = ImageSender(
            node.node, cloud, codec, params.link, period_s, params.imaging, end_s, images
        )

    def on_image(frame: Frame, image: np.ndarray, record: ImageRecord) -> None:
        counts["images"] += 1
        counts["image_bytes"] += record.bytes
        if to_cloud is not None:
            with node.task("T_data"):
                to_cloud.send(
                    image, record.capture_s, record.origin, record.origin_frame, record.level
                )
            counts["images_relayed"] += 1

    receiver = ImageReceiver(node.node, codec, params.imaging, on_image, images)

    def on_status(env: Envelope) -> None:
        counts["status"] += 1
        last_status[env.src] = env.sent_s

    def on_join(env: Envelope) -> dict[str, object]:
        counts["joins"] += 1
        return {"fog": node.node_id, "cluster": members}

    node.on("status", on_status)
    node.on("join", on_join)
    node.on("ping", lambda env: {"from": node.node_id})

    async def summary() -> None:
        receiver.expire()
        counts.update(receiver.counts())
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

    try:
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
    finally:
        counts.update(receiver.finish())
        if to_cloud is not None:
            counts["image_send_errors"] = to_cloud.send_errors
    return counts
