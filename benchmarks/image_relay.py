"""Images edge -> fog -> cloud through the link models: bytes, quality, latency, energy per hop.

Two edges send one frame each per simulated second to their fog over the ``wifi-edge-fog``
preset; the fog decodes each and sends it on to the cloud over ``lte``, encoded again at the same
level or lower (seed 000's successive compression); the cloud decodes. The nodes are the real
messaging core on ``sitl.links.InProcessPort`` in 2 ms lockstep steps of simulated time. The
frames are held-out renders of the project's scenes (``harness.imagery``), so PSNR against the
raw frame is known at both hops. Codec times are wall time on this machine.

    python benchmarks/image_relay.py          # learned codec: T_compress, levels 1, 3, 5
    python benchmarks/image_relay.py --codec jpeg --seconds 10

The last line is ``RESULT bytes_level5=... psnr_fog_db=... psnr_cloud_db=... lte_tx_mj=...
codec_ms=...`` for the T_compress run.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from companion.imaging.chunks import Frame
from companion.imaging.image_source import SyntheticImages
from companion.imaging.jpeg_codec import jpeg_codec
from companion.imaging.link_budget import LTE_UPLINK, WIFI_EDGE_FOG
from companion.imaging.relay import (
    CodecApi,
    ImageReceiver,
    ImageRecord,
    ImageSender,
    ImagingParams,
    project_codec,
)
from companion.net import NetConfig, Node, PortTransport
from sitl.links.config import LinksConfig
from sitl.links.inprocess import InProcessPort
from sitl.links.network import LinkNetwork

NET = NetConfig.from_dict(
    {
        "nodes": {
            "cloud": {"role": "cloud", "address": "127.0.0.1:47190"},
            "fog1": {"role": "fog", "address": "127.0.0.1:47191", "groups": ["c1"]},
            "edge1": {"role": "edge", "address": "127.0.0.1:47192", "groups": ["c1"]},
            "edge2": {"role": "edge", "address": "127.0.0.1:47193", "groups": ["c1"]},
        }
    }
)
STEP_S = 0.002


def psnr_db(a: np.ndarray, b: np.ndarray) -> float:
    """PSNR of two uint8 images, dB."""
    mse = float(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2))
    return math.inf if mse == 0 else 10 * math.log10(255.0**2 / mse)


def run(
    codec: CodecApi, frames: list[np.ndarray], level: int | None, seconds: float, seed: int
) -> dict:
    """One relay run; per hop: the sender's and the receiver's records, PSNR vs raw."""
    now = [0.0]
    network = LinkNetwork(LinksConfig.load(), seed=seed)
    for node_id, spec in NET.nodes.items():
        network.add_node(node_id, spec.role)
    port = InProcessPort(network, lambda: now[0])
    nodes = {n: Node(n, NET, PortTransport(port, n), lambda: now[0]) for n in NET.nodes}
    params = ImagingParams(level=level)
    edges = {
        e: ImageSender(nodes[e], "fog1", codec, WIFI_EDGE_FOG, 1.0, params)
        for e in ("edge1", "edge2")
    }
    to_cloud = ImageSender(nodes["fog1"], "cloud", codec, LTE_UPLINK, 0.5, params)
    raw, psnr = {}, {"fog1": [], "cloud": []}

    def at_fog(frame: Frame, image: np.ndarray, record: ImageRecord) -> None:
        psnr["fog1"].append(psnr_db(image, raw[record.origin, record.origin_frame]))
        to_cloud.send(image, record.capture_s, record.origin, record.origin_frame, record.level)

    def at_cloud(frame: Frame, image: np.ndarray, record: ImageRecord) -> None:
        psnr["cloud"].append(psnr_db(image, raw[record.origin, record.origin_frame]))

    fog = ImageReceiver(nodes["fog1"], codec, params, at_fog)
    cloud = ImageReceiver(nodes["cloud"], codec, params, at_cloud)
    k = 0
    next_s = 0.0
    while now[0] < seconds + 2.0:
        if now[0] >= next_s and now[0] < seconds:
            for j, (edge, sender) in enumerate(edges.items()):
                image = frames[(k + j * len(frames) // 2) % len(frames)]
                raw[edge, len(sender.records)] = image
                sender.send(image, now[0])
            k += 1
            next_s += 1.0
        for node in nodes.values():
            node.poll()
        now[0] += STEP_S
    sent = [r for s in edges.values() for r in s.records]
    return {
        "edge->fog": (sent, fog.records, psnr["fog1"], fog.finish()),
        "fog->cloud": (to_cloud.records, cloud.records, psnr["cloud"], cloud.finish()),
    }


def main() -> None:
    """Command-line entry point."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--codec", choices=("learned", "jpeg"), default="learned")
    parser.add_argument("--seconds", type=float, default=24.0, help="simulated seconds of images")
    parser.add_argument("--images", type=int, default=12, help="held-out renders to cycle through")
    parser.add_argument("--seed", type=int, default=0, help="seed of the renders and the links")
    parser.add_argument("--synthetic", action="store_true", help="synthetic textures, no renders")
    args = parser.parse_args()
    codec = jpeg_codec() if args.codec == "jpeg" else project_codec()
    if args.synthetic:
        source = SyntheticImages(np.random.default_rng(args.seed))
        frames = [source() for _ in range(args.images)]
    else:
        from harness.imagery import render_images

        frames = [rgb for rgb, _ in render_images("heldout", args.images, 320, 240, args.seed)]
    print(f"codec {args.codec}, levels {codec.levels}, {len(frames)} frames 320x240")
    print("level  hop         sent dec  bytes   bpp  PSNR dB  lat ms mean/max  radio mJ"
          "  enc ms  dec ms  codec mJ")  # fmt: skip
    result = ""
    for level in (None, *codec.levels[::2]):
        hops = run(codec, frames, level, args.seconds, args.seed)
        for hop, (sent, got, psnr, _) in hops.items():
            lat = [1e3 * r.latency_s for r in got]
            print(
                f"{level or 'auto':>5}  {hop:10s} {len(sent):4d} {len(got):3d} "
                f"{np.mean([r.bytes for r in sent]):6.0f} "
                f"{np.mean([r.bits_per_pixel for r in sent]):5.2f} {np.mean(psnr):8.2f}  "
                f"{np.mean(lat):6.1f} / {np.max(lat):3.0f}  "
                f"{1e3 * np.mean([r.tx_j for r in sent]):8.3f} "
                f"{1e3 * np.median([r.codec_wall_s for r in sent]):7.1f} "
                f"{1e3 * np.median([r.codec_wall_s for r in got]):7.1f} "
                f"{1e3 * np.median([r.codec_j for r in sent]):9.0f}"
            )
        if level is None:
            sent, got, psnr_fog, _ = hops["edge->fog"]
            lte_sent, _, psnr_cloud, _ = hops["fog->cloud"]
            codec_ms = 1e3 * np.median([r.codec_wall_s for r in sent + got])
            result = (
                f"RESULT bytes_level{sent[0].level}={np.mean([r.bytes for r in sent]):.0f} "
                f"psnr_fog_db={np.mean(psnr_fog):.2f} psnr_cloud_db={np.mean(psnr_cloud):.2f} "
                f"lte_tx_mj={1e3 * np.mean([r.tx_j for r in lte_sent]):.1f} codec_ms={codec_ms:.1f}"
            )
    print(result)


if __name__ == "__main__":
    main()
