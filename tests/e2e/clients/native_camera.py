"""MAVSDK 4.x native (ctypes) asyncio client of the vehicle's camera: list, stream, photo.

    python native_camera.py --url udpin://0.0.0.0:PORT

Reports what :mod:`classic_camera` reports, through the native API's camera plugin.
"""

from __future__ import annotations

import asyncio

from _common import Report, first, native_autopilot, native_main, wait_for, within

VIDEO_INFO_WAIT_S = 240.0
"""Simulated seconds for VIDEO_STREAM_INFORMATION: MAVSDK asks for it on its own wall-clock
schedule (seconds apart), so this covers several of its requests at SPEED 4."""


async def fly(args, r: Report) -> None:
    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
    from mavsdk.asyncio.plugins.camera import CameraAsync
    from mavsdk.asyncio.plugins.telemetry import TelemetryAsync

    config = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    async with Mavsdk(config) as sdk:
        r["mavsdk_version"] = await sdk.version()
        system = await native_autopilot(sdk, args.url, r, 120)
        camera = CameraAsync(system)
        r.stage("camera list")
        cameras = await wait_for(
            camera.subscribe_camera_list(), lambda c: len(c.cameras) > 0, 60, "a camera"
        )
        cam = cameras.cameras[0]
        r["camera"] = {
            "component_id": cam.component_id,
            "focal_length_mm": cam.focal_length_mm,
            "sensor_h_mm": cam.horizontal_sensor_size_mm,
            "resolution": [cam.horizontal_resolution_px, cam.vertical_resolution_px],
        }
        r.stage("video stream")
        update = await wait_for(
            camera.subscribe_video_stream_info(),
            lambda u: bool(u.video_stream_info.settings.uri),
            VIDEO_INFO_WAIT_S,
            "video stream info",
        )
        r["video"] = {"uri": update.video_stream_info.settings.uri}
        r.stage("position")
        pos = await first(TelemetryAsync(system).subscribe_position())
        r["position"] = [pos.latitude_deg, pos.longitude_deg, pos.relative_altitude_m]
        r.stage("photo")
        captured = asyncio.ensure_future(first(camera.subscribe_capture_info()))
        await asyncio.sleep(1.0)
        await camera.take_photo(cam.component_id)
        info = await within(captured, 60, "capture info")
        r["capture"] = {
            "component_id": info.component_id,
            "is_success": info.is_success,
            "index": info.index,
            "file_url": info.file_url,
            "lat_deg": info.position.latitude_deg,
            "lon_deg": info.position.longitude_deg,
            "rel_alt_m": info.position.relative_altitude_m,
            "pitch_deg": info.attitude_euler_angle.pitch_deg,
        }
        del camera
        r.stage("done")


def main() -> None:
    native_main(fly, 720)


if __name__ == "__main__":
    main()
