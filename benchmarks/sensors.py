"""Cost of the companion-facing sensors: ultrasonic rangefinders and RGB cameras.

Three measurements, one run:

1. rays per second: 10 Typhoons hovering 2 m over the ground between walls, each with its 7
   rangefinders (17 rays per cone); wall time of ``World.poll_rangefinders`` (one rayTestBatch
   per sensor tick, noise, DISTANCE_SENSOR messages) per ray cast.
2. camera ms per frame: one Typhoon hovering 10 m over the textured ground with a down-looking
   camera (the ground fills the image) at 320x240 and at 640x480, a box in view; wall time of
   ``World.poll_cameras`` per frame.
3. slowdown_10: the full stack (physics, autopilots, MAVLink links, no clients) flying the
   takeoff + hover + goto scenario of ``realtime_factor.py`` with 10 vehicles, with a 320x240
   camera at 5 Hz and 7 rangefinders each (plus each camera's MAVLink component and stream
   server), against the same run with neither; wall-time ratio of the two runs.

    python benchmarks/sensors.py
    python benchmarks/sensors.py --sim-seconds 10 --repeat 1    # quicker, noisier

The last line is ``RESULT rays_per_s=... camera_ms_320=... camera_ms_640=... slowdown_10=...``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from realtime_factor import fly_scenario, machine
from sitl.physics.obstacles import BoxObstacle
from sitl.sensors.camera import CameraSpec, with_mount
from sitl.sensors.rangefinder import RAYS_PER_SENSOR
from sitl.world import World, WorldConfig, hover_actuator_message

N_VEHICLES = 10
CAMERA_HZ = 5.0


def rays_per_second(sim_seconds: float) -> tuple[float, int]:
    """Rays cast per wall second by ``poll_rangefinders``, and the rays cast per sensor tick."""
    walls = (
        BoxObstacle((22.5, 3.0, 1.5), (60.0, 0.2, 3.0)),  # 3 m north of the row of vehicles
        BoxObstacle((22.5, -1.5, 1.5), (60.0, 0.2, 3.0)),  # 1.5 m south
    )
    config = WorldConfig(
        n_vehicles=N_VEHICLES, spawn_altitude_m=2.0, obstacles=walls, rangefinders=True
    )
    with World(config) as world:
        hover = [hover_actuator_message(spec) for spec in world.airframes]
        world.step(hover)
        spent = 0.0
        rays = 0
        ticks = 0
        clock = time.perf_counter
        for _ in range(round(sim_seconds * config.physics_hz)):
            world.step()
            world.poll_sensors()
            t0 = clock()
            msgs = world.poll_rangefinders()
            spent += clock() - t0
            if msgs is not None:
                ticks += 1
                rays += RAYS_PER_SENSOR * sum(len(m) for m in msgs)
            world.poll_battery()
        assert ticks > 0, "no rangefinder was due"
        return rays / spent, rays // ticks


def camera_ms_per_frame(width_px: int, height_px: int, frames: int) -> float:
    """Mean wall time of a ``poll_cameras`` call that renders a frame, ms."""
    spec = with_mount(
        CameraSpec(width_px=width_px, height_px=height_px, hfov_deg=114.59, rate_hz=10.0), "down"
    )
    box = BoxObstacle((3.0, 2.0, 0.5), (2.0, 1.0, 1.0), rgba=(0.85, 0.2, 0.15, 1.0))
    config = WorldConfig(cameras=True, camera=spec, spawn_altitude_m=10.0, obstacles=(box,))
    with World(config) as world:
        world.step([hover_actuator_message(world.airframes[0])])
        spent = 0.0
        taken = 0
        clock = time.perf_counter
        while taken < frames:
            world.step()
            t0 = clock()
            out = world.poll_cameras()
            elapsed = clock() - t0
            if out is not None:
                spent += elapsed
                taken += len(out)
                assert out[0].rgb.shape == (height_px, width_px, 3)
                assert float(np.std(out[0].rgb)) > 5.0, "blank frame"
    return 1e3 * spent / taken


def main() -> int:
    """Run the three measurements and print the RESULT line."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--sim-seconds", type=float, default=20.0, help="length of each flight, s")
    ap.add_argument("--frames", type=int, default=30, help="frames timed per resolution")
    ap.add_argument(
        "--repeat", type=int, default=2, help="flights per configuration (the best counts)"
    )
    ap.add_argument("--port-base", type=int, default=25540, help="UDP ports to use")
    args = ap.parse_args()
    print(f"machine: {machine()}")

    rays_s, rays_tick = rays_per_second(min(args.sim_seconds, 5.0))
    print(
        f"rangefinders: {N_VEHICLES} vehicles x 7 sensors x {RAYS_PER_SENSOR} rays = "
        f"{rays_tick} rays per tick -> {rays_s / 1e6:.2f} M rays/s "
        f"({1e3 * rays_tick / rays_s:.2f} ms per tick)"
    )
    ms = {}
    for w, h in ((320, 240), (640, 480)):
        ms[w] = camera_ms_per_frame(w, h, args.frames)
        print(f"camera {w}x{h}, down, ground filling the view: {ms[w]:.2f} ms per frame")

    sensors_on = WorldConfig(
        rangefinders=True,
        cameras=True,
        camera=with_mount(
            CameraSpec(width_px=320, height_px=240, hfov_deg=114.59, rate_hz=CAMERA_HZ), "down"
        ),
    )
    sensors_off = WorldConfig(rangefinders=False, cameras=False)
    walls = {}
    for name, world in (("none", sensors_off), ("sensors", sensors_on)):
        runs = [
            fly_scenario(N_VEHICLES, args.sim_seconds, args.port_base, world=world)
            for _ in range(args.repeat)
        ]
        walls[name] = min(wall for wall, _ in runs)
        _, summary = runs[0]
        print(
            f"full stack, {N_VEHICLES} vehicles, {name:7s}: {walls[name]:6.2f} s wall for "
            f"{args.sim_seconds:g} s sim -> rtf {args.sim_seconds / walls[name]:5.2f}  "
            f"flight: {summary}"
        )
    slowdown = walls["sensors"] / walls["none"]
    print(
        f"slowdown with a {CAMERA_HZ:g} Hz 320x240 camera and 7 rangefinders per vehicle: "
        f"{slowdown:.2f}x (target <= 2x)"
    )
    print(
        f"RESULT rays_per_s={rays_s:.0f} camera_ms_320={ms[320]:.2f} "
        f"camera_ms_640={ms[640]:.2f} slowdown_10={slowdown:.2f}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
