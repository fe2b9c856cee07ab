"""Train the codec on rendered scenes and write a model directory: ``python -m compression.train``.

One network for all levels (``compression.model``): each step trains one level, in turn, on the
rate-distortion loss ``R + lambda_level * D`` (Ballé et al. 2017, Eq. 2), with R the bits per
pixel under the level's prior and D = (1 - MS-SSIM) + MSE (MS-SSIM because the codec is judged at
equal MS-SSIM; the small MSE term keeps colours where MS-SSIM hardly looks). Seeded: the same
images, seed and thread count give the same weights.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Annotated

import numpy as np
import torch
import typer
from pytorch_msssim import ms_ssim

from compression.bundle import DEFAULT_MODEL_DIR
from compression.codec import Codec
from compression.dataset import DEFAULT_IMAGE_ROOT, ensure_images, random_batch, read_rgb
from compression.export import export_model
from compression.model import Autoencoder, ModelConfig

LEVELS = (1, 2, 3, 4, 5)


@dataclass(frozen=True)
class TrainConfig:
    """What a training run does; stored in the model's ``meta.json``."""

    steps: int = 5000
    batch: int = 8
    patch_px: int = 192
    learning_rate: float = 4e-3
    final_learning_rate: float = 2e-4
    lambdas: tuple[float, ...] = (2.0, 5.0, 12.0, 30.0, 75.0)
    """Distortion weight of each level, lowest quality first."""
    mse_weight: float = 10.0
    entropy_lr_factor: float = 10.0
    """The gains and priors learn this much faster than the transforms (they start far off)."""
    seed: int = 0
    threads: int = 1
    model: ModelConfig = field(default_factory=ModelConfig)

    def __post_init__(self) -> None:
        if len(self.lambdas) != self.model.levels:
            raise ValueError(
                f"TrainConfig.lambdas has {len(self.lambdas)} values for {self.model.levels} levels"
            )
        if self.patch_px < 176 or self.patch_px % 16:
            raise ValueError(
                f"TrainConfig.patch_px must be a multiple of 16 and >= 176 (5-scale MS-SSIM), "
                f"got {self.patch_px}"
            )
        for name in ("steps", "batch", "threads"):
            if getattr(self, name) < 1:
                raise ValueError(f"TrainConfig.{name} must be >= 1, got {getattr(self, name)}")


def learning_rate(config: TrainConfig, step: int) -> float:
    """Constant, then a cosine decay to ``final_learning_rate`` over the last half of the steps."""
    half = config.steps // 2
    if step < half:
        return config.learning_rate
    t = (step - half) / max(1, config.steps - half)
    lo, hi = config.final_learning_rate, config.learning_rate
    return lo + 0.5 * (hi - lo) * (1.0 + np.cos(np.pi * t))


def train(
    config: TrainConfig, images: list[np.ndarray], progress: bool = True
) -> tuple[Autoencoder, list[dict]]:
    """Train a model on RGB images; return it and the per-step log (loss, bpp, MS-SSIM, level).

    Denormal floats are flushed to zero while it trains (in the GDN they would slow the CPU
    tenfold) and the process default (off) is restored after: with flushing on, every float32
    denormal reads as 0 in the whole process, e.g. PX4's bytewise INT32 parameters (1 is a
    denormal) of an autopilot running in the same process.
    """
    torch.set_flush_denormal(True)
    try:
        return _train(config, images, progress)
    finally:
        torch.set_flush_denormal(False)


def _train(
    config: TrainConfig, images: list[np.ndarray], progress: bool
) -> tuple[Autoencoder, list[dict]]:
    torch.manual_seed(config.seed)
    torch.set_num_threads(config.threads)
    rng = np.random.default_rng(config.seed)
    model = Autoencoder(config.model)
    entropy_params = [model.log_gains, *model.priors.parameters()]
    ids = {id(p) for p in entropy_params}
    transforms = [p for p in model.parameters() if id(p) not in ids]
    optimiser = torch.optim.Adam(
        [
            {"params": transforms, "scale": 1.0},
            {"params": entropy_params, "scale": config.entropy_lr_factor},
        ],
        lr=config.learning_rate,
    )
    log: list[dict] = []
    pixels = config.batch * config.patch_px**2
    started = time.perf_counter()
    for step in range(config.steps):
        level = step % config.model.levels
        for group in optimiser.param_groups:
            group["lr"] = learning_rate(config, step) * group["scale"]
        x = torch.from_numpy(random_batch(images, rng, config.batch, config.patch_px))
        x_hat, bits = model(x, level)
        x_hat = x_hat.clamp(0.0, 1.0)
        similarity = ms_ssim(x_hat, x, data_range=1.0)
        mse = torch.mean((x_hat - x) ** 2)
        bpp = bits.sum() / pixels
        loss = bpp + config.lambdas[level] * ((1.0 - similarity) + config.mse_weight * mse)
        optimiser.zero_grad()
        loss.backward()
        torch.nn.utils.clip_grad_norm_(model.parameters(), 5.0)
        optimiser.step()
        log.append(
            {
                "step": step,
                "level": level,
                "loss": loss.item(),
                "bpp": bpp.item(),
                "ms_ssim": similarity.item(),
            }
        )
        if progress and (step + 1) % 250 == 0:
            levels = "  ".join(
                f"{np.mean([r['bpp'] for r in log[-250:] if r['level'] == i]):.3f}/"
                f"{np.mean([r['ms_ssim'] for r in log[-250:] if r['level'] == i]):.3f}"
                for i in range(config.model.levels)
            )
            print(
                f"step {step + 1}/{config.steps} {time.perf_counter() - started:5.0f} s  "
                f"bpp/MS-SSIM per level: {levels}",
                flush=True,
            )
    return model.eval(), log


def heldout_bits_per_pixel(codec: Codec, images: list[np.ndarray]) -> list[float]:
    """Mean bits per pixel of each level on the held-out images, from the real streams."""
    out = []
    for level in codec.levels:
        bits = [8 * len(codec.encode(image, level)) for image in images]
        pixels = [image.shape[0] * image.shape[1] for image in images]
        out.append(float(np.sum(bits) / np.sum(pixels)))
    return out


app = typer.Typer(add_completion=False)


@app.command()
def main(
    out: Annotated[Path, typer.Option(help="Model directory to write.")] = DEFAULT_MODEL_DIR,
    images: Annotated[
        Path, typer.Option(help="Image root with train/ and heldout/ (rendered when missing).")
    ] = DEFAULT_IMAGE_ROOT,
    train_count: Annotated[int, typer.Option(help="Training images to render and use.")] = 600,
    heldout_count: Annotated[int, typer.Option(help="Held-out images for the level rates.")] = 48,
    steps: Annotated[int, typer.Option(help="Optimisation steps (one level per step).")] = 5000,
    seed: Annotated[int, typer.Option(help="Seed of the crops, noise and initial weights.")] = 0,
    threads: Annotated[int, typer.Option(help="torch CPU threads (the result depends on it).")] = 1,
) -> None:
    """Train the default levels and write the model directory (ONNX + tables).

    Example: python -m compression.train --steps 5000 --out src/compression/models/default
    """
    config = TrainConfig(steps=steps, seed=seed, threads=threads)
    started = time.perf_counter()
    train_paths = ensure_images(images / "train", "train", train_count)
    heldout_paths = ensure_images(images / "heldout", "heldout", heldout_count)
    train_images = [read_rgb(p) for p in train_paths]
    render_s = time.perf_counter() - started
    model, log = train(config, train_images)
    train_s = time.perf_counter() - started - render_s
    meta = {
        "train_config": asdict(config),
        "train_images": len(train_images),
        "render_seconds": round(render_s, 1),
        "train_seconds": round(train_s, 1),
        "torch": torch.__version__,
        "final_log": log[-config.model.levels :],
        "heldout_bits_per_pixel": [0.0] * config.model.levels,
    }
    export_model(model, out, LEVELS, meta)
    codec = Codec.load(out)
    heldout = [read_rgb(p) for p in heldout_paths]
    meta["heldout_bits_per_pixel"] = heldout_bits_per_pixel(codec, heldout)
    meta["heldout_images"] = len(heldout)
    record = json.loads((out / "meta.json").read_text())
    record.update(meta)
    (out / "meta.json").write_text(json.dumps(record, indent=2) + "\n")
    total = time.perf_counter() - started
    print(f"wrote {out} in {total:.0f} s (render {render_s:.0f} s, train {train_s:.0f} s)")
    for level, bpp in zip(LEVELS, meta["heldout_bits_per_pixel"], strict=True):
        print(f"  level {level}: {bpp:.3f} bits per pixel on {len(heldout)} held-out images")


if __name__ == "__main__":
    app()
