"""Training is seeded and reproducible, and its command writes a model the codec loads."""

import json
import struct
import subprocess
import sys

import numpy as np
import pytest
import torch

from compression import Codec
from compression.train import TrainConfig, train

pytestmark = pytest.mark.heavy


def _images(n=3):
    rng = np.random.default_rng(5)
    return [rng.integers(0, 256, (200, 210, 3), dtype=np.uint8) for _ in range(n)]


def test_same_seed_same_weights_other_seed_other_weights():
    config = TrainConfig(steps=6, batch=2, patch_px=176)
    a, log_a = train(config, _images(), progress=False)
    b, log_b = train(config, _images(), progress=False)
    c, _ = train(TrainConfig(steps=6, batch=2, patch_px=176, seed=1), _images(), progress=False)
    for (name, pa), pb in zip(a.state_dict().items(), b.state_dict().values(), strict=True):
        assert torch.equal(pa, pb), name
    assert any(
        not torch.equal(pa, pc) for pa, pc in zip(a.parameters(), c.parameters(), strict=True)
    )
    assert log_a == log_b
    assert {r["level"] for r in log_a} == set(range(5))  # every level trains in turn


def test_training_leaves_denormal_floats_alone_in_the_process():
    """Flush-to-zero is on only while it trains: after it, a float32 denormal (PX4's bytewise
    INT32 parameter 1) still reads back, for an autopilot or test in the same process."""
    one = struct.unpack("<f", struct.pack("<i", 1))[0]
    train(TrainConfig(steps=1, batch=1, patch_px=176), _images(1), progress=False)
    assert struct.unpack("<f", struct.pack("<i", 1))[0] == one > 0.0
    assert torch.tensor([one], dtype=torch.float32).item() > 0.0


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"patch_px": 160}, "patch_px"),
        ({"patch_px": 200}, "patch_px"),
        ({"lambdas": (1.0, 2.0)}, "lambdas"),
        ({"steps": 0}, "steps"),
    ],
)
def test_bad_training_config_names_the_field(kwargs, field):
    with pytest.raises(ValueError, match=field):
        TrainConfig(**kwargs)


def test_train_command_renders_trains_and_writes_a_loadable_model(tmp_path):
    out = tmp_path / "model"
    command = [
        sys.executable,
        "-m",
        "compression.train",
        "--out",
        str(out),
        "--images",
        str(tmp_path / "img"),
        "--train-count",
        "4",
        "--heldout-count",
        "2",
        "--steps",
        "5",
    ]
    done = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert len(list((tmp_path / "img" / "train").glob("*.png"))) == 4
    meta = json.loads((out / "meta.json").read_text())
    assert meta["train_config"]["steps"] == 5 and len(meta["heldout_bits_per_pixel"]) == 5
    codec = Codec.load(out)
    image = np.zeros((40, 50, 3), dtype=np.uint8)
    assert codec.decode(codec.encode(image, 5)).shape == image.shape


@pytest.mark.slow
def test_full_training_reproduces_the_shipped_rates(tmp_path):
    """`python -m compression.train` with its defaults gives the shipped model's held-out rates.

    Bit-identical weights on the machine that trained it; on another CPU the float reductions may
    differ, so the rates are compared within 5 %.
    """
    from compression.bundle import DEFAULT_MODEL_DIR

    out = tmp_path / "model"
    command = [sys.executable, "-m", "compression.train", "--out", str(out)]
    command += ["--images", str(tmp_path / "img")]
    done = subprocess.run(command, capture_output=True, text=True, timeout=3600)
    assert done.returncode == 0, done.stderr[-2000:]
    shipped = json.loads((DEFAULT_MODEL_DIR / "meta.json").read_text())["heldout_bits_per_pixel"]
    rates = json.loads((out / "meta.json").read_text())["heldout_bits_per_pixel"]
    assert rates == pytest.approx(shipped, rel=0.05)
