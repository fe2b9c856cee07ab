"""The edge role: report status and camera images to the fog coordinator, talk to neighbours.

Traffic (seed 000, Sec. 3: edge UAVs send camera images to their fog node and share state with
their neighbours over WiFi): a ``status`` message to the coordinator every ``status_period_s``,
a camera image every ``image_period_s``, a ``ping`` request to each neighbouring edge every
``ping_period_s``. It first asks the coordinator to ``join`` (request/reply, retried, and asked
again until it answers: the coordinator may start later).

Images are real codec output (``companion.imaging``): the latest camera frame (or the next image
of the given source), compressed at the level seed 000's T_compress policy picks from the WiFi
link's bandwidth and the energy budget, sent as ``image_chunk`` messages. An image that cannot
be read or encoded is counted (``image_errors``) and reported once on stderr; the role goes on.
"""

from __future__ import annotations

import asyncio
import sys
from dataclasses import dataclass, field

import numpy as np

from companion import clock
from companion.imaging.image_source import ImageSource, SyntheticImages
from companion.imaging.link_budget import WIFI_EDGE_FOG, LinkBudget
from companion.imaging.relay import (
    CodecApi,
    ImageRecord,
    ImageSender,
    ImagingParams,
    project_codec,
)
from companion.net import AsyncNode
from companion.roles.asking import ask, ask_until_answered
from companion.roles.cluster import coordinator_of, nodes_with_role
from companion.roles.periodic import every


@dataclass(frozen=True)
class EdgeParams:
    """Traffic of an edge node, simulated seconds and bytes."""

    status_period_s: float = 1.0
    image_period_s: float = 5.0
    ping_period_s: float = 2.0
    request_timeout_s: float = 1.0
    retries: int = 3
    imaging: ImagingParams = field(default_factory=ImagingParams)
    """Level (or the policy), chunking, energy budget of the images."""
    link: LinkBudget = WIFI_EDGE_FOG
    """The edge-fog link as T_compress sees it (bandwidth, J per byte)."""


async def run_edge(
    node: AsyncNode,
    duration_s: float,
    params: EdgeParams,
    rng: np.random.Generator,
    counts: dict[str, int] | None = None,
    codec: CodecApi | None = None,
    source: ImageSource | None = None,
    images: list[ImageRecord] | None = None,
) -> dict[str, int]:
    """Run the edge role for ``duration_s`` simulated seconds; return its counters.

    ``counts`` (filled in place) lets a caller that cancels the role still read them.
    ``codec``: default the project's learned codec (``compression``); ``source``: where images
    come from (default synthetic textures drawn from ``rng``); ``images`` receives a record per
    image sent (filled in place).
    """
    config = node.node.config
    fog = coordinator_of(config, node.node_id)
    peers = [e for e in nodes_with_role(config, "edge") if e != node.node_id]
    counts = {} if counts is None else counts
    counts.update(joined=0, status=0, images=0, pings_answered=0, timeouts=0)
    counts.update(images_skipped=0, image_errors=0, image_bytes=0, image_level=0)
    counts.update(image_send_errors=0)
    node.on("ping", lambda env: {"from": node.node_id})
    end_s = clock.now_s() + duration_s
    source = source or SyntheticImages(rng)
    sender = None
    if fog is not None:
        codec = codec or project_codec()
        sender = ImageSender(
            node.node, fog, codec, params.link, params.image_period_s, params.imaging, end_s, images
        )

    async def request(dst: str, topic: str, body: dict) -> bool:
        answered = await ask(node, dst, topic, body, params.request_timeout_s, params.retries)
        counts["timeouts"] += not answered
        return answered

    async def status() -> None:
        node.send(fog, "status", {"seq": counts["status"], "t_s": clock.now_s()})
        counts["status"] += 1

    async def image() -> None:
        assert sender is not None
        try:
            frame = source()
            if frame is None:  # the camera has not delivered a frame yet
                counts["images_skipped"] += 1
                return
            with node.task("T_data"):
                record = sender.send(frame, clock.now_s())
        except ValueError as exc:  # an unreadable file, an image the codec refuses
            counts["image_errors"] += 1
            if counts["image_errors"] == 1:
                print(f"{node.node_id}: image not sent: {exc}", file=sys.stderr, flush=True)
            return
        counts["images"] += 1
        counts["image_bytes"] += record.bytes
        counts["image_level"] = record.level
        counts["image_send_errors"] = sender.send_errors

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
