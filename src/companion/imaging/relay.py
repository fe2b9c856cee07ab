"""Send encoded images to a node and receive, reassemble and decode them, recording each image.

The edge role sends its camera frames with an :class:`ImageSender` (level from the T_compress
policy, ``compression.encode``, chunks); the fog receives them with an :class:`ImageReceiver`
(reassemble, ``compression.decode``) and may send each decoded image on to the cloud at a level
no higher than it arrived at (seed 000's successive compression); the cloud receives those.

Every image gives an :class:`ImageRecord`: capture time, level, bytes, send -> decoded latency in
the node's clock (simulated seconds under swarmsitl) and energy:

- transmit energy = the link's J per byte (:class:`LinkBudget`: radio power x airtime, seed 000
  Table I) x the bytes on the wire (UDP payloads + ``wire_overhead_bytes`` per datagram);
- codec energy = ``compute_power_w`` x the codec time a Pi would take, the codec's
  ``s_per_megapixel`` x the image's megapixels. ASSUMPTIONS: the whole embedded computer's
  27 W of seed 000 Table I while the codec runs, an upper bound (a Raspberry Pi 5 draws about
  5-10 W more under load than idle); per megapixel, 0.3 s for an encode or a decode of the
  learned codec, about five times the one-core x86 time ``python -m compression.evaluate``
  measures (a Cortex-A72/A76 core against a server core), and 0.02 s for OpenCV's JPEG
  (libjpeg-turbo, same factor).
  A model rather than the measured time, so that the energy and the levels the policy chooses
  from it are the same in every run of a seed; the measured wall time is recorded beside it.

Times a receiver records are its clock when the last chunk arrived and the image was decoded;
``latency_s`` = decoded - ``sent_s`` of the sender (one clock under swarmsitl: see
docs/messaging.md on clocks), ``age_s`` = decoded - capture.
"""

from __future__ import annotations

import csv
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from companion.imaging.chunks import CHUNK_TOPIC, MAX_CHUNK_BYTES, Frame, Reassembler, split
from companion.imaging.compress_level import (
    LevelController,
    LevelPolicyParams,
    energy_per_image_j,
)
from companion.imaging.link_budget import LinkBudget
from companion.net import Envelope, Node, link_class


@dataclass(frozen=True)
class CodecApi:
    """The codec functions the pipeline uses (``compression``'s public API, or a stand-in)."""

    levels: tuple[int, ...]
    """Levels, lowest quality first."""
    encode: Callable[[np.ndarray, int], bytes]
    """RGB uint8 (H, W, 3) and level -> stream."""
    decode: Callable[[bytes], np.ndarray]
    """Stream -> RGB uint8 (H, W, 3)."""
    bits_per_pixel: Mapping[int, float]
    """Expected bits per pixel of each level (what T_compress plans with)."""
    errors: tuple[type[BaseException], ...] = (ValueError,)
    """Exceptions of a stream that cannot be decoded (``compression.CompressionError``)."""
    s_per_megapixel: float = 0.3
    """Time of one encode or decode on the companion per megapixel, s (ASSUMPTION: for the
    learned codec about five times the one-core x86 time ``python -m compression.evaluate``
    measures, a Cortex-A72/A76 core against a server core)."""


def project_codec() -> CodecApi:
    """The project's learned codec (``compression``), imported on first use.

    Raises:
        ImportError: ``compression`` has no codec (its public API is missing) or its model
            cannot be loaded.
    """
    import compression

    missing = [
        name
        for name in ("LEVELS", "encode", "decode", "level_bits_per_pixel", "CompressionError")
        if not hasattr(compression, name)
    ]
    if missing:
        raise ImportError(f"compression lacks {', '.join(missing)}: no codec installed")
    try:
        levels = tuple(int(lv) for lv in compression.LEVELS)
        bits_per_pixel = {lv: float(compression.level_bits_per_pixel(lv)) for lv in levels}
    except (OSError, ValueError, RuntimeError) as exc:  # e.g. no trained model on disk
        raise ImportError(f"compression codec not usable: {exc}") from exc
    return CodecApi(
        levels,
        compression.encode,
        compression.decode,
        bits_per_pixel,
        (compression.CompressionError,),
    )


@dataclass(frozen=True)
class ImagingParams:
    """How a node sends and receives images."""

    level: int | None = None
    """A fixed level; None: the T_compress policy chooses each image's level."""
    policy: LevelPolicyParams = field(default_factory=LevelPolicyParams)
    """Tuning of the policy."""
    chunk_bytes: int = MAX_CHUNK_BYTES
    """Image bytes per datagram."""
    reassembly_timeout_s: float = 5.0
    """A frame still missing chunks this long after its first chunk is dropped, s."""
    compute_power_w: float = 27.0
    """Power charged while encoding or decoding, W (seed 000 Table I embedded computer; an
    upper bound, see the module docstring)."""
    energy_budget_j: float | None = None
    """Energy this node may spend on sending images over the run (codec + radio), J; None: no
    limit (then only the bandwidth bounds the level)."""
    wire_overhead_bytes: int = 28
    """Bytes a link adds per datagram (IPv4 + UDP), as the link models' ``overhead_bytes``."""

    def __post_init__(self) -> None:
        if not 1 <= self.chunk_bytes <= MAX_CHUNK_BYTES:
            raise ValueError(
                f"chunk_bytes: must be within 1..{MAX_CHUNK_BYTES}, got {self.chunk_bytes}"
            )
        if not self.reassembly_timeout_s > 0:
            raise ValueError(f"reassembly_timeout_s: must be > 0, got {self.reassembly_timeout_s}")
        if not (math.isfinite(self.compute_power_w) and self.compute_power_w >= 0):
            raise ValueError(f"compute_power_w: must be >= 0, got {self.compute_power_w}")
        if self.energy_budget_j is not None and not self.energy_budget_j >= 0:
            raise ValueError(f"energy_budget_j: must be >= 0, got {self.energy_budget_j}")
        if self.wire_overhead_bytes < 0:
            raise ValueError(f"wire_overhead_bytes: must be >= 0, got {self.wire_overhead_bytes}")

    def codec_energy_j(self, codec: CodecApi, pixels: int) -> float:
        """Energy of one encode or decode of an image of ``pixels`` on the companion, J."""
        return self.compute_power_w * codec.s_per_megapixel * pixels / 1e6


@dataclass
class ImageRecord:
    """One image sent or received by a node (a CSV row)."""

    event: str
    """"sent" or "decoded"."""
    node: str
    """The node recording it."""
    peer: str
    """Destination (sent) or sender (decoded)."""
    origin: str
    """Node whose camera took the image."""
    origin_frame: int
    """The origin's frame number."""
    frame_id: int
    """This hop's frame id (the sender's counter)."""
    level: int
    """Compression level of this hop."""
    width_px: int
    height_px: int
    bytes: int
    """Encoded image size, bytes."""
    wire_bytes: int
    """UDP payloads + per-datagram link overhead (sent only; 0 when received), bytes."""
    chunks: int
    """Datagrams the image took."""
    bits_per_pixel: float
    """8 x bytes / pixels."""
    capture_s: float
    """Origin's clock when the image was taken, s."""
    sent_s: float
    """Sender's clock after encoding, when the first chunk left, s."""
    decoded_s: float
    """Receiver's clock once decoded (nan for "sent"), s."""
    latency_s: float
    """decoded_s - sent_s: link + reassembly + decode (nan for "sent"), s."""
    age_s: float
    """decoded_s - capture_s (nan for "sent"), s."""
    codec_wall_s: float
    """Measured encode (sent) or decode (decoded) time here, wall s (information only)."""
    codec_j: float
    """compute_power_w x the codec's s_per_megapixel x megapixels, J."""
    tx_j: float
    """Radio energy of the wire bytes (sent), J."""
    budget_bytes: float
    """T_compress's byte budget for this image (inf: unlimited or fixed level; sent only)."""


CSV_FIELDS = tuple(f.name for f in fields(ImageRecord))
"""Columns of the image CSV, in order."""


def write_csv(records: list[ImageRecord], path: str | Path) -> Path:
    """Write ``records`` as CSV (header ``CSV_FIELDS``); return the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=CSV_FIELDS)
        writer.writeheader()
        for record in records:
            writer.writerow(asdict(record))
    return path


def summarize(records: list[ImageRecord]) -> dict[str, Any]:
    """Per event: images, bytes, mean bits per pixel, mean/max latency, energy, levels used."""
    out: dict[str, Any] = {}
    for event in ("sent", "decoded"):
        rows = [r for r in records if r.event == event]
        if not rows:
            continue
        levels: dict[str, int] = {}
        for r in rows:
            levels[str(r.level)] = levels.get(str(r.level), 0) + 1
        entry: dict[str, Any] = {
            "images": len(rows),
            "bytes": sum(r.bytes for r in rows),
            "mean_bits_per_pixel": float(np.mean([r.bits_per_pixel for r in rows])),
            "levels": levels,
            "codec_j": float(sum(r.codec_j for r in rows)),
        }
        if event == "sent":
            entry["wire_bytes"] = sum(r.wire_bytes for r in rows)
            entry["tx_j"] = float(sum(r.tx_j for r in rows))
        else:
            entry["mean_latency_s"] = float(np.mean([r.latency_s for r in rows]))
            entry["max_latency_s"] = float(np.max([r.latency_s for r in rows]))
        out[event] = entry
    return out


class ImageSender:
    """Encodes images at the T_compress level and sends them to one node in chunks.

    Args:
        node: the sending node (``AsyncNode.node`` in the roles).
        dst: the receiving node.
        codec: the codec functions.
        link: bandwidth and energy per byte of the link to ``dst``.
        image_period_s: time between two images on this stream (the policy's byte budget).
        params: imaging parameters.
        end_s: clock time the run ends (spreads the energy budget), s; inf: no end.
        records: list to append the records to (default a new one, ``records``).
    """

    def __init__(
        self,
        node: Node,
        dst: str,
        codec: CodecApi,
        link: LinkBudget,
        image_period_s: float,
        params: ImagingParams | None = None,
        end_s: float = math.inf,
        records: list[ImageRecord] | None = None,
    ) -> None:
        if not image_period_s > 0:
            raise ValueError(f"image_period_s: must be > 0, got {image_period_s}")
        self.node = node
        self.dst = dst
        self.codec = codec
        self.link = link
        self.image_period_s = image_period_s
        self.params = params or ImagingParams()
        if self.params.level is not None and self.params.level not in codec.levels:
            raise ValueError(f"level: {self.params.level} is not one of {codec.levels}")
        self.end_s = end_s
        self.controller = LevelController(codec.bits_per_pixel, self.params.policy)
        self.records: list[ImageRecord] = [] if records is None else records
        self.spent_j = 0.0
        """Codec + radio energy spent on images so far, J."""
        self.send_errors = 0
        """Chunks the transport refused (a datagram above the link's limit)."""
        self._next_frame = 0
        self._last_encode_j = 0.0

    def send(
        self,
        image: np.ndarray,
        capture_s: float,
        origin: str | None = None,
        origin_frame: int | None = None,
        cap: int | None = None,
    ) -> ImageRecord:
        """Choose the level, encode, send the chunks; return the record.

        ``cap``: highest level allowed (a relayed image: the level it arrived at).

        Raises:
            ValueError (from the codec): not an RGB uint8 image.
        """
        clock = self.node.clock
        height, width = int(image.shape[0]), int(image.shape[1])
        pixels = max(1, height * width)
        budget = math.inf
        if self.params.level is not None:
            level = self.params.level
            if cap is not None:
                level = min(level, cap)
        else:
            remaining_j = (
                None
                if self.params.energy_budget_j is None
                else self.params.energy_budget_j - self.spent_j
            )
            per_image_j = energy_per_image_j(remaining_j, self.end_s - clock(), self.image_period_s)
            level = self.controller.next_level(
                pixels,
                self.link.rate_bytes_s,
                self.image_period_s,
                self.link.j_per_byte,
                per_image_j,
                self._last_encode_j,
                cap,
            )
            budget = self.controller.last_budget_bytes
        start = time.perf_counter()
        data = self.codec.encode(image, level)
        encode_wall_s = time.perf_counter() - start
        self.controller.observe(level, pixels, len(data))
        codec_j = self.params.codec_energy_j(self.codec, pixels)
        self._last_encode_j = codec_j
        frame_id = self._next_frame
        self._next_frame += 1
        sent_s = clock()
        meta = {
            "origin": origin or self.node.node_id,
            "origin_frame": frame_id if origin_frame is None else origin_frame,
            "level": level,
            "capture_s": float(capture_s),
            "sent_s": sent_s,
            "width_px": width,
            "height_px": height,
        }
        bodies = split(frame_id, data, meta, self.params.chunk_bytes)
        payload_bytes = 0
        link = link_class(self.node.role, self.node.config.nodes[self.dst].role)
        traffic = self.node.stats.peer(self.dst, link).sent["data"]
        for body in bodies:
            before = traffic.bytes
            try:
                self.node.send(self.dst, CHUNK_TOPIC, body)
            except ValueError:  # a datagram above the link's limit: counted, the frame is lost
                self.send_errors += 1
            payload_bytes += traffic.bytes - before
        wire_bytes = payload_bytes + self.params.wire_overhead_bytes * len(bodies)
        tx_j = self.link.j_per_byte * wire_bytes
        self.spent_j += codec_j + tx_j
        record = ImageRecord(
            "sent", self.node.node_id, self.dst, meta["origin"], meta["origin_frame"], frame_id,
            level, width, height, len(data), wire_bytes, len(bodies), 8.0 * len(data) / pixels,
            float(capture_s), sent_s, math.nan, math.nan, math.nan, encode_wall_s, codec_j, tx_j,
            budget,
        )  # fmt: skip
        self.records.append(record)
        return record


class ImageReceiver:
    """Reassembles and decodes the images sent to a node; registers the chunk handler.

    Args:
        node: the receiving node.
        codec: the codec functions.
        params: imaging parameters (reassembly timeout, compute power).
        on_image: called with (frame, decoded RGB image, record) for each decoded image.
        records: list to append the records to (default a new one, ``records``).
    """

    def __init__(
        self,
        node: Node,
        codec: CodecApi,
        params: ImagingParams | None = None,
        on_image: Callable[[Frame, np.ndarray, ImageRecord], None] | None = None,
        records: list[ImageRecord] | None = None,
    ) -> None:
        self.node = node
        self.codec = codec
        self.params = params or ImagingParams()
        self.on_image = on_image
        self.reassembler = Reassembler(self.params.reassembly_timeout_s)
        self.records: list[ImageRecord] = [] if records is None else records
        self.decoded = 0
        """Images decoded."""
        self.corrupt = 0
        """Complete frames whose stream the codec refused (``compression.StreamError``)."""
        self.bad_meta = 0
        """Complete frames whose metadata was unusable (dropped)."""
        node.on(CHUNK_TOPIC, self._on_chunk)

    def expire(self) -> int:
        """Drop frames that waited too long for a chunk; return how many."""
        return self.reassembler.expire(self.node.clock())

    def finish(self) -> dict[str, int]:
        """Drop the frames still incomplete (end of the run); return the counters."""
        self.reassembler.flush()
        return self.counts()

    def counts(self) -> dict[str, int]:
        """Frames decoded, lost (incomplete or missing), corrupt; chunks, duplicates, malformed."""
        c = self.reassembler.counts
        return {
            "images_decoded": self.decoded,
            "frames_incomplete": c.incomplete,
            "frames_missing": c.missing,
            "frames_corrupt": self.corrupt + self.bad_meta,
            "chunks": c.chunks,
            "chunks_duplicate": c.duplicates,
            "chunks_malformed": c.malformed,
            "chunks_late": c.late_chunks,
        }

    def _on_chunk(self, env: Envelope) -> None:
        frame = self.reassembler.add(env.src, env.body, self.node.clock())
        if frame is not None:
            self._decode(frame)

    def _decode(self, frame: Frame) -> None:
        meta = frame.meta
        try:
            level = int(meta["level"])
            capture_s = float(meta["capture_s"])
            sent_s = float(meta["sent_s"])
            origin = str(meta["origin"])
            origin_frame = int(meta["origin_frame"])
        except (KeyError, TypeError, ValueError):
            self.bad_meta += 1
            return
        start = time.perf_counter()
        try:
            image = self.codec.decode(frame.data)
        except self.codec.errors:
            self.corrupt += 1
            return
        decode_wall_s = time.perf_counter() - start
        decoded_s = self.node.clock()
        height, width = int(image.shape[0]), int(image.shape[1])
        record = ImageRecord(
            "decoded", self.node.node_id, frame.src, origin, origin_frame, frame.frame_id, level,
            width, height, len(frame.data), 0, frame.chunks,
            8.0 * len(frame.data) / max(1, width * height), capture_s, sent_s, decoded_s,
            decoded_s - sent_s, decoded_s - capture_s, decode_wall_s,
            self.params.codec_energy_j(self.codec, width * height), 0.0, math.nan,
        )  # fmt: skip
        self.records.append(record)
        self.decoded += 1
        if self.on_image is not None:
            self.on_image(frame, image, record)
