"""A PNG gallery of the worlds' ground as the cameras see it, for a person to look at.

    python benchmarks/scenery_gallery.py                   # into /tmp/swarmsitl_gallery
    python benchmarks/scenery_gallery.py --out docs/images --altitude 30

One straight-down 320x240 frame (the Typhoon H480's 2.0 rad field of view) per shipped example
world, ``--altitude`` metres above the centre of its first launch area (its helideck, land base,
safe point, start zone; the origin if it has none), and its texture tile (``<kind>_tile.png``);
for the offshore world also one frame ``--altitude`` metres above its first oil spill (shown as if
it had appeared). Prints each path.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

import worlds
from sitl.sensors.camera import CameraSpec, camera_pose_enu
from sitl.world import World, WorldConfig
from worlds.examples import KINDS, example_path

CAMERA = CameraSpec(width_px=320, height_px=240, hfov_deg=114.59, position_frd_m=(0.16, 0.0, 0.12))
"""The Typhoon H480's camera, pointing down."""


def down_frame(
    world: worlds.World, xy_m: tuple[float, float], height_m: float, spills: bool = False
) -> np.ndarray:
    """One frame (H, W, 3) RGB looking straight down from ``height_m`` above z = 0 at ``xy_m``.

    ``spills``: raise the world's oil spills first (as at a time after they all appeared).
    """
    with World(WorldConfig(cameras=True, camera=CAMERA, scene=world)) as sim:
        if spills and sim._spills is not None:
            sim._spills.update(float("inf"))
        rig = sim._cameras
        assert rig is not None
        centre, axes = camera_pose_enu(CAMERA, np.array([*xy_m, height_m]), np.eye(3))
        return rig.render_camera(0, centre, axes, force_tiny=True).copy()


def ground_tile(world: worlds.World) -> np.ndarray:
    """The world's ground texture tile, (S, S, 3) RGB."""
    with World(WorldConfig(cameras=True, camera=CAMERA, scene=world)) as sim:
        assert sim._cameras is not None
        return sim._cameras.ground_texture_rgb.copy()


def _save(path: Path, rgb: np.ndarray) -> None:
    cv2.imwrite(str(path), rgb[:, :, ::-1], [cv2.IMWRITE_PNG_COMPRESSION, 9])
    print(f"{path}: {rgb.shape[1]}x{rgb.shape[0]}, {path.stat().st_size / 1e3:.0f} kB")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--out", type=Path, default=Path("/tmp/swarmsitl_gallery"), help="folder for the PNGs"
    )
    parser.add_argument(
        "--altitude", type=float, default=30.0, help="height above the launch area, m (e.g. 30)"
    )
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for kind in KINDS:
        world = worlds.build(worlds.load_world(example_path(kind)))
        x, y, z = world.launch_areas[0].center_enu_m if world.launch_areas else (0.0, 0.0, 0.0)
        _save(args.out / f"{kind}.png", down_frame(world, (x, y), z + args.altitude))
        _save(args.out / f"{kind}_tile.png", ground_tile(world))
        for spill in world.targets_of(worlds.OilSpill)[:1]:
            cx, cy = spill.polygon.centroid.coords[0]
            frame = down_frame(world, (cx, cy), args.altitude, spills=True)
            _save(args.out / f"{kind}_spill.png", frame)


if __name__ == "__main__":
    main()
