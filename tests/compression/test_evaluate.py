"""The evaluation end to end on three synthetic images, with JPEG standing in for the codec."""

from __future__ import annotations

import csv
import math
import subprocess
import sys
from dataclasses import dataclass

import numpy as np
import pytest
from synthetic_images import one_torch_thread, write_synthetic_pngs  # noqa: F401 (autouse fixture)

from compression import dataset, evaluate
from compression.baselines import JpegCodec, WebpCodec
from compression.evaluate import RDSummary, baseline_bpp_at, bits_ratios, median_ratio


@dataclass(frozen=True)
class StandIn:
    """JPEG under the name "learned", levels 1..3 mapped to qualities."""

    name: str = "learned"
    settings: tuple[int, ...] = (1, 2, 3)
    quality = (15, 40, 80)

    def encode(self, image, setting):
        return JpegCodec().encode(image, self.quality[setting - 1])

    def decode(self, data):
        return JpegCodec().decode(data)


def _row(codec, setting, bpp, q):
    return RDSummary(codec, setting, 1, bpp, 30.0, 0.9, q)


def test_baseline_interpolation_uses_the_pareto_front():
    """Interpolation is linear between efficient points; dominated points are ignored."""
    base = [_row("jpeg", 10, 0.2, 0.90), _row("jpeg", 20, 0.4, 0.95), _row("jpeg", 30, 0.5, 0.94)]
    base.append(_row("jpeg", 40, 1.0, 0.99))
    assert baseline_bpp_at(base, 0.925) == pytest.approx(0.3)
    assert baseline_bpp_at(base, 0.97) == pytest.approx(0.4 + 0.6 * 0.5)
    assert math.isnan(baseline_bpp_at(base, 0.89))  # below the range: skipped
    assert math.isnan(baseline_bpp_at(base, 0.995))  # above the range: skipped


def test_bits_ratio_and_median_skip_levels_outside_the_range():
    """Ratio = learned bpp / baseline bpp at equal MS-SSIM; the median ignores skipped levels."""
    base = [_row("webp", 10, 0.2, 0.90), _row("webp", 90, 1.2, 0.99)]
    learned = [_row("learned", 1, 0.1, 0.80), _row("learned", 2, 0.35, 0.92)]
    learned.append(_row("learned", 3, 0.6, 0.97))
    ratios = bits_ratios(learned, base, "webp")
    assert math.isnan(ratios[0].ratio)
    assert ratios[1].ratio == pytest.approx(0.35 / (0.2 + 1.0 * 2 / 9))
    assert ratios[2].ratio == pytest.approx(0.6 / (0.2 + 1.0 * 7 / 9))
    assert median_ratio(ratios) == pytest.approx((ratios[1].ratio + ratios[2].ratio) / 2)
    assert math.isnan(median_ratio(ratios[:1]))


def test_same_codec_as_baseline_gives_ratio_one():
    """JPEG against itself: every level inside the range has a bits ratio of about 1."""
    jpeg = [_row("jpeg", q, 0.01 * q, 0.8 + 0.002 * q) for q in (5, 25, 50, 75, 95)]
    learned = [_row("learned", i, r.bpp, r.ms_ssim) for i, r in enumerate(jpeg[1:4])]
    assert [r.ratio for r in bits_ratios(learned, jpeg, "jpeg")] == pytest.approx([1, 1, 1])


def test_end_to_end_writes_csvs_plots_and_result_line(tmp_path, capsys):
    """main() on 3 images: CSVs with one row per codec/setting/image, small PNGs, RESULT last."""
    images_dir = tmp_path / "heldout"
    write_synthetic_pngs(images_dir, 3)
    out = tmp_path / "out"
    argv = ["--images", str(images_dir), "--out", str(out), "--jpeg-qualities", "10,30,60,90"]
    argv += ["--webp-qualities", "10,30,60,90,100", "--timing-repeats", "2"]
    assert evaluate.main(argv, learned=StandIn()) == 0
    printed = capsys.readouterr().out.strip().splitlines()
    assert printed[0].startswith("machine: cpu ")
    result = printed[-1]
    assert result.startswith("RESULT bits_vs_jpeg=")
    values = dict(kv.split("=") for kv in result.split()[1:])
    # The stand-in *is* JPEG: at equal MS-SSIM it needs about JPEG's bits.
    assert float(values["bits_vs_jpeg"]) == pytest.approx(1.0, abs=0.12)
    assert float(values["encode_decode_ms_320x240"]) > 0
    assert {"L1_bpp", "L3_ms_ssim", "jpeg_ms_320x240", "webp_ms_320x240"} <= set(values)

    with (out / "rd.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 3 * (3 + 4 + 5)
    assert set(rows[0]) == {
        "codec",
        "setting",
        "image",
        "n_bytes",
        "bpp",
        "psnr_db",
        "ssim",
        "ms_ssim",
    }
    jpeg60 = [r for r in rows if r["codec"] == "jpeg" and r["setting"] == "60"]
    assert sorted(r["image"] for r in jpeg60) == ["00000.png", "00001.png", "00002.png"]
    for name in ("summary.csv", "bits_ratios.csv", "successive.csv"):
        assert (out / name).stat().st_size > 0
    for name in (
        "rd_psnr_db.png",
        "rd_ssim.png",
        "rd_ms_ssim.png",
        "successive.png",
        "comparison.png",
    ):
        data = (out / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n"
        assert len(data) < 200_000
    with (out / "successive.csv").open() as fh:
        chains = {r["chain"] for r in csv.DictReader(fh)}
    assert chains == {"learned 3>3>3", "learned 3>2>1"}


def test_evaluation_is_deterministic(tmp_path):
    """Two runs on the same images write byte-identical CSVs."""
    images = [(f"{i}.png", img) for i, img in enumerate(write_synthetic_pngs(tmp_path / "i", 2))]
    baselines = [JpegCodec(settings=(20, 80)), WebpCodec(settings=(20, 80))]
    for run in ("a", "b"):
        evaluate.run_evaluation(
            images, StandIn(), baselines, tmp_path / run, chains=[(3, 1)], timing_repeats=1
        )
    for name in ("rd.csv", "summary.csv", "bits_ratios.csv", "successive.csv"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()


def test_bad_options_exit_2_with_a_message(tmp_path, capsys):
    """An empty images folder that cannot be rendered, or unknown levels: exit 2, clear error."""
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "x.png").write_bytes(b"not a png")
    assert evaluate.main(["--images", str(empty), "--out", str(tmp_path / "o")], StandIn()) == 2
    assert "cannot read" in capsys.readouterr().err
    argv = ["--images", str(empty), "--levels", "7"]
    assert evaluate.main(argv, learned=StandIn()) == 2
    assert "levels [7]" in capsys.readouterr().err


def test_missing_heldout_images_are_rendered_by_harness_imagery(tmp_path, monkeypatch):
    """An empty folder triggers `python -m harness.imagery --split heldout` as a subprocess."""
    calls = []

    def fake_run(cmd, **kwargs):
        calls.append(cmd)
        write_synthetic_pngs(tmp_path / "held", 1)
        return subprocess.CompletedProcess(cmd, 0, "", "")

    monkeypatch.setattr(dataset.subprocess, "run", fake_run)
    evaluate.ensure_heldout_images(tmp_path / "held", 5)
    assert calls == [
        [
            sys.executable,
            "-m",
            "harness.imagery",
            "--split",
            "heldout",
            "--count",
            "5",
            "--out",
            str(tmp_path / "held"),
        ]
    ]
    evaluate.ensure_heldout_images(tmp_path / "held", 5)  # PNGs there now: no second render
    assert len(calls) == 1


def test_a_failed_render_is_a_runtime_error_with_its_stderr(tmp_path, monkeypatch):
    """If the renderer fails, the error carries its exit code and last stderr lines."""
    monkeypatch.setattr(
        dataset.subprocess,
        "run",
        lambda cmd, **kw: subprocess.CompletedProcess(cmd, 1, "", "boom: no such scene\n"),
    )
    with pytest.raises(RuntimeError, match=r"exit 1.*boom"):
        evaluate.ensure_heldout_images(tmp_path / "none", 3)


@dataclass(frozen=True)
class Posterise:
    """An idempotent lossy "codec": keeps the top 3 bits of each channel, raw bytes."""

    name: str = "posterise"
    settings: tuple[int, ...] = (1,)
    shape: tuple[int, int, int] = (176, 208, 3)

    def encode(self, image, setting):
        return (image & 0xE0).tobytes()

    def decode(self, data):
        return np.frombuffer(data, np.uint8).reshape(self.shape).copy()


def test_successive_table_leaves_unchanged_images_out_of_the_psnr_mean(tmp_path):
    """An idempotent stage changes nothing: unchanged_fraction 1, PSNR vs previous nan."""
    images = [(f"{i}", img) for i, img in enumerate(write_synthetic_pngs(tmp_path, 2))]
    rows = evaluate.successive_table(Posterise(), images, [(1, 1)])
    first, second = rows
    assert first.chain == "posterise 1>1"
    assert first.unchanged_fraction == 0.0
    assert math.isfinite(first.psnr_db_vs_previous)
    assert second.unchanged_fraction == 1.0
    assert math.isnan(second.psnr_db_vs_previous)
    assert second.ms_ssim_vs_previous == pytest.approx(1.0, abs=1e-6)
    assert second.psnr_db_vs_raw == pytest.approx(first.psnr_db_vs_raw)
