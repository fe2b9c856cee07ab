"""Sample camera frames (one per mount) and the render cost per frame.

    python benchmarks/camera_frames.py                      # timings only
    python benchmarks/camera_frames.py --save docs/images   # + camera_down.png, camera_forward.png

The down frame: the Typhoon H480's own camera (2.0 rad FOV, 320x240) 10 m above the textured
ground, with a few boxes. The forward frame: the same camera pointed forward 1.5 m above the
ground, facing a wall and a pillar. The timings render the down view from 10 m with the camera
at 320x240 and 640x480, best of --repeat renders, in ms per frame (one vehicle; N vehicles cost
N times that at each frame): with nothing but ground in view (the ground is drawn per pixel ray
and TinyRenderer is skipped), and with the down scene's two boxes in view (TinyRenderer draws
them, composited over the ground by depth).
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import cv2
import numpy as np

from sitl.physics.obstacles import BoxObstacle
from sitl.sensors.camera import CameraSpec, with_mount
from sitl.vehicles.multirotor import load_airframe
from sitl.world import World, WorldConfig

SCENE_DOWN = (
    BoxObstacle((3.0, 4.0, 0.5), (2.0, 1.0, 1.0), yaw_deg=30.0, rgba=(0.85, 0.2, 0.15, 1.0)),
    BoxObstacle((-4.0, -2.0, 1.0), (1.0, 1.0, 2.0), rgba=(0.2, 0.35, 0.85, 1.0)),
)
SCENE_FORWARD = (
    BoxObstacle((0.0, 6.1, 1.5), (8.0, 0.2, 3.0), rgba=(0.75, 0.72, 0.65, 1.0)),  # wall
    BoxObstacle((1.2, 3.5, 1.5), (0.4, 0.4, 3.0), rgba=(0.85, 0.2, 0.15, 1.0)),  # pillar
)


def first_frame(camera: CameraSpec, height_m: float, obstacles: tuple) -> np.ndarray:
    """The first frame of one vehicle's camera, spawned at ``height_m``."""
    config = WorldConfig(
        cameras=True, camera=camera, spawn_altitude_m=height_m, obstacles=obstacles
    )
    with World(config) as world:
        while True:
            world.step()
            frames = world.poll_cameras()
            if frames is not None:
                return frames[0].rgb


def ms_per_frame(camera: CameraSpec, repeat: int, obstacles: tuple = ()) -> float:
    """Best wall time of one render of the down view from 10 m, ms."""
    config = WorldConfig(cameras=True, camera=camera, spawn_altitude_m=10.0, obstacles=obstacles)
    with World(config) as world:
        rig = world._cameras
        assert rig is not None
        scene = world._scene
        best = float("inf")
        for _ in range(repeat):
            t0 = time.perf_counter()
            rig.render_due(0, 0.0, scene.position_enu_m, scene.rotation, scene.quaternion_xyzw)
            best = min(best, time.perf_counter() - t0)
    return best * 1e3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--save", type=Path, help="folder for camera_down.png, camera_forward.png")
    parser.add_argument("--repeat", type=int, default=20, help="renders per timing")
    args = parser.parse_args()
    typhoon = load_airframe("typhoon_h480").camera
    assert typhoon is not None
    if args.save is not None:
        args.save.mkdir(parents=True, exist_ok=True)
        for name, camera, height, scene in (
            ("camera_down.png", with_mount(typhoon, "down"), 10.0, SCENE_DOWN),
            ("camera_forward.png", with_mount(typhoon, "forward"), 1.5, SCENE_FORWARD),
        ):
            path = args.save / name
            rgb = first_frame(camera, height, scene)
            # 6 bits per channel: the grass noise compresses badly; this keeps a PNG < 100 kB.
            small = (rgb >> 2) << 2
            cv2.imwrite(str(path), small[:, :, ::-1], [cv2.IMWRITE_PNG_COMPRESSION, 9])
            print(f"{path}: {rgb.shape[1]}x{rgb.shape[0]}, {path.stat().st_size / 1e3:.0f} kB")
    results = {}
    for width, height in ((320, 240), (640, 480)):
        camera = dataclasses.replace(with_mount(typhoon, "down"), width_px=width, height_px=height)
        ground = ms_per_frame(camera, args.repeat)
        results[width] = ms_per_frame(camera, args.repeat, SCENE_DOWN)
        print(
            f"{width}x{height}: {ground:.1f} ms per frame of ground only, "
            f"{results[width]:.1f} ms with boxes in view (one vehicle)"
        )
    print(f"RESULT camera_ms_320={results[320]:.2f} camera_ms_640={results[640]:.2f}")


if __name__ == "__main__":
    main()
