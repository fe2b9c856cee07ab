"""The cameras' ground in a world without a scene: seeded grass-like noise with a metre grid.

The texture tiles seamlessly (the noise is periodic: filtered in the Fourier domain), so one
small image repeats over the whole ground plane; the grid lines make motion and scale visible in
the camera images. A scene's own surface (sea, asphalt, grass, concrete) is drawn by
``surface_texture``; world generation proper (terrain, targets, spills) belongs to ``worlds/``.
"""

from __future__ import annotations

import numpy as np

GRASS_RGB = np.array([86.0, 125.0, 60.0])
"""Mean colour of the ground, RGB."""
DIRT_RGB = np.array([128.0, 108.0, 76.0])
"""Colour of the bare patches, RGB."""
GRID_RGB = np.array([215.0, 215.0, 200.0])
"""Colour of the grid lines, RGB."""


def _periodic_noise(rng: np.random.Generator, size_px: int, beta: float) -> np.ndarray:
    """Zero-mean, unit-variance noise with a 1/f^beta spectrum that tiles seamlessly."""
    spectrum = np.fft.rfft2(rng.standard_normal((size_px, size_px)))
    fy = np.fft.fftfreq(size_px)[:, None]
    fx = np.fft.rfftfreq(size_px)[None, :]
    f = np.hypot(fx, fy)
    f[0, 0] = np.inf  # no DC term
    noise = np.fft.irfft2(spectrum / f**beta, s=(size_px, size_px))
    return (noise - noise.mean()) / noise.std()


def ground_texture(
    rng: np.random.Generator, size_px: int = 256, tile_m: float = 20.0, grid_m: float = 5.0
) -> np.ndarray:
    """One tile of ground, (size_px, size_px, 3) uint8 RGB, covering tile_m x tile_m metres.

    Grass-like fine noise over larger bare patches, with grid lines every ``grid_m`` metres
    (``tile_m`` must be a multiple of it so the grid continues across tiles).
    """
    if size_px < 16:
        raise ValueError(f"size_px must be >= 16, got {size_px}")
    lines = tile_m / grid_m
    if not (grid_m > 0.0 and abs(lines - round(lines)) < 1e-9 and round(lines) >= 1):
        raise ValueError(f"tile_m={tile_m} must be a whole multiple of grid_m={grid_m}")
    patches = _periodic_noise(rng, size_px, 1.6)
    fine = _periodic_noise(rng, size_px, 0.4)
    dirt = np.clip(0.5 + 0.35 * patches, 0.0, 1.0)[..., None] ** 2
    rgb = (1.0 - dirt) * GRASS_RGB + dirt * DIRT_RGB
    rgb *= (1.0 + 0.18 * fine)[..., None]
    step_px = size_px / round(lines)
    width_px = max(1, round(0.15 * size_px / tile_m))  # 15 cm wide lines
    on_line = (np.arange(size_px) % step_px) < width_px
    rgb[on_line, :] = GRID_RGB
    rgb[:, on_line] = GRID_RGB
    return np.clip(rgb, 0.0, 255.0).astype(np.uint8)
