"""Images from edge to fog to cloud through the link models (WiFi, LTE) in simulation time.

The nodes are the real messaging core (``companion.net.Node``) on the lockstep transport the
harness uses (``sitl.links.InProcessPort`` over a ``LinkNetwork`` with the shipped presets), driven
by a clock the test advances: every wait is simulated time.
"""

from __future__ import annotations

import csv
import functools
import math

import numpy as np
import pytest

from companion.imaging.chunks import CHUNK_TOPIC, split
from companion.imaging.compress_level import expected_bytes
from companion.imaging.image_source import DirectoryImages, StreamImages
from companion.imaging.jpeg_codec import jpeg_codec
from companion.imaging.link_budget import LTE_UPLINK, WIFI_EDGE_FOG, LinkBudget
from companion.imaging.relay import (
    CSV_FIELDS,
    CodecApi,
    ImageReceiver,
    ImageSender,
    ImagingParams,
    project_codec,
    summarize,
    write_csv,
)
from companion.net import NetConfig, Node, PortTransport
from harness.run.ports import free_port_block
from sitl.links.config import LinksConfig
from sitl.links.inprocess import InProcessPort
from sitl.links.network import LinkNetwork

BASE = free_port_block(4)
"""Ports of the nodes below, from the suite's allocator (this xdist worker's own slice)."""

NET = NetConfig.from_dict(
    {
        "nodes": {
            "cloud": {"role": "cloud", "address": f"127.0.0.1:{BASE}"},
            "fog1": {"role": "fog", "address": f"127.0.0.1:{BASE + 1}", "groups": ["c1"]},
            "edge1": {"role": "edge", "address": f"127.0.0.1:{BASE + 2}", "groups": ["c1"]},
            "edge2": {"role": "edge", "address": f"127.0.0.1:{BASE + 3}", "groups": ["c1"]},
        }
    }
)
EDGES = ("edge1", "edge2")
STEP_S = 0.002


def test_codec() -> CodecApi:
    """The project's learned codec when it is installed, else OpenCV JPEG."""
    try:
        return project_codec()
    except ImportError:
        return jpeg_codec()


test_codec.__test__ = False  # a helper, not a test


class Clock:
    def __init__(self) -> None:
        self.t_s = 0.0

    def __call__(self) -> float:
        return self.t_s


def psnr_db(a: np.ndarray, b: np.ndarray) -> float:
    mse = float(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2))
    return math.inf if mse == 0 else 10 * math.log10(255.0**2 / mse)


class Relay:
    """Two edges, a fog that decodes and re-compresses for the cloud, a cloud that decodes."""

    def __init__(self, seed: int, edge_params: ImagingParams, fog_params: ImagingParams,
                 fog_link: LinkBudget = LTE_UPLINK, port_wrapper=None) -> None:  # fmt: skip
        self.clock = Clock()
        network = LinkNetwork(LinksConfig.load(), seed=seed)
        for node_id, spec in NET.nodes.items():
            network.add_node(node_id, spec.role)
        self.network = network
        port = InProcessPort(network, self.clock)
        port = port_wrapper(port) if port_wrapper else port
        self.nodes = {n: Node(n, NET, PortTransport(port, n), self.clock) for n in NET.nodes}
        self.codec = test_codec()
        self.raw: dict[tuple[str, int], np.ndarray] = {}
        self.decoded: dict[tuple[str, str, int], np.ndarray] = {}
        self.edges = {
            e: ImageSender(self.nodes[e], "fog1", self.codec, WIFI_EDGE_FOG, 1.0, edge_params)
            for e in EDGES
        }
        self.to_cloud = ImageSender(
            self.nodes["fog1"], "cloud", self.codec, fog_link, 0.5, fog_params
        )

        def relay(frame, image, record):
            self.decoded["fog1", record.origin, record.origin_frame] = image
            self.to_cloud.send(
                image, record.capture_s, record.origin, record.origin_frame, record.level
            )

        def keep(frame, image, record):
            self.decoded["cloud", record.origin, record.origin_frame] = image

        self.fog = ImageReceiver(self.nodes["fog1"], self.codec, fog_params, relay)
        self.cloud = ImageReceiver(self.nodes["cloud"], self.codec, fog_params, keep)

    def run(self, duration_s: float, images: dict[str, object]) -> None:
        """Each edge sends one image per simulated second for ``duration_s``, then 2 s to drain."""
        next_image_s = 0.0
        while self.clock.t_s < duration_s + 2.0:
            if self.clock.t_s >= next_image_s and self.clock.t_s < duration_s:
                for edge, sender in self.edges.items():
                    image = images[edge]()
                    self.raw[edge, len(sender.records)] = image
                    sender.send(image, self.clock.t_s)
                next_image_s += 1.0
            for node in self.nodes.values():
                node.poll()
            self.clock.t_s += STEP_S
        self.fog.finish()
        self.cloud.finish()


@functools.cache
def scenes() -> tuple[np.ndarray, ...]:
    """Held-out images of the project's scenes (sea, roofs, plant, land), 320x240, rendered once."""
    from harness.imagery import render_images

    return tuple(rgb for rgb, _ in render_images("heldout", 8, 320, 240, seed=5))


class Cycle:
    """The scenes in turn, from an offset: an edge's camera."""

    def __init__(self, offset: int) -> None:
        self.next = offset

    def __call__(self) -> np.ndarray:
        self.next += 1
        return scenes()[(self.next - 1) % len(scenes())]


def sources(offset: int) -> dict[str, object]:
    return {e: Cycle(offset + 4 * k) for k, e in enumerate(EDGES)}


def test_images_go_edge_fog_cloud_over_wifi_and_lte(tmp_path):
    """Every image sent is decoded or counted as lost at each hop; the records add up."""
    relay = Relay(3, ImagingParams(chunk_bytes=2000), ImagingParams(chunk_bytes=2000))
    relay.run(10.0, sources(0))
    sent = [r for s in relay.edges.values() for r in s.records]
    at_fog = relay.fog.records
    at_cloud = relay.cloud.records
    assert len(sent) == 20
    fog_counts, cloud_counts = relay.fog.counts(), relay.cloud.counts()

    # Every frame is decoded or counted lost (0.75 % WiFi, 1.99 % LTE loss per datagram).
    def accounted(counts):
        return counts["images_decoded"] + counts["frames_incomplete"] + counts["frames_missing"]

    assert accounted(fog_counts) == len(sent)
    assert len(relay.to_cloud.records) == len(at_fog) >= 15
    relayed = len(relay.to_cloud.records)
    assert accounted(cloud_counts) == relayed
    assert len(at_cloud) >= relayed - 3
    assert fog_counts["frames_corrupt"] == cloud_counts["frames_corrupt"] == 0
    assert any(r.chunks > 1 for r in sent)  # images above one chunk were split

    by_origin = {(r.origin, r.origin_frame): r for r in sent}
    relayed_by_origin = {(r.origin, r.origin_frame): r for r in relay.to_cloud.records}
    for r in at_fog:
        s = by_origin[r.origin, r.origin_frame]
        assert (r.bytes, r.level, r.chunks, r.capture_s) == (
            s.bytes,
            s.level,
            s.chunks,
            s.capture_s,
        )
        # Latency in simulated seconds: at least the airtime of its bytes and WiFi's 1 ms.
        assert r.latency_s >= WIFI_EDGE_FOG.airtime_s(s.wire_bytes) + 0.001
        assert r.latency_s < 0.1
        assert r.age_s >= r.latency_s
        raw = relay.raw[r.origin, r.origin_frame]
        image = relay.decoded["fog1", r.origin, r.origin_frame]
        # The stream arrived intact: the codec is deterministic, so decoding gives its own output.
        assert np.array_equal(image, relay.codec.decode(relay.codec.encode(raw, r.level)))
    for r in at_cloud:
        s = relayed_by_origin[r.origin, r.origin_frame]
        assert (r.bytes, r.level) == (s.bytes, s.level)
        assert r.level <= by_origin[r.origin, r.origin_frame].level  # never recompressed higher
        assert r.latency_s >= 0.015  # the LTE uplink's base delay
        assert r.age_s > r.latency_s
        # Successive compression: the cloud decodes the fog's re-encoding of its decoded image.
        at_fog_image = relay.decoded["fog1", r.origin, r.origin_frame]
        again = relay.codec.decode(relay.codec.encode(at_fog_image, r.level))
        assert np.array_equal(relay.decoded["cloud", r.origin, r.origin_frame], again)
    # Quality against the raw frames (only a test knows them): lost, not gained, at each stage.
    both = [(o, f) for (node, o, f) in relay.decoded if node == "cloud"]
    psnr = {
        node: np.mean([psnr_db(relay.decoded[node, o, f], relay.raw[o, f]) for o, f in both])
        for node in ("fog1", "cloud")
    }
    assert psnr["cloud"] <= psnr["fog1"] + 0.1

    # Energy: the radio's J per byte of its link; LTE dwarfs WiFi for images of similar size.
    for r in sent + relay.to_cloud.records:
        link = WIFI_EDGE_FOG if r.peer == "fog1" else LTE_UPLINK
        assert r.tx_j == pytest.approx(link.j_per_byte * r.wire_bytes)
        assert r.wire_bytes > r.bytes and r.codec_j > 0
    summary = summarize(sent)["sent"]
    assert summary["images"] == 20 and summary["bytes"] == sum(r.bytes for r in sent)
    lte_j_per_image = np.mean([r.tx_j for r in relay.to_cloud.records])
    assert lte_j_per_image > 100 * summary["tx_j"] / 20

    path = write_csv(sent + at_fog + relay.to_cloud.records + at_cloud, tmp_path / "images.csv")
    with path.open() as f:
        rows = list(csv.DictReader(f))
    assert tuple(rows[0]) == CSV_FIELDS
    assert len(rows) == len(sent) + len(at_fog) + relayed + len(at_cloud)


def test_a_narrow_uplink_makes_the_fog_recompress_lower():
    """T_compress on the fog: 1 kB/s of LTE leaves ~250 B per image, the lowest level."""
    narrow = LinkBudget(1000.0, 100.0, "lte")
    relay = Relay(4, ImagingParams(), ImagingParams(), fog_link=narrow)
    relay.run(4.0, sources(1))
    top = max(relay.codec.levels)
    assert {r.level for r in relay.fog.records} == {top}  # WiFi: the best level
    lowest = min(relay.codec.levels)
    assert {r.level for r in relay.to_cloud.records} == {lowest}
    assert all(r.budget_bytes == pytest.approx(250.0) for r in relay.to_cloud.records)
    for fog_row, cloud_row in zip(relay.fog.records, relay.cloud.records, strict=False):
        assert cloud_row.bytes < fog_row.bytes


def test_a_smaller_energy_budget_lowers_the_level_and_is_kept():
    """10 images in 10 s at 1e-5 J/B (LTE-priced), budgets around the codec's level sizes.

    Per image: a third of the lowest level's expected size, the middle level's, ten times the
    top level's.
    """
    costly = LinkBudget(1e9, 1e4, "lte")  # 1e-5 J per byte, unlimited bandwidth
    codec = test_codec()
    levels = codec.levels
    pixels = 320 * 240

    def size(level):
        return expected_bytes(level, pixels, codec.bits_per_pixel, 200)

    per_image = (size(levels[0]) / 3, size(levels[len(levels) // 2]), 10 * size(levels[-1]))
    mean_level, spent = [], []
    for budget_bytes in per_image:
        budget_j = 10 * budget_bytes * costly.j_per_byte
        params = ImagingParams(energy_budget_j=budget_j, compute_power_w=0.0)
        relay = Relay(5, params, ImagingParams())
        sender = relay.edges["edge1"]
        sender.link, sender.end_s = costly, 10.0
        relay.run(10.0, sources(2))
        assert len(sender.records) == 10
        assert sender.spent_j == pytest.approx(sum(r.tx_j for r in sender.records))
        mean_level.append(np.mean([r.level for r in sender.records]))
        spent.append(sender.spent_j / budget_j)
    assert mean_level[0] == levels[0]  # below every level: the lowest
    assert mean_level[0] < mean_level[1] < mean_level[2] == levels[-1]
    assert spent[2] <= 1.0  # ample: the top level throughout
    assert spent[1] <= 1.5  # kept, within the error of the size forecast


class DropOneChunk:
    """Wraps a port: drops each edge's 9th datagram (a chunk of its 2nd or 3rd image)."""

    def __init__(self, port) -> None:
        self.port = port
        self.topic_count: dict[str, int] = {}

    def send(self, src, dst, data):
        count = self.topic_count[src] = self.topic_count.get(src, 0) + 1
        if src in EDGES and count == 9:  # the edges send nothing but chunks here
            return
        self.port.send(src, dst, data)

    def receive(self, node_id):
        return self.port.receive(node_id)


def test_a_lost_chunk_drops_its_frame_and_a_corrupt_stream_is_counted():
    """A frame missing a chunk is counted incomplete, a stream the codec refuses as corrupt."""
    relay = Relay(6, ImagingParams(chunk_bytes=800, level=max(test_codec().levels)),
                  ImagingParams(), port_wrapper=DropOneChunk)  # fmt: skip
    # 800-byte chunks: each 320x240 image takes >= 3 chunks at the top level.
    relay.run(5.0, sources(3))
    for sender in relay.edges.values():
        assert all(r.chunks >= 3 for r in sender.records)
    counts = relay.fog.counts()
    assert counts["frames_incomplete"] >= 1
    assert counts["images_decoded"] + counts["frames_incomplete"] == 10
    assert counts["frames_missing"] == 0
    # A corrupt stream in well-formed chunks: counted, never raised.
    edge = relay.nodes["edge1"]
    meta = {"origin": "edge1", "origin_frame": 99, "level": 1, "capture_s": 0.0,
            "sent_s": relay.clock.t_s}  # fmt: skip
    for body in split(99, b"\x00not a stream\xff" * 10, meta, 800):
        edge.send("fog1", CHUNK_TOPIC, body)
    for _ in range(50):
        for node in relay.nodes.values():
            node.poll()
        relay.clock.t_s += STEP_S
    assert relay.fog.counts()["frames_corrupt"] == 1


def test_directory_images_cycle_and_refuse_what_is_not_an_image(tmp_path):
    import cv2

    for k in range(2):
        cv2.imwrite(str(tmp_path / f"{k:05d}.png"), np.full((8, 10, 3), 50 * k + 10, np.uint8))
    source = DirectoryImages(tmp_path)
    frames = [source() for _ in range(3)]
    assert frames[0].shape == (8, 10, 3) and frames[2][0, 0, 0] == frames[0][0, 0, 0] == 10
    (tmp_path / "00002.png").write_bytes(b"not a png")
    source = DirectoryImages(tmp_path)
    with pytest.raises(ValueError, match=r"00002\.png"):
        [source() for _ in range(3)]
    with pytest.raises(ValueError, match="not a directory"):
        DirectoryImages(tmp_path / "00000.png")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match=r"no \.png"):
        DirectoryImages(tmp_path / "empty")


def test_the_stream_source_hands_out_the_latest_frame_of_a_video(tmp_path):
    """A real OpenCV capture (a video file stands in for the camera stream), read in a thread."""
    import time

    import cv2

    path = tmp_path / "camera.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (32, 24))
    for k in range(5):
        writer.write(np.full((24, 32, 3), (0, 0, 40 * k + 40), np.uint8))  # BGR: red rising
    writer.release()
    source = StreamImages(str(path))
    try:
        for _ in range(200):  # the thread opens the file and reads all 5 frames (bounded wait)
            if source.frames == 5:
                break
            time.sleep(0.02)
        frame = source()
        assert source.frames == 5 and source.error is None
        assert frame.shape == (24, 32, 3) and frame.dtype == np.uint8
        assert abs(int(frame[12, 16, 0]) - 200) <= 8 and frame[12, 16, 2] <= 8  # RGB, the last
    finally:
        source.close()
