"""Entropy coding of the integer latent with the learned per-channel tables (constriction's ANS).

Each level has, per latent channel, the probability of every integer in ``[low, low + n - 2]``
and one more "escape" symbol for values outside that range (the tail mass the prior leaves
there). Escaped values travel beside the ANS words as varints (``compression.bitstream``).
The tables are fixed numbers written at export time, read identically by encoder and decoder, so
a stream decodes the same on every machine: no float computation is shared between the two ends
(the reason for a factorised prior rather than a hyperprior, whose scales would be recomputed by
the decoder's network and can differ in the last bit across CPUs).

constriction (Bamler, NeurIPS 2022) is a maintained Rust coder with numpy bindings; its
``Categorical`` model quantises the tables deterministically and gives every symbol a non-zero
probability, so any latent can be coded.
"""

from __future__ import annotations

from dataclasses import dataclass

import constriction
import numpy as np

from compression.bitstream import Payload
from compression.errors import StreamError

TAIL_MASS = 1e-6
"""Probability left outside a channel's table on both sides together (then escaped)."""


@dataclass(frozen=True)
class LevelTables:
    """One level's per-channel tables: ``pmf[c, :lengths[c]]`` covers ``low[c]``.. plus escape."""

    low: np.ndarray  # (C,) int64, smallest value with its own symbol
    lengths: np.ndarray  # (C,) int64, symbols per channel including the escape (last)
    pmf: np.ndarray  # (C, L) float64, zero-padded past lengths[c]


def tables_from_pmf(
    values: np.ndarray, pmf: np.ndarray, tail_mass: float = TAIL_MASS
) -> LevelTables:
    """Trim a prior evaluated on integers ``values`` (K,) as ``pmf`` (C, K) to where its mass is.

    Keeps, per channel, the integers between the ``tail_mass / 2`` quantiles on either side and
    gives the rest of the mass (at least ``tail_mass``) to the escape symbol.
    """
    pmf = np.asarray(pmf, dtype=np.float64)  # mass beyond ``values`` goes to the escape too
    cdf = np.cumsum(pmf, axis=1)
    first = np.argmax(cdf > tail_mass / 2, axis=1)
    last = np.argmax(cdf >= 1.0 - tail_mass / 2, axis=1)
    last = np.maximum(last, first)
    lengths = last - first + 2
    table = np.zeros((pmf.shape[0], int(lengths.max())))
    for c in range(pmf.shape[0]):
        kept = pmf[c, first[c] : last[c] + 1]
        table[c, : kept.size] = kept
        table[c, kept.size] = max(1.0 - kept.sum(), tail_mass)
    return LevelTables(
        low=values[first].astype(np.int64), lengths=lengths.astype(np.int64), pmf=table
    )


class LatentCoder:
    """Codes integer latents (C, h, w) of one level with its tables."""

    def __init__(self, tables: LevelTables) -> None:
        self.tables = tables
        self._models = [
            constriction.stream.model.Categorical(tables.pmf[c, :n], perfect=False)
            for c, n in enumerate(tables.lengths.tolist())
        ]

    def encode(self, latent: np.ndarray) -> Payload:
        """ANS words and escapes of an integer latent (C, h, w)."""
        channels = latent.shape[0]
        flat = latent.reshape(channels, -1).astype(np.int64)
        symbols = flat - self.tables.low[:, None]
        escape = (self.tables.lengths - 1)[:, None]
        outside = (symbols < 0) | (symbols >= escape)
        escapes = flat[outside]  # channel-major, in order: the decoder reads them back the same way
        symbols = np.where(outside, escape, symbols).astype(np.int32)
        coder = constriction.stream.stack.AnsCoder()
        for c in range(channels - 1, -1, -1):  # a stack: push the last channel first
            coder.encode_reverse(symbols[c], self._models[c])
        return Payload(escapes=escapes, words=coder.get_compressed())

    def decode(self, payload: Payload, shape: tuple[int, int, int]) -> np.ndarray:
        """The integer latent (C, h, w) back from its payload."""
        channels, h, w = shape
        if channels != len(self._models):
            raise StreamError(f"latent has {channels} channels, the tables {len(self._models)}")
        coder = constriction.stream.stack.AnsCoder(payload.words)
        out = np.empty((channels, h * w), dtype=np.int64)
        used = 0
        for c in range(channels):
            try:
                symbols = coder.decode(self._models[c], h * w).astype(np.int64)
            except Exception as exc:  # constriction raises on words it cannot read
                raise StreamError(f"stream corrupted: entropy decoding failed ({exc})") from exc
            escaped = symbols == self.tables.lengths[c] - 1
            values = symbols + self.tables.low[c]
            n = int(escaped.sum())
            if used + n > payload.escapes.size:
                raise StreamError("stream corrupted: more escaped latent values than stored")
            values[escaped] = payload.escapes[used : used + n]
            used += n
            out[c] = values
        if used != payload.escapes.size or not coder.is_empty():
            raise StreamError("stream corrupted: entropy-coded data left over after the latent")
        return out.reshape(channels, h, w)
