"""Classic MAVSDK-Python client of the vehicle's camera (component 100): list, stream, photo.

    python classic_camera.py --url udpin://0.0.0.0:PORT --grpc-port GRPC

Reports the camera MAVSDK found (camera_list), its video stream (video_stream_info), the
vehicle's position, and the CaptureInfo of one take_photo.
"""

from __future__ import annotations

import asyncio

from _common import Report, classic_main, connect_healthy, first, wait_for, within

VIDEO_INFO_WAIT_S = 240.0
"""Simulated seconds for VIDEO_STREAM_INFORMATION: MAVSDK asks for it on its own wall-clock
schedule (seconds apart), so this covers several of its requests at SPEED 4."""


async def fly(args, r: Report) -> None:
    from mavsdk_grpc import System

    drone = System(port=args.grpc_port)
    try:
        await connect_healthy(drone, args.url, r, 120)
        r.stage("camera list")
        cameras = await wait_for(
            drone.camera.camera_list(), lambda c: len(c.cameras) > 0, 60, "a camera"
        )
        cam = cameras.cameras[0]
        r["camera"] = {
            "component_id": cam.component_id,
            "vendor": cam.vendor_name,
            "model": cam.model_name,
            "focal_length_mm": cam.focal_length_mm,
            "sensor_h_mm": cam.horizontal_sensor_size_mm,
            "sensor_v_mm": cam.vertical_sensor_size_mm,
            "resolution": [cam.horizontal_resolution_px, cam.vertical_resolution_px],
        }
        r.stage("video stream")
        update = await wait_for(
            drone.camera.video_stream_info(),
            lambda u: bool(u.video_stream_info.settings.uri),
            VIDEO_INFO_WAIT_S,
            "video stream info",
        )
        settings = update.video_stream_info.settings
        r["video"] = {
            "uri": settings.uri,
            "resolution": [settings.horizontal_resolution_pix, settings.vertical_resolution_pix],
            "fps": settings.frame_rate_hz,
            "hfov_deg": settings.horizontal_fov_deg,
        }
        r.stage("position")
        pos = await first(drone.telemetry.position())
        r["position"] = [pos.latitude_deg, pos.longitude_deg, pos.relative_altitude_m]
        r.stage("photo")
        captured = asyncio.ensure_future(first(drone.camera.capture_info()))
        await asyncio.sleep(1.0)  # let the subscription reach mavsdk_server first
        await drone.camera.take_photo(cam.component_id)
        info = await within(captured, 60, "capture info")
        r["capture"] = {
            "component_id": info.component_id,
            "is_success": info.is_success,
            "index": info.index,
            "file_url": info.file_url,
            "lat_deg": info.position.latitude_deg,
            "lon_deg": info.position.longitude_deg,
            "abs_alt_m": info.position.absolute_altitude_m,
            "rel_alt_m": info.position.relative_altitude_m,
            "pitch_deg": info.attitude_euler_angle.pitch_deg,
        }
        r.stage("done")
    finally:
        drone._stop_mavsdk_server()


def main() -> None:
    classic_main(fly)


if __name__ == "__main__":
    main()
