"""The flat textured ground and the sky of a camera image, computed per pixel ray (no rasteriser).

The ground is the plane z = 0 (ENU) painted with a texture that repeats every ``tile_m`` metres.
Drawn by TinyRenderer it covers every pixel of a down-looking camera and costs about 200 ns per
pixel; here each pixel's ray is intersected with the plane and the texture looked up with
``cv2.remap``, about 1 ms per 320x240 frame. ``CameraRig`` composites TinyRenderer's image of
everything else (vehicles, obstacles) over it with the depth buffer.

Conventions match what TinyRenderer drew for the former textured ground quad (whose uvs were
``(x, y) / tile_m``), so the ground looks the same (``tests/sitl/test_camera.py`` compares both):

- Pixel (column u, row v) shows the ray through K's pixel centre (u + 0.5, v + 0.5), as
  TinyRenderer's samples with ``camera_render.projection_matrix`` (which shifts its principal point
  by half a pixel: it samples at integer coordinates of its y-up screen), so ground and
  objects line up.
- It samples the texture without filtering at column ``floor(x / tile_m * S) mod S`` and row
  ``floor(-y / tile_m * S) mod S`` of the S x S image (its texture rows run south).
- Its lighting scales the ground's texels by a constant ``GROUND_SHADE`` (light fixed in the
  world, flat ground; measured on a TinyRenderer render of the quad: 98 % of the pixels equal
  ``floor(0.94 * texel)`` exactly) and truncates to uint8.

With ``filtered=True`` (the worlds' surfaces) the layer also keeps the tile box-filtered to half,
a quarter, ... of its side (a mipmap) and reads, for each frame, the level whose texels are
closest to the ground size of a pixel straight below the camera (height / focal length): seen
from high up, fine texture detail averages out instead of aliasing into speckle. The lookup is
the same single ``cv2.remap``, so a frame costs the same.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import cv2
import numpy as np

if TYPE_CHECKING:
    from sitl.sensors.camera import CameraSpec

GROUND_SHADE = 0.94
"""TinyRenderer's lighting factor on the flat ground (ambient + diffuse of its default light)."""

_NO_GROUND = -1.0  # a texture coordinate outside the texture: cv2.remap gives the sky colour


class GroundLayer:
    """One camera's view of the ground plane and the sky, with preallocated per-frame buffers.

    Args:
        spec: the camera.
        texture_rgb: one tile of ground, (S, S, 3) uint8 RGB, as ``ground_texture`` makes it.
        tile_m: side of the square of ground one tile covers, m.
        sky_rgb: colour of the pixels whose ray meets no ground within ``spec.far_m``.
        filtered: pick a box-filtered level of the tile by the camera's height (see above);
            False: always the tile itself, as TinyRenderer would draw it.
    """

    def __init__(
        self,
        spec: CameraSpec,
        texture_rgb: np.ndarray,
        tile_m: float,
        sky_rgb: tuple[int, int, int],
        filtered: bool = False,
    ) -> None:
        texture = np.asarray(texture_rgb)
        if texture.ndim != 3 or texture.shape[2] != 3 or texture.shape[0] != texture.shape[1]:
            raise ValueError(f"texture_rgb must be (S, S, 3), got shape {texture.shape}")
        if not (math.isfinite(tile_m) and tile_m > 0.0):
            raise ValueError(f"tile_m must be positive, got {tile_m!r}")
        self.spec = spec
        self._levels = [self._lit_level(texture.astype(np.float32), tile_m)]
        """(lit texture, its side in texels, texels per metre) per mipmap level, finest first."""
        level = texture.astype(np.float32)
        while filtered and level.shape[0] % 2 == 0 and level.shape[0] >= 32:
            # A 2 x 2 box average: within the tile, so every level tiles as the first does.
            half = level.shape[0] // 2
            level = cv2.resize(level, (half, half), interpolation=cv2.INTER_AREA)
            self._levels.append(self._lit_level(level, tile_m))
        self._texture, self._size, self._texels_per_m = self._levels[0]
        self._tile_m = tile_m
        self._sky = tuple(float(c) for c in sky_rgb)
        k = spec.intrinsics()
        h, w = spec.height_px, spec.width_px
        u = (np.arange(w, dtype=np.float64) + 0.5 - k.cx_px) / k.fx_px
        v = (np.arange(h, dtype=np.float64) + 0.5 - k.cy_px) / k.fy_px
        rays = np.empty((h, w, 3), dtype=np.float32)
        rays[..., 0] = u[None, :]
        rays[..., 1] = v[:, None]
        rays[..., 2] = 1.0
        self._rays = rays.reshape(h * w, 1, 3)
        """Pixel rays in the optical frame, z = 1 (so a ray's t is the depth along the axis)."""
        self._dirs = np.empty((h * w, 1, 3), dtype=np.float32)
        self.depth_m = np.empty((h, w), dtype=np.float32)
        """Depth of the ground along the optical axis per pixel, m; inf: no ground (last frame)."""
        self._depth = self.depth_m.reshape(-1)
        self._map_x = np.empty((h, w), dtype=np.float32)
        self._map_y = np.empty((h, w), dtype=np.float32)
        self._scratch = np.empty(h * w, dtype=np.float32)
        self._none = np.empty(h * w, dtype=bool)
        self._far = np.empty(h * w, dtype=bool)
        self._gl_depth = np.empty((h, w), dtype=np.float32)
        self._nearer = np.empty((h, w), dtype=bool)
        self.rgb = np.empty((h, w, 3), dtype=np.uint8)
        """The ground-and-sky image of the last frame, (H, W, 3) uint8 RGB (reused)."""
        self._pixel_rad = 1.0 / k.fx_px
        """Angle one pixel spans at the image centre, rad (its ground size over the height)."""

    @staticmethod
    def _lit_level(texture: np.ndarray, tile_m: float) -> tuple[np.ndarray, float, float]:
        """A texture lit once, with one wrapped row and column more.

        Nearest-neighbour lookups at coordinates in [S - 0.5, S) round to S and read the tile's
        first row/column.
        """
        lit = (texture * np.float32(GROUND_SHADE)).astype(np.uint8)
        size = texture.shape[0]
        return np.pad(lit, ((0, 1), (0, 1), (0, 0)), mode="wrap"), float(size), size / tile_m

    def _pick_level(self, height_m: float) -> None:
        """Use the mipmap level whose texel best matches a pixel's ground size below the camera."""
        if len(self._levels) == 1:
            return
        texels = max(height_m, 1e-3) * self._pixel_rad * self._levels[0][2]
        level = min(max(round(math.log2(max(texels, 1.0))), 0), len(self._levels) - 1)
        self._texture, self._size, self._texels_per_m = self._levels[level]

    def render(self, centre_enu_m: np.ndarray, optical_to_enu: np.ndarray) -> np.ndarray:
        """Ground and sky seen from a pose into ``rgb`` (returned), ground depth into ``depth_m``.

        Args:
            centre_enu_m: optical centre, ENU, m.
            optical_to_enu: rotation optical -> ENU (3, 3).
        """
        spec = self.spec
        height = float(centre_enu_m[2])
        self._pick_level(height)
        # cv2.transform, not np.matmul: a BLAS call on a (3, 3) matrix can wait for idle threads.
        cv2.transform(self._rays, optical_to_enu.astype(np.float32), dst=self._dirs)
        dx, dy, dz = (self._dirs[:, 0, k] for k in range(3))
        t = self._depth
        with np.errstate(divide="ignore", invalid="ignore"):
            np.divide(np.float32(-height), dz, out=t)
        # No ground: a ray parallel to or away from it, behind the camera, or beyond the clip
        # range (NaN compares False, so it lands here too). A camera below z = 0 sees none.
        none, far = self._none, self._far
        np.greater_equal(t, np.float32(spec.near_m), out=none)
        np.less_equal(t, np.float32(spec.far_m), out=far)
        np.logical_and(none, far, out=none)
        np.logical_not(none, out=none)
        if height <= 0.0:
            none[:] = True
        np.copyto(t, np.float32(np.inf), where=none)
        # Texture coordinates from the camera's position within its tile (float64 first: far
        # from the origin float32 would lose the texel).
        scale = self._texels_per_m
        x0 = (float(centre_enu_m[0]) % self._tile_m) * scale - 0.5
        y0 = -(float(centre_enu_m[1]) % self._tile_m) * scale - 0.5
        mx, my = self._map_x.reshape(-1), self._map_y.reshape(-1)
        with np.errstate(invalid="ignore"):
            np.multiply(dx, t, out=mx)
            mx *= np.float32(scale)
            mx += np.float32(x0)
            self._wrap(mx)
            np.multiply(dy, t, out=my)
            my *= np.float32(-scale)
            my += np.float32(y0)
            self._wrap(my)
        np.copyto(mx, np.float32(_NO_GROUND), where=none)
        cv2.remap(
            self._texture,
            self._map_x,
            self._map_y,
            cv2.INTER_NEAREST,
            dst=self.rgb,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=self._sky,
        )
        return self.rgb

    def _wrap(self, x: np.ndarray) -> None:
        """Wrap texture coordinates into [0, S] in place (np.mod is ten times slower)."""
        size = np.float32(self._size)
        q = self._scratch
        np.multiply(x, np.float32(1.0) / size, out=q)
        np.floor(q, out=q)
        q *= size
        x -= q

    def opengl_depth(self, near_m: float, far_m: float, none_value: float) -> np.ndarray:
        """The last frame's ground depth as OpenGL's depth buffer holds it, (H, W) float32.

        ``(1 / near - 1 / t) / (1 / near - 1 / far)`` for the ground's depth t along the axis,
        ``none_value`` where there is no ground (a reused buffer).
        """
        d = self._gl_depth
        with np.errstate(divide="ignore"):
            np.divide(np.float32(near_m), self.depth_m, out=d)
        np.subtract(np.float32(1.0), d, out=d)
        d *= np.float32(far_m / (far_m - near_m))
        np.minimum(d, np.float32(none_value), out=d)
        return d

    def nearer_than_ground(
        self, opengl_depth: np.ndarray, near_m: float, far_m: float, none_value: float
    ) -> np.ndarray:
        """Mask (H, W) uint8, 1 where a depth buffer's pixel is drawn and not behind the ground.

        A tie counts as nearer: float32 depth near 1 resolves about 7 cm at 250 m (50 mm near
        clip), so a decal a few mm above the ground (an oil spill) has the ground's depth there.

        Args:
            opengl_depth: TinyRenderer's depth buffer of the same camera pose.
            near_m: the camera's near clip, m.
            far_m: its far clip, m.
            none_value: the depth buffer's value where nothing was drawn (never nearer).
        """
        ground = self.opengl_depth(near_m, far_m, none_value)
        np.less_equal(opengl_depth, ground, out=self._nearer)
        self._nearer &= opengl_depth < np.float32(none_value)
        return self._nearer.view(np.uint8)
