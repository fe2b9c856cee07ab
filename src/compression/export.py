"""Turn a trained ``Autoencoder`` into a model directory the companion's ``Codec`` loads."""

from __future__ import annotations

import json
import warnings
from dataclasses import asdict
from pathlib import Path

import numpy as np
import torch

from compression.bitstream import FORMAT_VERSION
from compression.bundle import save_tables
from compression.entropy import LevelTables, tables_from_pmf
from compression.model import Autoencoder

LATENT_RANGE = 2048
"""Integers (either sign) on which the priors are tabulated; beyond them values are escaped."""


def level_tables(model: Autoencoder) -> list[LevelTables]:
    """The entropy tables of every level, from the priors evaluated in double precision."""
    values = torch.arange(-LATENT_RANGE, LATENT_RANGE + 1, dtype=torch.float64)
    tables = []
    for prior in model.priors:
        pmf = prior.double().integer_pmf(values).numpy()
        prior.float()
        tables.append(tables_from_pmf(values.numpy().astype(np.int64), pmf))
    return tables


def export_model(model: Autoencoder, directory: Path, levels: tuple[int, ...], meta: dict) -> None:
    """Write ``encoder.onnx``, ``decoder.onnx``, ``tables.npz``, ``model.pt`` and ``meta.json``."""
    directory.mkdir(parents=True, exist_ok=True)
    model = model.eval()
    image = torch.rand(1, 3, 64, 96)
    latent = torch.randn(1, model.config.latent_channels, 4, 6)
    _to_onnx(model.g_a, image, directory / "encoder.onnx", ("image", "latent"))
    _to_onnx(model.g_s, latent, directory / "decoder.onnx", ("latent", "image"))
    with torch.no_grad():
        gains = torch.exp(model.log_gains).numpy()
    save_tables(directory / "tables.npz", gains, level_tables(model))
    torch.save(model.state_dict(), directory / "model.pt")
    record = {
        "format_version": FORMAT_VERSION,
        "levels": list(levels),
        "downsampling": model.config.downsampling,
        "config": asdict(model.config),
        **meta,
    }
    (directory / "meta.json").write_text(json.dumps(record, indent=2) + "\n")


def _to_onnx(
    module: torch.nn.Module, example: torch.Tensor, path: Path, names: tuple[str, str]
) -> None:
    """Export one transform with free batch, height and width (TorchScript exporter, opset 17)."""
    axes = {
        "image": {0: "n", 2: "height", 3: "width"},
        "latent": {0: "n", 2: "h", 3: "w"},
    }
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        torch.onnx.export(
            module,
            (example,),
            str(path),
            input_names=[names[0]],
            output_names=[names[1]],
            dynamic_axes={name: axes[name] for name in names},
            opset_version=17,
            dynamo=False,
        )
