"""Rate-distortion evaluation of the learned codec against JPEG and WebP on held-out images.

``python -m compression.evaluate [--images DIR] [--out DIR] [--levels 1,2,3]``

1. Loads the held-out images (``data/imagery/heldout`` by default; rendered by
   ``python -m harness.imagery --split heldout`` in a subprocess when the folder has no PNG).
2. Encodes and decodes every image with every setting of every codec (learned levels, JPEG and
   WebP qualities) and measures bytes, bits per pixel and PSNR / SSIM / MS-SSIM against the
   original (definitions in ``compression.metrics``).
3. Writes ``rd.csv`` (one row per codec, setting and image), ``summary.csv`` (means over the
   images), ``bits_ratios.csv``, ``successive.csv``, the plots ``rd_psnr.png``, ``rd_ssim.png``,
   ``rd_ms_ssim.png``, ``successive.png`` and ``comparison.png`` (original / learned / JPEG / WebP
   at about equal bits, with an enlarged crop) into ``--out`` (``docs/images/compression``).
4. Times encode + decode of a 320x240 frame (learned codec on one ONNX Runtime thread, JPEG and
   WebP on one OpenCV thread) and prints the last line
   ``RESULT bits_vs_jpeg=... bits_vs_webp=... encode_decode_ms_320x240=...``.

Bits ratio at equal MS-SSIM, for each learned level L: the learned codec's mean MS-SSIM ``m_L``
and mean bpp ``b_L`` over the images; the baseline's bpp at ``m_L`` interpolated on its curve of
mean bpp vs mean MS-SSIM over its qualities (only the Pareto-efficient points, so the curve is
increasing); ratio ``b_L / bpp_baseline(m_L)``. The RESULT reports the median over levels; a level
whose ``m_L`` lies outside the baseline's measured range is skipped (and listed).

Everything but the timings is deterministic: same images and codecs, byte-identical CSVs.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import math
import os
import platform
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

import cv2
import numpy as np
import torch

from compression.baselines import ImageCodec, JpegCodec, LearnedCodec, WebpCodec
from compression.dataset import ensure_images
from compression.metrics import (
    ms_ssim_batch,
    ms_ssim_defined,
    psnr_db,
    psnr_db_batch,
    ssim_batch,
)
from compression.successive import StageResult, compress_successively

DEFAULT_IMAGES = Path("data/imagery/heldout")
"""Held-out images, relative to the working directory (the repository root)."""
DEFAULT_OUT = Path("docs/images/compression")
"""Where the CSVs and plots go, relative to the working directory."""
HELDOUT_COUNT = 48
"""Images rendered when the held-out folder is empty."""
TIMING_HEIGHT_PX, TIMING_WIDTH_PX = 240, 320
"""Size of the frame the codecs are timed on."""

_COLOURS = {"learned": "tab:red", "jpeg": "tab:blue", "webp": "tab:green"}
_METRICS = (("psnr_db", "PSNR, dB"), ("ssim", "SSIM"), ("ms_ssim", "MS-SSIM"))


@dataclass(frozen=True)
class RDPoint:
    """One codec setting on one image."""

    codec: str
    setting: int
    image: str
    """File name of the image."""
    n_bytes: int
    bpp: float
    """Bits per pixel, 8 * bytes / (H * W)."""
    psnr_db: float
    ssim: float
    ms_ssim: float
    """``nan`` if the image is too small for five-scale MS-SSIM."""


@dataclass(frozen=True)
class RDSummary:
    """Means over the images of one codec setting."""

    codec: str
    setting: int
    n_images: int
    bpp: float
    psnr_db: float
    ssim: float
    ms_ssim: float


@dataclass(frozen=True)
class BitsRatio:
    """Learned level vs one baseline at the learned level's mean MS-SSIM."""

    baseline: str
    level: int
    learned_bpp: float
    learned_ms_ssim: float
    baseline_bpp: float
    """Baseline's interpolated bpp at ``learned_ms_ssim``; ``nan`` if outside its range."""
    ratio: float
    """``learned_bpp / baseline_bpp``; ``nan`` when skipped."""


@dataclass(frozen=True)
class SuccessiveRow:
    """Mean over the images of one stage of one successive-compression chain."""

    chain: str
    stage: int
    setting: int
    n_bytes: float
    bpp: float
    psnr_db_vs_raw: float
    ssim_vs_raw: float
    ms_ssim_vs_raw: float
    psnr_db_vs_previous: float
    """Mean over the images this stage changed (``nan`` if it changed none), dB."""
    ssim_vs_previous: float
    ms_ssim_vs_previous: float
    unchanged_fraction: float
    """Share of the images this stage's decode returned unchanged (re-encoding at the same
    setting can be idempotent); their infinite PSNR is left out of ``psnr_db_vs_previous``."""


@dataclass(frozen=True)
class Timing:
    """Median wall time of one encode and one decode of the timing frame."""

    codec: str
    setting: int
    encode_ms: float
    decode_ms: float

    @property
    def total_ms(self) -> float:
        """Encode plus decode, ms."""
        return self.encode_ms + self.decode_ms


@dataclass(frozen=True)
class SettingsSubset:
    """A codec restricted to some of its settings (``--levels``)."""

    codec: ImageCodec
    settings: tuple[int, ...]

    def __post_init__(self) -> None:
        unknown = sorted(set(self.settings) - set(self.codec.settings))
        if unknown:
            raise ValueError(f"levels {unknown} are not settings of {self.codec.name}")

    @property
    def name(self) -> str:
        """Name of the wrapped codec."""
        return self.codec.name

    def encode(self, image: np.ndarray, setting: int) -> bytes:
        """Encode with the wrapped codec."""
        return self.codec.encode(image, setting)

    def decode(self, data: bytes) -> np.ndarray:
        """Decode with the wrapped codec."""
        return self.codec.decode(data)


# --- images -------------------------------------------------------------------------------------


def ensure_heldout_images(directory: Path, count: int = HELDOUT_COUNT) -> None:
    """Render the held-out set into ``directory`` with ``harness.imagery`` if it has no PNG."""
    ensure_images(directory, "heldout", count)


def load_images(directory: Path) -> list[tuple[str, np.ndarray]]:
    """All ``*.png`` in ``directory`` as (file name, RGB uint8), sorted by name."""
    paths = sorted(directory.glob("*.png"))
    if not paths:
        raise ValueError(f"--images: no PNG images in {directory}")
    images = []
    for path in paths:
        bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if bgr is None:
            raise ValueError(f"--images: cannot read {path}")
        images.append((path.name, cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)))
    return images


# --- rate-distortion ----------------------------------------------------------------------------


def rate_distortion(
    codecs: Sequence[ImageCodec], images: Sequence[tuple[str, np.ndarray]]
) -> list[RDPoint]:
    """Bytes, bpp and quality of every codec setting on every image."""
    points: list[RDPoint] = []
    for codec in codecs:
        for name, image in images:
            streams = [codec.encode(image, s) for s in codec.settings]
            decoded = np.stack([codec.decode(data) for data in streams])
            originals = np.broadcast_to(image, decoded.shape)
            psnr = psnr_db_batch(originals, decoded)
            ssim = ssim_batch(originals, decoded)
            if ms_ssim_defined(*image.shape[:2]):
                msssim = ms_ssim_batch(originals, decoded)
            else:
                msssim = np.full(len(streams), math.nan)
            n_pixels = image.shape[0] * image.shape[1]
            for i, setting in enumerate(codec.settings):
                points.append(
                    RDPoint(
                        codec=codec.name,
                        setting=int(setting),
                        image=name,
                        n_bytes=len(streams[i]),
                        bpp=8.0 * len(streams[i]) / n_pixels,
                        psnr_db=float(psnr[i]),
                        ssim=float(ssim[i]),
                        ms_ssim=float(msssim[i]),
                    )
                )
    return points


def summarise(points: Sequence[RDPoint]) -> list[RDSummary]:
    """Means over the images for each (codec, setting), in first-seen order."""
    groups: dict[tuple[str, int], list[RDPoint]] = {}
    for p in points:
        groups.setdefault((p.codec, p.setting), []).append(p)
    rows = []
    for (codec, setting), group in groups.items():
        rows.append(
            RDSummary(
                codec=codec,
                setting=setting,
                n_images=len(group),
                bpp=float(np.mean([p.bpp for p in group])),
                psnr_db=float(np.mean([p.psnr_db for p in group])),
                ssim=float(np.mean([p.ssim for p in group])),
                ms_ssim=float(np.mean([p.ms_ssim for p in group])),
            )
        )
    return rows


def baseline_bpp_at(baseline: Sequence[RDSummary], ms_ssim: float) -> float:
    """Baseline bpp needed for a mean MS-SSIM, interpolated; ``nan`` outside its range.

    Uses the Pareto-efficient points (each has a higher MS-SSIM than every cheaper point), so
    the curve is strictly increasing and the interpolation well defined.
    """
    ordered = sorted(baseline, key=lambda r: (r.bpp, -r.ms_ssim))
    front_bpp: list[float] = []
    front_q: list[float] = []
    for row in ordered:
        if math.isfinite(row.ms_ssim) and (not front_q or row.ms_ssim > front_q[-1]):
            front_bpp.append(row.bpp)
            front_q.append(row.ms_ssim)
    if not front_q or not math.isfinite(ms_ssim) or not front_q[0] <= ms_ssim <= front_q[-1]:
        return math.nan
    return float(np.interp(ms_ssim, front_q, front_bpp))


def bits_ratios(
    learned: Sequence[RDSummary], baseline: Sequence[RDSummary], baseline_name: str
) -> list[BitsRatio]:
    """For each learned level: its bpp over the baseline's bpp at the same mean MS-SSIM."""
    out = []
    for row in sorted(learned, key=lambda r: r.setting):
        base = baseline_bpp_at(baseline, row.ms_ssim)
        out.append(
            BitsRatio(
                baseline=baseline_name,
                level=row.setting,
                learned_bpp=row.bpp,
                learned_ms_ssim=row.ms_ssim,
                baseline_bpp=base,
                ratio=row.bpp / base if math.isfinite(base) and base > 0 else math.nan,
            )
        )
    return out


def median_ratio(ratios: Sequence[BitsRatio]) -> float:
    """Median of the defined ratios (``nan`` if no level was in the baseline's range)."""
    values = [r.ratio for r in ratios if math.isfinite(r.ratio)]
    return float(np.median(values)) if values else math.nan


# --- successive compression ---------------------------------------------------------------------


def default_chains(levels: Sequence[int]) -> list[tuple[int, ...]]:
    """Edge, fog, cloud chains: best level three times, and best -> middle -> lowest."""
    ordered = sorted(levels)
    top, mid, low = ordered[-1], ordered[len(ordered) // 2], ordered[0]
    chains = [(top, top, top), (top, mid, low)]
    return list(dict.fromkeys(chains))


def successive_table(
    codec: ImageCodec,
    images: Sequence[tuple[str, np.ndarray]],
    chains: Sequence[Sequence[int]],
) -> list[SuccessiveRow]:
    """Mean stage results over the images for each chain of levels."""
    rows = []
    for chain in chains:
        label = f"{codec.name} " + ">".join(str(level) for level in chain)
        per_image = [compress_successively(img, chain, codec) for _, img in images]
        for stage, setting in enumerate(chain):
            stages: list[StageResult] = [results[stage] for results in per_image]

            def mean(attr: str, stages: list[StageResult] = stages) -> float:
                return float(np.mean([getattr(s, attr) for s in stages]))

            rows.append(
                SuccessiveRow(
                    chain=label,
                    stage=stage,
                    setting=int(setting),
                    n_bytes=mean("n_bytes"),
                    bpp=mean("bpp"),
                    psnr_db_vs_raw=mean("psnr_db_vs_raw"),
                    ssim_vs_raw=mean("ssim_vs_raw"),
                    ms_ssim_vs_raw=mean("ms_ssim_vs_raw"),
                    psnr_db_vs_previous=_finite_mean([s.psnr_db_vs_previous for s in stages]),
                    ssim_vs_previous=mean("ssim_vs_previous"),
                    ms_ssim_vs_previous=mean("ms_ssim_vs_previous"),
                    unchanged_fraction=float(
                        np.mean([math.isinf(s.psnr_db_vs_previous) for s in stages])
                    ),
                )
            )
    return rows


def _finite_mean(values: Sequence[float]) -> float:
    """Mean of the finite values, ``nan`` if there are none."""
    finite = [v for v in values if math.isfinite(v)]
    return float(np.mean(finite)) if finite else math.nan


# --- timing -------------------------------------------------------------------------------------


def timing_frame(image: np.ndarray) -> np.ndarray:
    """The image as a 320x240 frame (resized with area averaging if it is another size)."""
    if image.shape[:2] == (TIMING_HEIGHT_PX, TIMING_WIDTH_PX):
        return image
    return cv2.resize(image, (TIMING_WIDTH_PX, TIMING_HEIGHT_PX), interpolation=cv2.INTER_AREA)


def time_codec(codec: ImageCodec, setting: int, frame: np.ndarray, repeats: int = 30) -> Timing:
    """Median encode and decode wall times of ``frame`` over ``repeats`` runs (after 3 warm-ups)."""
    if repeats < 1:
        raise ValueError(f"repeats must be >= 1, got {repeats}")
    for _ in range(3):
        codec.decode(codec.encode(frame, setting))
    enc, dec = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        data = codec.encode(frame, setting)
        t1 = time.perf_counter()
        codec.decode(data)
        t2 = time.perf_counter()
        enc.append(t1 - t0)
        dec.append(t2 - t1)
    return Timing(
        codec=codec.name,
        setting=int(setting),
        encode_ms=1e3 * float(np.median(enc)),
        decode_ms=1e3 * float(np.median(dec)),
    )


def machine_details() -> dict[str, str]:
    """CPU model, cores and library versions, for the printed report."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    details = {"cpu": cpu, "cores": str(os.cpu_count()), "python": platform.python_version()}
    if hasattr(os, "getloadavg"):  # other work on the machine skews the timings
        details["load_1min"] = f"{os.getloadavg()[0]:.2f}"
    for dist in ("onnxruntime", "torch", "opencv-python-headless", "numpy", "pytorch-msssim"):
        try:
            details[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            details[dist] = "absent"
    return details


# --- output -------------------------------------------------------------------------------------


def _fmt(value: object) -> object:
    if isinstance(value, float):
        return f"{value:.6g}"
    return value


def write_csv(path: Path, rows: Sequence[object]) -> None:
    """Write dataclass rows as a CSV (floats with 6 significant digits)."""
    if not rows:
        raise ValueError(f"nothing to write to {path}")
    fields = [f.name for f in dataclasses.fields(rows[0])]
    with path.open("w", newline="") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(fields)
        for row in rows:
            writer.writerow([_fmt(getattr(row, f)) for f in fields])


def _figure(width_in: float, height_in: float) -> tuple[object, object]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt, plt.figure(figsize=(width_in, height_in))


def plot_rd(summary: Sequence[RDSummary], out_dir: Path) -> list[Path]:
    """One PNG per metric: mean bpp (log axis) vs mean quality for every codec."""
    paths = []
    codecs = list(dict.fromkeys(r.codec for r in summary))
    for metric, label in _METRICS:
        plt, fig = _figure(5.5, 3.8)
        ax = fig.add_subplot()
        for codec in codecs:
            rows = sorted((r for r in summary if r.codec == codec), key=lambda r: r.bpp)
            ax.plot(
                [r.bpp for r in rows],
                [getattr(r, metric) for r in rows],
                marker="o",
                markersize=3,
                color=_COLOURS.get(codec),
                label=codec,
                zorder=3 if codec == "learned" else 2,
            )
        n_images = max(r.n_images for r in summary)
        ax.set_title(f"{label} vs rate, {n_images} held-out images", fontsize=10)
        ax.set_xscale("log")
        ax.set_xlabel("bits per pixel (mean over images)")
        ax.set_ylabel(f"{label} (mean)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        fig.tight_layout()
        path = out_dir / f"rd_{metric}.png"
        fig.savefig(path, dpi=90)
        plt.close(fig)
        paths.append(path)
    return paths


def plot_successive(rows: Sequence[SuccessiveRow], path: Path) -> None:
    """Quality vs the raw image at each stage of each chain (PSNR and MS-SSIM panels)."""
    plt, fig = _figure(8.0, 3.4)
    chains = list(dict.fromkeys(r.chain for r in rows))
    for i, (metric, label) in enumerate(
        (("psnr_db_vs_raw", "PSNR"), ("ms_ssim_vs_raw", "MS-SSIM"))
    ):
        ax = fig.add_subplot(1, 2, i + 1)
        for chain in chains:
            stages = [r for r in rows if r.chain == chain]
            ax.plot(
                [r.stage for r in stages], [getattr(r, metric) for r in stages], "o-", label=chain
            )
            for r in stages:
                ax.annotate(f"{r.bpp:.2f}", (r.stage, getattr(r, metric)), fontsize=7, va="bottom")
        ax.set_xticks(range(max(len([r for r in rows if r.chain == c]) for c in chains)))
        ax.set_xticklabels(
            ["edge", "fog", "cloud", "4", "5", "6", "7", "8"][: len(ax.get_xticks())]
        )
        ax.set_ylabel(f"{label} vs raw (mean)" + (", dB" if metric.startswith("psnr") else ""))
        ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, title="chain (labels: bpp)", title_fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _closest_setting(codec: ImageCodec, image: np.ndarray, n_bytes: int) -> int:
    """The quality (1..100) whose stream for ``image`` is closest in size to ``n_bytes``."""
    sizes = {q: len(codec.encode(image, q)) for q in range(1, 101)}
    return min(sizes, key=lambda q: (abs(sizes[q] - n_bytes), q))


def _detail_crop(image: np.ndarray, crop_h: int, crop_w: int) -> tuple[int, int]:
    """Top-left corner of the crop with the most gradient energy (the most telling detail)."""
    gray = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY).astype(np.float32)
    energy = np.abs(cv2.Sobel(gray, cv2.CV_32F, 1, 0)) + np.abs(cv2.Sobel(gray, cv2.CV_32F, 0, 1))
    box = cv2.boxFilter(energy, -1, (crop_w, crop_h), normalize=False, anchor=(0, 0))
    valid = box[: image.shape[0] - crop_h + 1, : image.shape[1] - crop_w + 1]
    row, col = np.unravel_index(int(np.argmax(valid)), valid.shape)
    return int(row), int(col)


def comparison_picture(
    image: np.ndarray,
    learned: ImageCodec,
    level: int,
    baselines: Sequence[ImageCodec],
    path: Path,
) -> list[tuple[str, int, float]]:
    """Original / learned / baselines at about the learned codec's bytes, with enlarged crops.

    Each baseline's quality is the one (of 1..100) whose stream size is closest to the learned
    stream's. Returns (codec, setting, bpp) of each panel after the original.
    """
    n_pixels = image.shape[0] * image.shape[1]
    data = learned.encode(image, level)
    panels = [("original", image)]
    chosen = [(learned.name, level, 8.0 * len(data) / n_pixels)]
    panels.append((f"{learned.name} L{level}", learned.decode(data)))
    for codec in baselines:
        q = _closest_setting(codec, image, len(data))
        stream = codec.encode(image, q)
        chosen.append((codec.name, q, 8.0 * len(stream) / n_pixels))
        panels.append((f"{codec.name} q{q}", codec.decode(stream)))
    crop_h, crop_w = max(1, image.shape[0] // 4), max(1, image.shape[1] // 4)
    top, left = _detail_crop(image, crop_h, crop_w)
    columns = []
    for i, (title, img) in enumerate(panels):
        if i == 0:
            lines = [title, "raw, 24 bpp", ""]
        else:
            lines = [title, f"{chosen[i - 1][2]:.3f} bpp", f"{psnr_db(image, img):.1f} dB"]
            lines[2] += ms_ssim_text(image, img)
        columns.append(_comparison_column(img, lines, (top, left, crop_h, crop_w)))
    gap = np.full((columns[0].shape[0], _GAP_PX, 3), 255, np.uint8)
    sheet = np.concatenate([part for col in columns for part in (col, gap)][:-1], axis=1)
    png = [
        cv2.IMWRITE_PNG_COMPRESSION,
        9,
        cv2.IMWRITE_PNG_STRATEGY,
        cv2.IMWRITE_PNG_STRATEGY_FILTERED,
    ]
    if not cv2.imwrite(str(path), cv2.cvtColor(sheet, cv2.COLOR_RGB2BGR), png):
        raise ValueError(f"--out: cannot write {path}")
    return chosen


_CROP_ZOOM = 3
"""Enlargement of the detail crop (nearest neighbour: the codec's pixels, not a resampling)."""
_GAP_PX = 8
_TEXT_LINE_PX = 15


def _comparison_column(
    img: np.ndarray, lines: Sequence[str], crop: tuple[int, int, int, int]
) -> np.ndarray:
    """One column of the comparison sheet: text, the image at half size, the enlarged crop.

    Built pixel-exact with numpy (no plot resampling): the enlarged crop repeats pixels, which
    PNG stores almost for free, so the sheet stays small.
    """
    top, left, crop_h, crop_w = crop
    width = max(_CROP_ZOOM * crop_w, img.shape[1] // 2)
    text = np.full((_TEXT_LINE_PX * len(lines) + 4, width, 3), 255, np.uint8)
    for k, line in enumerate(lines):
        cv2.putText(
            text,
            line,
            (2, _TEXT_LINE_PX * (k + 1) - 3),
            cv2.FONT_HERSHEY_SIMPLEX,
            0.4,
            (0, 0, 0),
            1,
            cv2.LINE_AA,
        )
    half = cv2.resize(
        img, (max(1, img.shape[1] // 2), max(1, img.shape[0] // 2)), interpolation=cv2.INTER_AREA
    )
    half = np.ascontiguousarray(half)
    cv2.rectangle(  # where the crop below comes from
        half, (left // 2, top // 2), ((left + crop_w) // 2, (top + crop_h) // 2), (255, 255, 0), 1
    )
    zoom = np.repeat(
        np.repeat(img[top : top + crop_h, left : left + crop_w], _CROP_ZOOM, 0), _CROP_ZOOM, 1
    )
    parts = [text, _pad_width(half, width), np.full((_GAP_PX, width, 3), 255, np.uint8)]
    parts.append(_pad_width(zoom, width))
    return np.concatenate(parts, axis=0)


def _pad_width(img: np.ndarray, width: int) -> np.ndarray:
    """``img`` centred on a white strip ``width`` pixels wide."""
    out = np.full((img.shape[0], width, 3), 255, np.uint8)
    x0 = (width - img.shape[1]) // 2
    out[:, x0 : x0 + img.shape[1]] = img
    return out


def ms_ssim_text(a: np.ndarray, b: np.ndarray) -> str:
    """The MS-SSIM part of a panel title, empty where MS-SSIM is undefined."""
    if not ms_ssim_defined(*a.shape[:2]):
        return ""
    value = float(ms_ssim_batch(a[None], b[None])[0])
    return f", MS-SSIM {value:.3f}"


# --- the whole evaluation -----------------------------------------------------------------------


@dataclass
class Report:
    """Everything the evaluation measured."""

    summary: list[RDSummary]
    ratios: dict[str, list[BitsRatio]]
    successive: list[SuccessiveRow]
    timings: list[Timing]
    comparison: list[tuple[str, int, float]]
    files: list[Path]


def run_evaluation(
    images: Sequence[tuple[str, np.ndarray]],
    learned: ImageCodec,
    baselines: Sequence[ImageCodec],
    out_dir: Path,
    chains: Sequence[Sequence[int]] | None = None,
    timing_codec: ImageCodec | None = None,
    timing_repeats: int = 30,
) -> Report:
    """Measure, write the CSVs and plots into ``out_dir``, and return the numbers.

    Args:
        images: (name, RGB uint8) pairs, the held-out set.
        learned: The codec under test (its settings are its levels).
        baselines: The reference codecs (JPEG, WebP).
        out_dir: Output folder, created if needed.
        chains: Successive-compression chains of learned levels; ``None`` for
            ``default_chains``.
        timing_codec: The learned codec as timed (e.g. on one thread); ``None`` times ``learned``.
        timing_repeats: Runs per timing (the median is reported).
    """
    if not images:
        raise ValueError("images: the evaluation needs at least one image")
    out_dir.mkdir(parents=True, exist_ok=True)
    # pytorch_msssim's convolutions are 2-4x faster on one thread than on two on a shared CPU.
    torch_threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        return _evaluate(images, learned, baselines, out_dir, chains, timing_codec, timing_repeats)
    finally:
        torch.set_num_threads(torch_threads)


def _evaluate(
    images: Sequence[tuple[str, np.ndarray]],
    learned: ImageCodec,
    baselines: Sequence[ImageCodec],
    out_dir: Path,
    chains: Sequence[Sequence[int]] | None,
    timing_codec: ImageCodec | None,
    timing_repeats: int,
) -> Report:
    """``run_evaluation`` without the thread setting."""
    points = rate_distortion([learned, *baselines], images)
    summary = summarise(points)
    learned_rows = [r for r in summary if r.codec == learned.name]
    ratios = {
        b.name: bits_ratios(learned_rows, [r for r in summary if r.codec == b.name], b.name)
        for b in baselines
    }
    chains = default_chains(learned.settings) if chains is None else chains
    successive = successive_table(learned, images, chains)

    # The comparison image: the one whose learned MS-SSIM (PSNR if undefined) at the middle
    # level is the median of the set, so the picture is typical, not the best case.
    levels = sorted(learned.settings)
    mid_level = levels[len(levels) // 2]
    mid_points = [p for p in points if p.codec == learned.name and p.setting == mid_level]
    key = "ms_ssim" if all(math.isfinite(p.ms_ssim) for p in mid_points) else "psnr_db"
    ranked = sorted(mid_points, key=lambda p: (getattr(p, key), p.image))
    chosen_name = ranked[len(ranked) // 2].image
    chosen_image = dict(images)[chosen_name]

    files = [out_dir / "rd.csv", out_dir / "summary.csv", out_dir / "bits_ratios.csv"]
    write_csv(files[0], points)
    write_csv(files[1], summary)
    write_csv(files[2], [r for rows in ratios.values() for r in rows])
    files.append(out_dir / "successive.csv")
    write_csv(files[-1], successive)
    files += plot_rd(summary, out_dir)
    files.append(out_dir / "successive.png")
    plot_successive(successive, files[-1])
    files.append(out_dir / "comparison.png")
    comparison = comparison_picture(chosen_image, learned, mid_level, baselines, files[-1])

    frame = timing_frame(images[0][1])
    timed = timing_codec or learned
    timings = [time_codec(timed, level, frame, timing_repeats) for level in levels]
    cv2_threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        for codec, setting, _ in comparison[1:]:
            base = next(b for b in baselines if b.name == codec)
            timings.append(time_codec(base, setting, frame, timing_repeats))
    finally:
        cv2.setNumThreads(cv2_threads)
    return Report(summary, ratios, successive, timings, comparison, files)


def result_line(report: Report, learned_name: str) -> str:
    """The ``RESULT key=value ...`` line (bits ratios, median learned timing, per-level numbers)."""

    def num(x: float, digits: int = 3) -> str:
        return "nan" if not math.isfinite(x) else f"{x:.{digits}f}"

    learned_t = [t for t in report.timings if t.codec == learned_name]
    parts = [
        f"bits_vs_jpeg={num(median_ratio(report.ratios.get('jpeg', [])))}",
        f"bits_vs_webp={num(median_ratio(report.ratios.get('webp', [])))}",
        f"encode_decode_ms_320x240={num(float(np.median([t.total_ms for t in learned_t])), 2)}",
    ]
    for name, ratios in report.ratios.items():
        skipped = [str(r.level) for r in ratios if not math.isfinite(r.ratio)]
        if skipped:
            parts.append(f"levels_outside_{name}={','.join(skipped)}")
    for t in report.timings:
        if t.codec != learned_name:
            parts.append(f"{t.codec}_ms_320x240={num(t.total_ms, 2)}")
    for r in sorted(
        (r for r in report.summary if r.codec == learned_name), key=lambda r: r.setting
    ):
        parts.append(f"L{r.setting}_bpp={num(r.bpp, 4)}")
        parts.append(f"L{r.setting}_psnr_db={num(r.psnr_db, 2)}")
        parts.append(f"L{r.setting}_ms_ssim={num(r.ms_ssim, 4)}")
    return "RESULT " + " ".join(parts)


def format_report(report: Report, learned_name: str) -> str:
    """Human-readable tables of the report (everything but the RESULT line)."""
    lines = [
        f"{'codec':8} {'setting':>7} {'n':>3} {'bpp':>7} {'PSNR dB':>8} {'SSIM':>7} {'MS-SSIM':>8}"
    ]
    for r in report.summary:
        lines.append(
            f"{r.codec:8} {r.setting:7d} {r.n_images:3d} {r.bpp:7.3f} {r.psnr_db:8.2f} "
            f"{r.ssim:7.4f} {r.ms_ssim:8.4f}"
        )
    lines.append("")
    lines.append("bits at equal MS-SSIM (learned bpp / baseline bpp):")
    for name, rows in report.ratios.items():
        for r in rows:
            if math.isfinite(r.ratio):
                lines.append(
                    f"  L{r.level} MS-SSIM {r.learned_ms_ssim:.4f}: {r.learned_bpp:.3f} bpp vs "
                    f"{name} {r.baseline_bpp:.3f} bpp -> {r.ratio:.3f}"
                )
            else:
                lines.append(
                    f"  L{r.level} MS-SSIM {r.learned_ms_ssim:.4f}: outside {name}'s measured "
                    "range, skipped"
                )
        lines.append(f"  median vs {name}: {median_ratio(rows):.3f}")
    lines.append("")
    lines.append("successive compression (means over the images; quality vs raw / vs previous):")
    for r in report.successive:
        lines.append(
            f"  {r.chain:16} stage {r.stage} L{r.setting}: {r.bpp:.3f} bpp, "
            f"PSNR {r.psnr_db_vs_raw:.2f} / {r.psnr_db_vs_previous:.2f} dB, "
            f"MS-SSIM {r.ms_ssim_vs_raw:.4f} / {r.ms_ssim_vs_previous:.4f}"
            + (f", {r.unchanged_fraction:.0%} unchanged" if r.unchanged_fraction else "")
        )
    lines.append("")
    lines.append(
        "comparison picture at about equal bits: "
        + ", ".join(f"{c} {s} ({b:.3f} bpp)" for c, s, b in report.comparison)
    )
    lines.append("timing, 320x240 frame, one thread (median ms):")
    for t in report.timings:
        lines.append(
            f"  {t.codec:8} setting {t.setting:3d}: encode {t.encode_ms:.2f} + decode "
            f"{t.decode_ms:.2f} = {t.total_ms:.2f}"
        )
    return "\n".join(lines)


def _int_list(text: str) -> tuple[int, ...]:
    try:
        values = tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError as exc:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated integers, got {text!r}"
        ) from exc
    if not values:
        raise argparse.ArgumentTypeError("expected at least one integer")
    return values


def build_parser() -> argparse.ArgumentParser:
    """The command-line options of ``python -m compression.evaluate``."""
    parser = argparse.ArgumentParser(
        prog="python -m compression.evaluate",
        description="Rate-distortion curves of the learned codec, JPEG and WebP on held-out "
        "images.",
    )
    parser.add_argument(
        "--images",
        metavar="DIR",
        type=Path,
        default=DEFAULT_IMAGES,
        help="folder of held-out PNG images, rendered with harness.imagery if it has none "
        "(e.g. --images data/imagery/heldout)",
    )
    parser.add_argument(
        "--count",
        metavar="N",
        type=int,
        default=HELDOUT_COUNT,
        help="images to render when --images is empty (e.g. --count 48)",
    )
    parser.add_argument(
        "--out",
        metavar="DIR",
        type=Path,
        default=DEFAULT_OUT,
        help="folder for the CSVs and PNG plots (e.g. --out /tmp/eval)",
    )
    parser.add_argument(
        "--levels",
        metavar="LIST",
        type=_int_list,
        default=None,
        help="learned codec levels to evaluate, default all (e.g. --levels 1,3,5)",
    )
    parser.add_argument(
        "--jpeg-qualities",
        metavar="LIST",
        type=_int_list,
        default=JpegCodec().settings,
        help="JPEG qualities 1..100 to sweep (e.g. --jpeg-qualities 5,25,50,75,95)",
    )
    parser.add_argument(
        "--webp-qualities",
        metavar="LIST",
        type=_int_list,
        default=WebpCodec().settings,
        help="WebP qualities 1..100 to sweep (e.g. --webp-qualities 5,25,50,75,100)",
    )
    parser.add_argument(
        "--successive",
        metavar="LIST",
        type=_int_list,
        action="append",
        default=None,
        help="a chain of levels for successive compression, edge first; repeatable "
        "(e.g. --successive 5,3,1 --successive 5,5,5); default: best x3 and best>middle>lowest",
    )
    parser.add_argument(
        "--timing-repeats",
        metavar="N",
        type=int,
        default=30,
        help="encode+decode runs per timing, median reported (e.g. --timing-repeats 100)",
    )
    return parser


def main(argv: Sequence[str] | None = None, learned: ImageCodec | None = None) -> int:
    """Run the evaluation; ``learned`` replaces the package codec (tests use a stand-in)."""
    args = build_parser().parse_args(argv)
    try:
        if args.count < 1 or args.timing_repeats < 1:
            raise ValueError("--count and --timing-repeats must be >= 1")
        jpeg = JpegCodec(settings=args.jpeg_qualities)
        webp = WebpCodec(settings=args.webp_qualities)
        timing_codec = None
        if learned is None:
            learned = LearnedCodec()
            timing_codec = LearnedCodec(threads=1)
        if args.levels is not None:
            learned = SettingsSubset(learned, tuple(sorted(args.levels)))
            if timing_codec is not None:
                timing_codec = SettingsSubset(timing_codec, tuple(sorted(args.levels)))
        ensure_heldout_images(args.images, args.count)
        images = load_images(args.images)
        report = run_evaluation(
            images,
            learned,
            [jpeg, webp],
            args.out,
            chains=args.successive,
            timing_codec=timing_codec,
            timing_repeats=args.timing_repeats,
        )
    except (ValueError, RuntimeError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    details = machine_details()
    print("machine: " + ", ".join(f"{k} {v}" for k, v in details.items()))
    print(f"images: {len(images)} from {args.images}; outputs in {args.out}")
    print(format_report(report, learned.name))
    print(result_line(report, learned.name))
    return 0


if __name__ == "__main__":
    sys.exit(main())
