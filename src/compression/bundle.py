"""A trained model on disk: the two ONNX transforms, the level tables and what describes them.

A model directory holds ``encoder.onnx`` (image -> unscaled latent), ``decoder.onnx`` (rescaled
latent -> image), ``tables.npz`` (per level: gains and entropy tables), ``meta.json`` (architecture,
levels, training record, the held-out bits per pixel of each level) and ``model.pt`` (the torch
weights, for evaluation and fine-tuning; the companion does not need torch). The model id in every
stream is the first 8 bytes of the SHA-256 of the ONNX files and the tables, so a stream written
by other weights is refused rather than decoded into garbage.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from compression.entropy import LevelTables
from compression.errors import CompressionError

DEFAULT_MODEL_DIR = Path(__file__).resolve().parent / "models" / "default"
FILES = ("encoder.onnx", "decoder.onnx", "tables.npz", "meta.json")


@dataclass(frozen=True)
class ModelBundle:
    """The files of a model directory, read and checked."""

    directory: Path
    model_id: bytes
    levels: tuple[int, ...]
    gains: np.ndarray  # (levels, C) float32
    tables: tuple[LevelTables, ...]
    meta: dict = field(repr=False)

    @property
    def latent_channels(self) -> int:
        """Channels of the latent."""
        return int(self.gains.shape[1])

    @property
    def downsampling(self) -> int:
        """Pixels per latent position along each axis."""
        return int(self.meta["downsampling"])

    def level_index(self, level: int) -> int:
        """0-based index of a level, or a ``CompressionError`` naming the valid ones."""
        if (
            isinstance(level, bool)
            or not isinstance(level, int | np.integer)
            or level not in self.levels
        ):
            raise CompressionError(f"level must be one of {self.levels}, got {level!r}")
        return self.levels.index(int(level))


def model_id_of(directory: Path) -> bytes:
    """Identity of a model: SHA-256 over its ONNX files and tables, first 8 bytes."""
    digest = hashlib.sha256()
    for name in ("encoder.onnx", "decoder.onnx", "tables.npz"):
        digest.update((directory / name).read_bytes())
    return digest.digest()[:8]


def save_tables(path: Path, gains: np.ndarray, tables: list[LevelTables]) -> None:
    """Write the per-level gains and entropy tables."""
    arrays: dict[str, np.ndarray] = {"gains": gains.astype(np.float32)}
    for i, t in enumerate(tables):
        arrays[f"low_{i}"] = t.low
        arrays[f"lengths_{i}"] = t.lengths
        arrays[f"pmf_{i}"] = t.pmf
    with path.open("wb") as f:
        np.savez_compressed(f, **arrays)


def load_bundle(directory: Path | str | None = None) -> ModelBundle:
    """Read a model directory (the shipped default model when ``None``)."""
    directory = Path(directory) if directory is not None else DEFAULT_MODEL_DIR
    missing = [name for name in FILES if not (directory / name).is_file()]
    if missing:
        hint = " (train one: python -m compression.train)" if directory == DEFAULT_MODEL_DIR else ""
        raise CompressionError(f"model directory {directory} lacks {', '.join(missing)}{hint}")
    meta = json.loads((directory / "meta.json").read_text())
    levels = tuple(int(x) for x in meta["levels"])
    with np.load(directory / "tables.npz") as data:
        gains = data["gains"]
        tables = tuple(
            LevelTables(low=data[f"low_{i}"], lengths=data[f"lengths_{i}"], pmf=data[f"pmf_{i}"])
            for i in range(len(levels))
        )
    if gains.shape[0] != len(levels):
        raise CompressionError(
            f"{directory}: {gains.shape[0]} gain vectors for {len(levels)} levels"
        )
    return ModelBundle(directory, model_id_of(directory), levels, gains, tables, meta)
