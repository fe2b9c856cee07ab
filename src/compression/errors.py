"""The codec's exceptions: every failure of ``encode`` or ``decode`` is one of these."""

from __future__ import annotations


class CompressionError(ValueError):
    """Base of the codec's errors: bad input image, damaged stream, wrong model."""


class StreamError(CompressionError):
    """The bytes are not a complete, intact stream of this codec (truncated, corrupted, foreign)."""


class ModelMismatchError(CompressionError):
    """The stream is intact but was written by another model or bitstream format version."""
