"""harness.imagery: images of the project's scenes for the codec, through the sitl cameras."""

from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from harness.imagery import SCENES, ImageInfo, render_images, world_seed

pytestmark = pytest.mark.process

SMALL = {"width": 80, "height": 60}
"""Small frames: the scenes are the same, the tests fast."""


@pytest.fixture(scope="module")
def train_images() -> list[tuple[np.ndarray, ImageInfo]]:
    """Forty small train images: 16 offshore, 12 city, 8 indoor, 4 land."""
    return list(render_images("train", 40, seed=0, **SMALL))


def test_images_are_rgb_frames_of_each_scene_in_the_mix(train_images):
    """RGB uint8 of the asked size; 40 % offshore, 30 % city, 20 % indoor, 10 % land."""
    for rgb, _ in train_images:
        assert rgb.dtype == np.uint8 and rgb.shape == (60, 80, 3)
    scenes = [info.scene for _, info in train_images]
    assert [scenes.count(s) for s in SCENES] == [16, 12, 8, 4]
    assert [info.index for _, info in train_images] == list(range(40))


def test_images_are_not_blank(train_images):
    """Every frame has structure (pixel std > 2 levels); the set is far from uniform."""
    stds = np.array([rgb.std() for rgb, _ in train_images])
    assert (stds > 2.0).all(), stds.min()
    assert np.median(stds) > 10.0
    means = np.array([rgb.mean(axis=(0, 1)) for rgb, _ in train_images])
    assert means.std(axis=0).min() > 5.0  # scenes, worlds and lighting differ in colour


def test_oil_spills_show_in_many_offshore_frames(train_images):
    """At least a third of the offshore frames hold oil: pixels whose brightest channel <= 28
    (the companion's spill detector's test; the sea's darkest texel stays far above it) over
    at least 1 % of the frame."""
    offshore = [rgb for rgb, info in train_images if info.scene == "offshore"]
    oily = [(rgb.max(axis=2) <= 28).mean() > 0.01 for rgb in offshore]
    assert sum(oily) >= len(offshore) / 3


def test_down_cameras_fly_in_their_altitude_bands_and_indoor_at_head_height(train_images):
    """Offshore 10-120 m, city at most 160 m, indoor 1-3 m; spill times rise within a world."""
    for _, info in train_images:
        if info.scene == "offshore":
            assert 10.0 <= info.altitude_m <= 120.0
        elif info.scene == "city":
            assert 25.0 <= info.altitude_m <= 160.0
        elif info.scene == "indoor":
            assert 1.0 <= info.altitude_m <= 3.0
    for seed in {info.seed for _, info in train_images}:
        times = [info.time_s for _, info in train_images if info.seed == seed]
        assert times == sorted(times)


def test_indoor_frames_look_forward_at_walls_and_floor(train_images):
    """A forward camera at 1-3 m sees the floor in its bottom rows and rarely the sky there."""
    for rgb, info in train_images:
        if info.scene == "indoor":
            sky = np.all(rgb[-10:] == (135, 185, 235), axis=2)
            assert sky.mean() < 0.05


def test_the_same_arguments_give_the_same_images():
    """Two runs with the same arguments: identical arrays; another seed: other worlds."""
    first = list(render_images("heldout", 6, seed=4, **SMALL))
    again = list(render_images("heldout", 6, seed=4, **SMALL))
    for (a, info_a), (b, info_b) in zip(first, again, strict=True):
        np.testing.assert_array_equal(a, b)
        assert info_a == info_b
    other = list(render_images("heldout", 6, seed=5, **SMALL))
    assert {i.seed for _, i in first}.isdisjoint({i.seed for _, i in other})
    assert not np.array_equal(first[0][0], other[0][0])


def test_train_and_heldout_never_share_a_world_instance():
    """World seeds: even for train, odd for heldout, for any run seed; and so in the images."""
    train = {world_seed("train", s, k) for s in range(5) for k in range(300)}
    heldout = {world_seed("heldout", s, k) for s in range(5) for k in range(300)}
    assert len(train) == len(heldout) == 1500 and train.isdisjoint(heldout)
    a = {info.seed for _, info in render_images("train", 30, seed=0, width=16, height=16)}
    b = {info.seed for _, info in render_images("heldout", 30, seed=0, width=16, height=16)}
    assert len(a) >= 4 and len(b) >= 4 and a.isdisjoint(b)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"split": "test"}, "split"),
        ({"count": -1}, "count"),
        ({"width": 8}, "width"),
        ({"height": 0}, "height"),
        ({"seed": -3}, "seed"),
    ],
)
def test_bad_arguments_name_the_argument(kwargs, field):
    args = {"split": "train", "count": 1, "width": 32, "height": 24, "seed": 0, **kwargs}
    with pytest.raises(ValueError, match=field):
        next(render_images(**args))


def _run(out: Path, *extra: str) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-m", "harness.imagery", "--out", str(out), *extra]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=False)


def test_the_cli_writes_pngs_and_an_index_byte_identical_on_a_second_run(tmp_path):
    """PNG files (RGB, read back with OpenCV as BGR), index.csv with one row per image."""
    args = ("--split", "train", "--count", "5", "--width", "64", "--height", "48", "--seed", "2")
    first = _run(tmp_path / "a", *args)
    assert first.returncode == 0, first.stderr
    assert "5/5 images" in first.stdout
    assert _run(tmp_path / "b", *args).returncode == 0
    names = sorted(p.name for p in (tmp_path / "a").iterdir())
    assert names == ["00000.png", "00001.png", "00002.png", "00003.png", "00004.png", "index.csv"]
    for name in names:
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()
    with (tmp_path / "a" / "index.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert [r["file"] for r in rows] == names[:5]
    assert {r["split"] for r in rows} == {"train"}
    expected = list(render_images("train", 5, 64, 48, 2))
    for row, (rgb, info) in zip(rows, expected, strict=True):
        assert row["scene"] == info.scene and int(row["seed"]) == info.seed
        assert float(row["altitude_m"]) == pytest.approx(info.altitude_m, abs=1e-3)
        png = cv2.imread(str(tmp_path / "a" / row["file"]), cv2.IMREAD_UNCHANGED)
        np.testing.assert_array_equal(png[:, :, ::-1], rgb)


def test_the_cli_rejects_an_unknown_split(tmp_path):
    result = _run(tmp_path, "--split", "validation", "--count", "1")
    assert result.returncode == 2
    assert "--split" in result.stderr and "heldout" in result.stderr
