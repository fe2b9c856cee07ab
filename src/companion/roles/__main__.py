"""Run this node's role (edge, fog or cloud) from ``SWARMSITL_NET`` / ``SWARMSITL_NODE``.

Example (three terminals, or three Raspberry Pis with their own ids)::

    SWARMSITL_NET=net.yaml SWARMSITL_NODE=cloud python -m companion.roles --duration-s 60
    SWARMSITL_NET=net.yaml SWARMSITL_NODE=fog1  python -m companion.roles --duration-s 60
    SWARMSITL_NET=net.yaml SWARMSITL_NODE=edge1 python -m companion.roles --duration-s 60

With ``--mavlink udpin:0.0.0.0:14540`` the node also flies its vehicle (take off to
``--altitude-m``, hover while the role runs, land).

Each node runs for ``--duration-s`` simulated seconds (SIGTERM or Ctrl-C ends it earlier), then
writes its message records (``companion.net`` stats: messages, bytes, latency, RTTs, tasks) as
JSON to ``--records`` (default: ``$SWARMSITL_NET_RECORDS/<node>.json`` when that directory is
set), one row per image sent or decoded to ``<node>_images.csv`` beside it, and prints its
counters (with an ``images`` summary) as one JSON line.

Images (docs/compression.md, "On the companion"): an edge sends the frames of its camera stream
(``SWARMSITL_VIDEO_URI``), else the PNGs of ``--images DIR``, else synthetic textures, compressed
with ``--codec`` (``learned``, the default: the ``compression`` package; ``jpeg``: OpenCV JPEG)
at the level
T_compress picks (or ``--image-level``).
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

from companion.imaging.image_source import DirectoryImages, ImageSource, StreamImages
from companion.imaging.relay import (
    CodecApi,
    ImageRecord,
    ImagingParams,
    project_codec,
    summarize,
    write_csv,
)
from companion.net import AsyncNode
from companion.roles.cloud import run_cloud
from companion.roles.edge import EdgeParams, run_edge
from companion.roles.flight import FlightParams, fly_during
from companion.roles.fog import FogParams, run_fog


async def main_async(args: argparse.Namespace) -> int:
    """Run the role until its duration ends or a stop signal; write the records."""
    node = AsyncNode.from_env()
    role = node.node.config.nodes[node.node_id].role
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    counts: dict = {}
    images: list[ImageRecord] = []
    imaging = ImagingParams(level=args.image_level, energy_budget_j=args.image_energy_j)
    try:
        codec = _codec(args.codec)
        if args.image_level is not None and args.image_level not in codec.levels:
            raise ValueError(f"--image-level {args.image_level} is not one of {codec.levels}")
        source = _source(args.images) if role == "edge" else None
    except (ImportError, ValueError) as exc:
        print(f"images: {exc}", file=sys.stderr)
        node.close()
        return 2
    if role == "cloud":
        job = run_cloud(node, args.duration_s, stop, counts, codec, images)
    elif role == "fog":
        params = FogParams(imaging=imaging)
        job = run_fog(node, args.duration_s, params, counts, codec, images)
    elif role == "edge":
        rng = np.random.default_rng([args.seed, zlib.crc32(node.node_id.encode())])
        params = EdgeParams(imaging=imaging)
        job = run_edge(node, args.duration_s, params, rng, counts, codec, source, images)
    else:
        print(f"role {role!r} has no program here (edge, fog, cloud)", file=sys.stderr)
        node.close()
        return 2
    # The role registers its handlers in its first step, before the node reads anything: what
    # peers that started earlier already sent (a fog's first relayed image) would otherwise
    # arrive with no handler to take it.
    task = asyncio.ensure_future(job)
    await asyncio.sleep(0)
    async with node:
        flight = None
        if args.mavlink and role != "cloud":
            flight = asyncio.ensure_future(
                fly_during(FlightParams(args.mavlink, args.altitude_m), task)
            )
        stopper = asyncio.ensure_future(stop.wait())
        await asyncio.wait({task, stopper}, return_when=asyncio.FIRST_COMPLETED)
        stopped = not task.done()
        if stopped:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
        else:
            task.result()  # a role that failed raises here
        stopper.cancel()
        if isinstance(source, StreamImages):
            source.close()
        records = args.records or _default_records(node.node_id)
        if records is not None:
            records.parent.mkdir(parents=True, exist_ok=True)
            node.write_records(records)
            write_csv(images, records.with_name(f"{node.node_id}_images.csv"))
    counts["images_summary"] = summarize(images)
    flown = None
    if flight is not None:
        try:
            flown = await asyncio.wait_for(flight, timeout=180.0)
        except TimeoutError:
            flown = "landing not confirmed within 180 s"
    for sig in (signal.SIGINT, signal.SIGTERM):  # done: a late signal must not print noise
        loop.remove_signal_handler(sig)
        signal.signal(sig, signal.SIG_IGN)
    out = {"node": node.node_id, "role": role, "counts": counts, "stopped": stopped}
    if flown is not None:
        out["flight"] = flown
    print(json.dumps(out), flush=True)
    return 0


def _codec(name: str) -> CodecApi:
    """The codec called ``name``: ``learned`` or ``jpeg``."""
    from companion.imaging.jpeg_codec import jpeg_codec

    if name == "jpeg":
        return jpeg_codec()
    return project_codec()


def _source(directory: Path | None) -> ImageSource | None:
    """The edge's images: the camera stream, else ``directory``, else None (synthetic)."""
    uri = os.environ.get("SWARMSITL_VIDEO_URI")
    if uri:
        return StreamImages(uri)
    return DirectoryImages(directory) if directory is not None else None


def _default_records(node_id: str) -> Path | None:
    directory = os.environ.get("SWARMSITL_NET_RECORDS")
    return Path(directory) / f"{node_id}.json" if directory else None


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration-s", type=float, default=60.0, help="simulated seconds to run")
    parser.add_argument("--records", type=Path, default=None, help="JSON file for the records")
    parser.add_argument("--seed", type=int, default=0, help="seed of the payload generator")
    parser.add_argument(
        "--mavlink",
        default=None,
        help="fly this node's vehicle while the role runs: pymavlink URL of its autopilot, "
        "e.g. udpin:0.0.0.0:14540 (take off, hover, land)",
    )
    parser.add_argument("--altitude-m", type=float, default=10.0, help="take-off height, m")
    parser.add_argument(
        "--codec",
        choices=("learned", "jpeg"),
        default="learned",
        help="image codec: the learned autoencoder (compression package, the default) or "
        "OpenCV JPEG (the baseline), e.g. --codec jpeg",
    )
    parser.add_argument(
        "--images",
        type=Path,
        default=None,
        help="edge: send the PNG/JPEG files of this directory in turn when there is no camera "
        "stream (SWARMSITL_VIDEO_URI), e.g. --images runs/imagery/heldout",
    )
    parser.add_argument(
        "--image-level",
        type=int,
        default=None,
        help="a fixed compression level instead of the T_compress policy, e.g. --image-level 3",
    )
    parser.add_argument(
        "--image-energy-j",
        type=float,
        default=None,
        help="energy each node may spend sending images over the run (codec + radio), J; "
        "lower levels when it runs short, e.g. --image-energy-j 50",
    )
    args = parser.parse_args(argv)
    if not args.duration_s > 0:
        parser.error("--duration-s must be > 0")
    if args.image_energy_j is not None and not args.image_energy_j >= 0:
        parser.error("--image-energy-j must be >= 0")
    return asyncio.run(main_async(args))


if __name__ == "__main__":
    sys.exit(main())
