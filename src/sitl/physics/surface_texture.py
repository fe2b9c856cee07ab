"""Procedural camera textures for a ``worlds`` surface: sea waves, asphalt, grass, concrete.

One square tile per world, made once at start from the world's scenery generator and repeated
over the ground plane by ``sitl.sensors.camera_ground`` (a nearest-texel lookup per pixel ray,
whose cost does not depend on what the texture shows). Every pattern is built from noise
filtered in the Fourier domain, so it is periodic and the tile's edges meet seamlessly; the
concrete slabs divide the tile exactly.

The colour of each texture averages to the surface's ``rgba`` (channel by channel), and its
brightness spread matches ``texture_contrast``: about 90 % of the texels lie within
``mean * (1 +- contrast)`` (:func:`contrast_of` measures it). The sea's texels never fall below
``mean * (1 - SEA_FLOOR_SPREAD * contrast)``, so even its darkest trough stays far brighter than an
oil film (the companion's spill detector calls a pixel oil when its brightest channel is <= 28).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from worlds import Surface

TEXTURE_PX = 512
"""Side of a surface tile, texels: the ground lookup costs the same as with the 256-texel grass
(measured: 0.44 vs 0.43 ms per 320x240 frame); 1024 texels would cost 50 % more."""
SEA_TILE_WAVES = 8
"""Dominant wave lengths across one sea tile (at least ``SEA_MIN_TILE_M``)."""
SEA_MIN_TILE_M = 64.0
"""Smallest side of a sea tile, m: 12.5 cm texels (ripples still show from 10 m); a larger tile
would blur the sea seen from low, and its repeat is hard to spot from 30 m."""
ASPHALT_TILE_M = 32.0
"""Side of an asphalt tile, m (6 cm texels: the grain of the surface from 10 m up)."""
GRASS_TILE_M = 40.0
"""Side of a grass tile, m."""
CONCRETE_TILE_M = 16.0
"""Approximate side of a concrete tile, m (a whole number of slabs of ``texture_scale_m``)."""
SEA_FLOOR_SPREAD = 1.8
"""The sea's darkest texel is at least ``mean * (1 - SEA_FLOOR_SPREAD * contrast)``."""
TEXTURES = ("waves", "asphalt", "grass", "concrete")
"""The ``Surface.texture`` names drawn."""

_SPREAD_PERCENTILES = (5.0, 95.0)


def surface_texture(
    rng: np.random.Generator, surface: Surface, size_px: int = TEXTURE_PX
) -> tuple[np.ndarray, float]:
    """One tile of ``surface`` as the cameras see it: ((S, S, 3) uint8 RGB, side of the tile, m).

    Args:
        rng: the scenery's generator (the draws depend only on it and ``surface``).
        surface: the world's sea, ground or floor.
        size_px: side of the tile, texels (>= 64).

    Raises:
        ValueError: an unknown ``surface.texture``, a bad size or scale.
    """
    if size_px < 64:
        raise ValueError(f"size_px must be >= 64, got {size_px}")
    if not (math.isfinite(surface.texture_scale_m) and surface.texture_scale_m > 0.0):
        raise ValueError(f"surface.texture_scale_m must be positive: {surface.texture_scale_m!r}")
    if not 0.0 <= surface.texture_contrast <= 1.0:
        raise ValueError(
            f"surface.texture_contrast must be in [0, 1]: {surface.texture_contrast!r}"
        )
    makers: dict[str, Callable[[np.random.Generator, Surface, int], tuple[np.ndarray, float]]] = {
        "waves": _sea,
        "asphalt": _asphalt,
        "grass": _grass,
        "concrete": _concrete,
    }
    maker = makers.get(surface.texture)
    if maker is None:
        raise ValueError(
            f"surface.texture must be one of {list(TEXTURES)}, got {surface.texture!r}"
        )
    return maker(rng, surface, size_px)


def contrast_of(texture_rgb: np.ndarray) -> float:
    """Brightness spread of a texture: (95th - 5th percentile) / (2 * mean) of its luminance."""
    lum = np.asarray(texture_rgb, dtype=float).mean(axis=-1)
    lo, hi = np.percentile(lum, _SPREAD_PERCENTILES)
    return float((hi - lo) / (2.0 * max(lum.mean(), 1e-9)))


# -- noise -------------------------------------------------------------------------------------


def _frequencies(size_px: int, tile_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Spatial frequencies (fx, fy) of an rfft2 of the tile, cycles per metre (broadcastable)."""
    d = tile_m / size_px
    return np.fft.rfftfreq(size_px, d)[None, :], np.fft.fftfreq(size_px, d)[:, None]


def _filtered(rng: np.random.Generator, size_px: int, gain: np.ndarray) -> np.ndarray:
    """White noise shaped by ``gain`` (an rfft2-sized spectrum), zero mean, unit variance."""
    spectrum = np.fft.rfft2(rng.standard_normal((size_px, size_px))) * gain
    spectrum[0, 0] = 0.0
    field = np.fft.irfft2(spectrum, s=(size_px, size_px))
    std = field.std()
    return field / std if std > 0.0 else field


def _band(size_px: int, tile_m: float, scale_m: float, width: float = 0.6) -> np.ndarray:
    """Isotropic gain around features of ``scale_m`` (log-normal in frequency, ``width`` in ln)."""
    fx, fy = _frequencies(size_px, tile_m)
    f = np.hypot(fx, fy)
    with np.errstate(divide="ignore"):
        return np.exp(-0.5 * (np.log(f * scale_m) / width) ** 2)


def _pink(size_px: int, beta: float) -> np.ndarray:
    """Gain of 1/f^beta noise (no DC)."""
    fx, fy = _frequencies(size_px, 1.0)
    f = np.hypot(fx, fy)
    f[0, 0] = np.inf
    return 1.0 / f**beta


def _smoothstep(x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """0 below ``lo``, 1 above ``hi``, a smooth cubic between."""
    t = np.clip((x - lo) / (hi - lo), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _spread(field: np.ndarray) -> np.ndarray:
    """``field`` shifted and scaled so its 5th and 95th percentiles are -1 and +1."""
    lo, hi = np.percentile(field, _SPREAD_PERCENTILES)
    if hi - lo <= 0.0:
        return np.zeros_like(field)
    return (2.0 * field - (hi + lo)) / (hi - lo)


def _finish(rgb: np.ndarray, surface: Surface) -> np.ndarray:
    """To uint8 with the surface's mean colour (channel by channel) and contrast (``contrast_of``).

    The deviations from the mean colour are scaled by one factor so the spread is the asked one
    (glints, seams and stains included), then each channel so its mean is the surface's.
    """
    target = 255.0 * np.clip(np.asarray(surface.rgba, dtype=float)[:3], 0.0, 1.0)
    for _ in range(2):  # the second pass corrects what clipping moved
        mean = np.maximum(rgb.reshape(-1, 3).mean(axis=0), 1e-6)
        rgb = rgb * (target / mean)
        spread = contrast_of(rgb)
        if spread > 0.0:
            rgb = target + (rgb - target) * (surface.texture_contrast / spread)
        rgb = np.clip(rgb, 0.0, 255.0)
    return np.rint(rgb).astype(np.uint8)


def _shade(brightness: np.ndarray, contrast: float, low: float = -np.inf) -> np.ndarray:
    """Relative brightness 1 + contrast * b for a spread ``b`` (see ``_spread``), b >= ``low``."""
    return 1.0 + contrast * np.maximum(brightness, low)


# -- the surfaces ------------------------------------------------------------------------------


def _sea(rng: np.random.Generator, surface: Surface, size_px: int) -> tuple[np.ndarray, float]:
    """Sea: a long swell under shorter wind waves with directional crests, a little sun glint.

    The brightness is the slope of the water towards the sun (the sky's reflection changes with
    it) plus a little of the height (crests thinner, lighter) and of short ripples (seen from low
    only: the camera's mipmap averages them out higher up); colour shifts greener on crests and
    over faint patches a few wave lengths wide. The tile holds ``SEA_TILE_WAVES`` wave lengths.
    """
    wave_m = surface.texture_scale_m
    tile_m = max(SEA_MIN_TILE_M, SEA_TILE_WAVES * wave_m)
    fx, fy = _frequencies(size_px, tile_m)
    f = np.hypot(fx, fy)
    theta = np.arctan2(fy, fx)
    wind = rng.uniform(0.0, 2.0 * math.pi)
    swell_dir = wind + rng.normal(0.0, 0.35)
    sun = wind + rng.uniform(-1.0, 1.0)

    def spectrum(length_m: float, direction: float, width: float, spread: float) -> np.ndarray:
        with np.errstate(divide="ignore"):
            radial = np.exp(-0.5 * (np.log(f * length_m) / width) ** 2)
        # cos^2s spreading about the direction and its opposite (a real field has both).
        directional = np.cos(theta - direction) ** (2 * spread)
        return radial * directional

    waves = _filtered(rng, size_px, spectrum(wave_m, wind, 0.3, 3))
    swell = _filtered(rng, size_px, spectrum(3.0 * wave_m, swell_dir, 0.15, 10))
    chop = _filtered(rng, size_px, spectrum(0.4 * wave_m, wind + 0.4, 0.4, 1))
    patches = _filtered(rng, size_px, _band(size_px, tile_m, 3.0 * wave_m, 0.5))
    height = waves + 1.2 * swell + 0.05 * chop
    # Slope towards the sun, exact on the periodic tile (spectral derivative).
    spec_h = np.fft.rfft2(height)
    slope = np.fft.irfft2(
        spec_h * 2j * np.pi * (math.cos(sun) * fx + math.sin(sun) * fy), s=(size_px, size_px)
    )
    slope /= slope.std()
    ripples = _filtered(rng, size_px, spectrum(0.12 * wave_m, wind, 0.5, 1))
    brightness = _spread(0.7 * slope + 0.5 * height / height.std() + 0.3 * patches + 0.3 * ripples)
    shade = _shade(brightness, surface.texture_contrast, low=-SEA_FLOOR_SPREAD)
    base = np.asarray(surface.rgba, dtype=float)[:3] * 255.0
    tint = 0.6 * np.clip(brightness, -1.5, 1.5) + patches
    greener = np.array([-0.03, 0.06, -0.02]) * tint[..., None]
    rgb = base * shade[..., None] * (1.0 + greener)
    # Glint: the steepest sun-facing facets of the short waves, a few texels in a thousand.
    facets = slope + 0.8 * _filtered(rng, size_px, spectrum(0.25 * wave_m, sun, 0.4, 1))
    glint = _smoothstep(facets, *np.percentile(facets, (99.85, 99.98)))
    rgb += glint[..., None] * (np.array([225.0, 238.0, 245.0]) - rgb) * 0.8
    return _finish(rgb, surface), tile_m


def _asphalt(rng: np.random.Generator, surface: Surface, size_px: int) -> tuple[np.ndarray, float]:
    """Asphalt: fine grain with light aggregate specks over darker worn and patched areas.

    No road markings: the tile repeats over the whole ground, not along the city's streets.
    """
    tile_m = ASPHALT_TILE_M
    scale_m = surface.texture_scale_m
    grain = _filtered(rng, size_px, _pink(size_px, 0.2))
    specks = rng.random((size_px, size_px))
    wear = _filtered(rng, size_px, _band(size_px, tile_m, scale_m, 0.7))
    repairs = _filtered(rng, size_px, _band(size_px, tile_m, 4.0 * scale_m, 0.4))
    stains = _filtered(rng, size_px, _band(size_px, tile_m, 0.6 * scale_m, 0.5))
    value = (
        0.9 * grain
        + 1.6 * (specks > 0.985)
        + 0.5 * wear
        - 0.7 * _smoothstep(repairs, 1.0, 1.3)
        - 0.9 * _smoothstep(stains, 1.6, 2.2)
    )
    shade = _shade(_spread(value), surface.texture_contrast, low=-2.5)
    warm = 1.0 + 0.012 * np.clip(wear, -2.0, 2.0)[..., None] * np.array([1.0, 0.3, -1.0])
    base = np.asarray(surface.rgba, dtype=float)[:3] * 255.0
    return _finish(base * shade[..., None] * warm, surface), tile_m


def _grass(rng: np.random.Generator, surface: Surface, size_px: int) -> tuple[np.ndarray, float]:
    """Grass: mottled greens (clumps, lighter dry patches, darker lush ones), a little bare soil."""
    tile_m = GRASS_TILE_M
    scale_m = surface.texture_scale_m
    patches = _filtered(rng, size_px, _band(size_px, tile_m, scale_m, 0.7))
    clumps = _filtered(rng, size_px, _band(size_px, tile_m, 0.1 * scale_m, 0.6))
    blades = _filtered(rng, size_px, _pink(size_px, 0.3))
    dryness = _filtered(rng, size_px, _band(size_px, tile_m, 2.5 * scale_m, 0.5))
    soil = _smoothstep(
        _filtered(rng, size_px, _band(size_px, tile_m, 0.4 * scale_m, 0.5)), 2.2, 2.8
    )
    shade = _shade(
        _spread(0.8 * patches + 0.35 * clumps + 0.3 * blades), surface.texture_contrast, low=-2.0
    )
    base = np.asarray(surface.rgba, dtype=float)[:3] * 255.0
    dry = _smoothstep(dryness + 0.3 * patches, -1.2, 1.8)[..., None]
    lush = base * np.array([0.85, 1.03, 0.85])
    yellow = base * np.array([1.18, 1.02, 0.85])
    rgb = ((1.0 - dry) * lush + dry * yellow) * shade[..., None]
    dirt = base.mean() * np.array([1.25, 1.0, 0.7])
    rgb += 0.8 * soil[..., None] * (dirt - rgb)
    return _finish(rgb, surface), tile_m


def _concrete(rng: np.random.Generator, surface: Surface, size_px: int) -> tuple[np.ndarray, float]:
    """Concrete: square slabs of ``texture_scale_m`` with dark seams, mottled, a few stains.

    Each slab is a little lighter or darker than the next; a fine speckle covers everything.
    """
    slab_m = surface.texture_scale_m
    slabs = max(1, round(CONCRETE_TILE_M / slab_m))
    tile_m = slabs * slab_m
    texels_per_m = size_px / tile_m
    idx = np.arange(size_px)
    slab_of = (idx * slabs) // size_px  # slab index of each texel row/column
    offset = rng.normal(0.0, 1.0, (slabs, slabs))[slab_of[:, None], slab_of[None, :]]
    mottle = _filtered(rng, size_px, _band(size_px, tile_m, 0.3 * slab_m, 0.9))
    speckle = _filtered(rng, size_px, _pink(size_px, 0.1))
    stains = _smoothstep(
        _filtered(rng, size_px, _band(size_px, tile_m, 0.5 * slab_m, 0.5)), 1.8, 2.6
    )
    value = _spread(0.8 * offset + 0.6 * mottle + 0.25 * speckle - 1.2 * stains)
    shade = _shade(value, surface.texture_contrast, low=-2.5)
    # Seams: about 4 cm (a sawn joint and its worn edges), at least one texel, dark.
    seam_px = max(1, round(0.04 * texels_per_m))
    start = (slab_of * size_px + slabs - 1) // slabs  # first texel of each texel's slab
    on_seam = (idx - start) < seam_px
    seam = on_seam[:, None] | on_seam[None, :]
    shade = np.where(seam, 0.55 * shade, shade)
    base = np.asarray(surface.rgba, dtype=float)[:3] * 255.0
    return _finish(base * shade[..., None], surface), tile_m
