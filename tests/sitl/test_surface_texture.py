"""The worlds' procedural ground textures: seeded, tileable, the surface's colour and contrast."""

from __future__ import annotations

import copy
import dataclasses

import numpy as np
import pytest

import worlds
from sitl.physics.bullet import GROUND_TILE_M
from sitl.physics.ground_texture import ground_texture
from sitl.physics.surface_texture import SEA_FLOOR_SPREAD, contrast_of, surface_texture
from sitl.sensors.camera import CameraSpec, camera_pose_enu
from sitl.sensors.camera_ground import GroundLayer
from sitl.world import World, WorldConfig
from worlds.examples import KINDS, example_path

SURFACES = {kind: worlds.build(worlds.load_world(example_path(kind))).surface for kind in KINDS}
"""The shipped example worlds' surfaces: sea (waves), asphalt, concrete (twice), grass (twice)."""
CAMERA = CameraSpec(width_px=320, height_px=240, hfov_deg=114.59, position_frd_m=(0.16, 0.0, 0.12))


@pytest.fixture(scope="module")
def tiles() -> dict[str, tuple[np.ndarray, float]]:
    return {kind: surface_texture(np.random.default_rng(7), s) for kind, s in SURFACES.items()}


def test_the_examples_cover_every_texture():
    assert {s.texture for s in SURFACES.values()} == {"waves", "asphalt", "grass", "concrete"}


@pytest.mark.parametrize("kind", KINDS)
def test_same_seed_same_tile_another_seed_another(kind, tiles):
    rgb, tile_m = tiles[kind]
    again, again_m = surface_texture(np.random.default_rng(7), SURFACES[kind])
    other, _ = surface_texture(np.random.default_rng(8), SURFACES[kind])
    assert np.array_equal(rgb, again) and tile_m == again_m
    assert np.mean(rgb != other) > 0.5


def _circular_blur(channel: np.ndarray, sigma_px: float) -> np.ndarray:
    """Gaussian blur that wraps around the tile (FFT): a seam at the edge stays a seam."""
    f = np.fft.fftfreq(channel.shape[0])
    gain = np.exp(-2.0 * (np.pi * sigma_px) ** 2 * (f[:, None] ** 2 + f[None, :] ** 2))
    return np.fft.ifft2(np.fft.fft2(channel) * gain).real


def _edge_step_rank(rgb: np.ndarray) -> float:
    """How the jump across the tile's wrap compares with the jumps inside: the fraction of the
    interior column/row boundaries (of the blurred luminance) with a smaller mean jump."""
    lum = _circular_blur(rgb.astype(float).mean(axis=-1), 2.0)
    ranks = []
    for field in (lum, lum.T):
        steps = np.abs(np.roll(field, -1, axis=1) - field).mean(axis=0)  # boundary j | j + 1
        ranks.append(np.mean(steps[:-1] < steps[-1]))
    return max(ranks)


@pytest.mark.parametrize("kind", KINDS)
def test_the_tile_wraps_without_a_seam(kind, tiles):
    rgb, _ = tiles[kind]
    assert rgb.shape[0] == rgb.shape[1] and rgb.dtype == np.uint8
    assert _edge_step_rank(rgb) < 0.995
    # The check can fail: a tile cut out of a larger field has a step at its edge.
    if kind == "offshore":
        cut = np.ascontiguousarray(rgb[40:, 40:][:400, :400])
        assert _edge_step_rank(cut) >= 0.995


@pytest.mark.parametrize("kind", KINDS)
def test_mean_colour_is_the_surface_rgba_and_the_contrast_as_asked(kind, tiles):
    rgb, _ = tiles[kind]
    surface = SURFACES[kind]
    mean = rgb.reshape(-1, 3).mean(axis=0)
    np.testing.assert_allclose(mean, 255.0 * np.array(surface.rgba[:3]), atol=1.5)
    assert contrast_of(rgb) == pytest.approx(surface.texture_contrast, abs=0.015)


@pytest.mark.parametrize("contrast", [0.0, 0.05, 0.4])
@pytest.mark.parametrize("texture", ["waves", "asphalt", "grass", "concrete"])
def test_the_contrast_follows_the_surface(texture, contrast):
    surface = worlds.Surface("ground", (0.3, 0.4, 0.5, 1.0), texture, 2.0, contrast)
    rgb, _ = surface_texture(np.random.default_rng(1), surface, size_px=128)
    assert contrast_of(rgb) == pytest.approx(contrast, abs=0.02)
    if contrast == 0.0:
        assert np.ptp(rgb.reshape(-1, 3), axis=0).max() <= 1


def test_the_sea_has_wave_crests_across_the_wind_and_no_dark_trough(tiles):
    rgb, tile_m = tiles["offshore"]
    surface = SURFACES["offshore"]
    lum = rgb.astype(float).mean(axis=-1)
    # Darkest texel: no lower than the documented floor (a little slack for the colour shifts).
    assert lum.min() >= lum.mean() * (1.0 - SEA_FLOOR_SPREAD * surface.texture_contrast) - 4.0
    assert rgb.max(axis=-1).min() * 0.94 > 1.5 * 28  # lit, its brightest channel: far from oil
    # Directional: the power spectrum near the wave length is concentrated in one direction.
    spectrum = np.abs(np.fft.fft2(lum - lum.mean())) ** 2
    f = np.fft.fftfreq(lum.shape[0], tile_m / lum.shape[0])
    fx, fy = np.meshgrid(f, f)
    ring = np.abs(np.hypot(fx, fy) * surface.texture_scale_m - 1.0) < 0.3
    angle = np.mod(np.arctan2(fy[ring], fx[ring]), np.pi)  # a real field: theta == theta + pi
    power, _ = np.histogram(angle, bins=8, range=(0.0, np.pi), weights=spectrum[ring])
    assert power.max() > 4.0 * np.median(power)


def test_concrete_slabs_divide_the_tile(tiles):
    rgb, tile_m = tiles["indoor"]
    slab_m = SURFACES["indoor"].texture_scale_m
    slabs = round(tile_m / slab_m)
    assert tile_m == pytest.approx(slabs * slab_m)
    lum = rgb.astype(float).mean(axis=-1)
    per_column = lum.mean(axis=0)
    first = (np.arange(slabs) * rgb.shape[0] + slabs - 1) // slabs  # each slab's first column
    others = np.setdiff1d(np.arange(rgb.shape[0]), first)
    assert per_column[first].max() < per_column[others].min()  # the seams: dark lines


def test_bad_surfaces_are_refused():
    sea = SURFACES["offshore"]
    with pytest.raises(ValueError, match=r"surface\.texture must"):
        surface_texture(np.random.default_rng(0), dataclasses.replace(sea, texture="lava"))
    with pytest.raises(ValueError, match="texture_scale_m"):
        surface_texture(np.random.default_rng(0), dataclasses.replace(sea, texture_scale_m=0.0))
    with pytest.raises(ValueError, match="texture_contrast"):
        surface_texture(np.random.default_rng(0), dataclasses.replace(sea, texture_contrast=2.0))


def test_a_world_with_a_scene_shows_its_surface_and_a_plain_one_the_old_ground(monkeypatch):
    """The texture comes from the scenery generator: same seed, same tile; a plain world keeps
    the tinted-free grass tile with its grid (``ground_texture``), 20 m a tile."""
    import sitl.world as world_module

    used: list[tuple[str, np.random.Generator]] = []

    def recording(name, make):
        def wrapper(rng, *args, **kwargs):
            used.append((name, copy.deepcopy(rng)))
            return make(rng, *args, **kwargs)

        return wrapper

    monkeypatch.setattr(world_module, "surface_texture", recording("surface", surface_texture))
    monkeypatch.setattr(world_module, "ground_texture", recording("ground", ground_texture))
    scene = worlds.build(worlds.load_world(example_path("city")))
    rigs = []
    for config in (
        WorldConfig(cameras=True, camera=CAMERA, scene=scene, seed=3),
        WorldConfig(cameras=True, camera=CAMERA, scene=scene, seed=3),
        WorldConfig(cameras=True, camera=CAMERA, scene=scene, seed=4),
        WorldConfig(cameras=True, camera=CAMERA, seed=3),
    ):
        with World(config) as world:
            rigs.append(world._cameras)
    assert [name for name, _ in used] == ["surface", "surface", "surface", "ground"]
    expected, tile_m = surface_texture(used[0][1], scene.surface)
    assert np.array_equal(rigs[0].ground_texture_rgb, expected) and rigs[0].tile_m == tile_m
    assert np.array_equal(rigs[1].ground_texture_rgb, expected)
    assert not np.array_equal(rigs[2].ground_texture_rgb, expected)
    assert np.array_equal(rigs[3].ground_texture_rgb, ground_texture(used[3][1]))
    assert rigs[3].tile_m == GROUND_TILE_M


def _frames(rgb: np.ndarray, tile_m: float, height_m: float) -> tuple[np.ndarray, np.ndarray]:
    """The same down view from ``height_m`` without and with the mipmap."""
    centre, axes = camera_pose_enu(CAMERA, np.array([3.3, -7.1, height_m]), np.eye(3))
    plain = GroundLayer(CAMERA, rgb, tile_m, (0, 0, 0)).render(centre, axes).copy()
    filtered = GroundLayer(CAMERA, rgb, tile_m, (0, 0, 0), filtered=True).render(centre, axes)
    return plain, filtered.copy()


def test_the_filtered_ground_averages_detail_seen_from_high_up_and_only_then(tiles):
    rgb, tile_m = tiles["city"]  # asphalt: grain at the texel scale
    plain, filtered = _frames(rgb, tile_m, 2.0)
    assert np.array_equal(plain, filtered)  # texels larger than pixels: the tile itself
    plain, filtered = _frames(rgb, tile_m, 100.0)

    def grain(img: np.ndarray) -> float:
        lum = img.astype(float).mean(axis=-1)
        return float(np.abs(np.diff(lum, axis=1)).mean())

    assert grain(filtered) < 0.5 * grain(plain)
    np.testing.assert_allclose(
        filtered.reshape(-1, 3).mean(axis=0), plain.reshape(-1, 3).mean(axis=0), atol=2.0
    )
