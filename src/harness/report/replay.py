"""Replay a finished run in 3-D from its ground truth: a PyBullet window, or a video file.

A run directory (DESIGN.md) holds ``truth.csv`` (every vehicle's pose at ``record_hz``), and
``manifest.json`` (``harness.run.manifest``: airframes, world file). The replay rebuilds the scene
with the simulation's own code (``worlds.load_world`` + ``worlds.build``, the solids through
``sitl.physics.obstacles.add_solids`` and ``MovingSolids``, each vehicle's URDF from its airframe
spec), then poses the bodies at each instant; nothing is simulated again.

Two outputs:

* the PyBullet GUI, played at ``speed`` x real time, when a display exists;
* a video (MP4 through OpenCV, or GIF through Pillow) rendered headless with PyBullet's
  TinyRenderer at a fixed rate of simulated time: ``fps`` frames per video second, each
  ``speed / fps`` simulated seconds apart, seen from an overview camera that frames every
  trajectory or from a camera that follows one vehicle. Trails and vehicle markers are drawn
  over the rendered image (projected with the same camera matrices; TinyRenderer draws no debug
  lines).

Bad input gets a :class:`ReplayError` with the reason, or a documented fallback that
:attr:`ReplayRun.notes` reports: no manifest (airframes assumed ``typhoon_h480``, no world), a
world file that is gone (plain ground), an airframe that no longer loads (a sphere marker), a
truncated truth.csv (its complete samples only).
"""

from __future__ import annotations

import contextlib
import csv
import io
import math
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

import worlds
from harness.run.manifest import MANIFEST_FILE, ManifestError, RunManifest, read_manifest
from sitl.physics.bullet_import import pybullet as p
from sitl.physics.moving_solids import MovingSolids
from sitl.physics.obstacles import add_solids
from sitl.vehicles.multirotor import load_airframe

TRUTH_FILE = "truth.csv"
"""Name of the ground-truth recording in a run directory."""
DEFAULT_AIRFRAME = "typhoon_h480"
"""Airframe assumed for every vehicle of a run without a manifest (SimulationConfig's default)."""
VIDEO_FPS = 20.0
"""Default frame rate of replay videos, frames per video second."""
VIDEO_SIZE_PX = (640, 360)
"""Default (width, height) of replay videos, px."""
CAMERA_FOV_DEG = 50.0
"""Vertical field of view of the replay cameras, degrees."""
OVERVIEW_YAW_DEG = 30.0
"""Heading of the replay cameras' view, PyBullet's camera yaw about ENU z, degrees (0 looks
north, 30 looks 30 degrees west of north)."""
OVERVIEW_PITCH_DEG = -40.0
"""Elevation of the overview camera's view, degrees (negative: looking down)."""
FOLLOW_DISTANCE_M = 8.0
"""Distance of the follow camera from its vehicle, m."""
FOLLOW_PITCH_DEG = -25.0
"""Elevation of the follow camera's view, degrees."""
VEHICLE_COLOURS_BGR = (
    (180, 119, 31),
    (14, 127, 255),
    (44, 160, 44),
    (40, 39, 214),
    (189, 103, 148),
    (75, 86, 140),
    (194, 119, 227),
    (127, 127, 127),
    (34, 189, 188),
    (207, 190, 23),
)
"""Trail and marker colour of vehicle i (i modulo 10), OpenCV BGR (matplotlib's tab10)."""
PLAIN_GROUND_RGBA = (0.45, 0.5, 0.42, 1.0)
"""Colour of the ground without a world."""
_QUAT_COLUMNS = ("quat_x", "quat_y", "quat_z", "quat_w")
_POSITION_COLUMNS = ("east_m", "north_m", "up_m")


class ReplayError(Exception):
    """A run directory that cannot be replayed; the message says why."""


@dataclass(frozen=True)
class TruthTrack:
    """Every vehicle's pose at each complete sample of truth.csv."""

    time_s: np.ndarray
    """Sample times, s, (T,), increasing."""
    position_enu_m: np.ndarray
    """Centre-of-mass positions, world ENU, m, (T, N, 3)."""
    quaternion_xyzw: np.ndarray | None
    """Attitudes body FLU -> world ENU, (x, y, z, w), (T, N, 4); None: the recording has none
    (older truth.csv), the vehicles are shown upright facing north."""
    dropped_rows: int = 0
    """Rows left out: a cut-off last line, unparsable rows, samples missing a vehicle."""

    @property
    def n_vehicles(self) -> int:
        """Number of vehicles."""
        return self.position_enu_m.shape[1]

    def index_at(self, t_s: float) -> int:
        """Index of the last sample at or before ``t_s`` (0 before the first)."""
        k = int(np.searchsorted(self.time_s, t_s, side="right")) - 1
        return min(max(k, 0), len(self.time_s) - 1)

    def at(self, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Positions (N, 3) and attitudes (N, 4), linearly interpolated at ``t_s`` (clamped)."""
        t = self.time_s
        k = self.index_at(t_s)
        k1 = min(k + 1, len(t) - 1)
        frac = float(np.clip((t_s - t[k]) / (t[k1] - t[k]), 0.0, 1.0)) if k1 > k else 0.0
        pos = self.position_enu_m[k] + frac * (self.position_enu_m[k1] - self.position_enu_m[k])
        if self.quaternion_xyzw is None:
            quat = np.tile([0.0, 0.0, math.sqrt(0.5), math.sqrt(0.5)], (self.n_vehicles, 1))
            return pos, quat
        q0, q1 = self.quaternion_xyzw[k], self.quaternion_xyzw[k1]
        sign = np.where(np.sum(q0 * q1, axis=1, keepdims=True) < 0.0, -1.0, 1.0)
        quat = q0 + frac * (sign * q1 - q0)
        quat /= np.linalg.norm(quat, axis=1, keepdims=True)
        return pos, quat


def load_truth(path: Path, n_vehicles: int | None = None) -> TruthTrack:
    """Read truth.csv into a :class:`TruthTrack`, keeping its complete samples.

    A run stopped while the file was written leaves a cut-off last line (dropped) and possibly a
    last sample with only some vehicles (dropped too). Columns are found by name, so recordings
    with more columns read alike.

    Args:
        path: The truth.csv file.
        n_vehicles: Vehicle count of the run (its manifest's); None: the largest index seen + 1.

    Raises:
        ReplayError: no file, no header with the position columns, or no complete sample.
    """
    try:
        text = path.read_text()
    except FileNotFoundError as exc:
        raise ReplayError(
            f"{path}: no ground truth recorded (the run had record_hz 0, or it was killed "
            "before it wrote truth.csv)"
        ) from exc
    except (OSError, UnicodeDecodeError) as exc:
        raise ReplayError(f"{path}: cannot read it: {exc}") from exc
    lines = text.splitlines(keepends=True)
    dropped = 0
    if lines and not lines[-1].endswith("\n") and len(lines) > 1:
        lines.pop()  # cut off mid-row
        dropped += 1
    reader = csv.reader(io.StringIO("".join(lines)))
    header = next(reader, None)
    needed = ("time_s", "vehicle", *_POSITION_COLUMNS)
    if header is None or not all(c in header for c in needed):
        raise ReplayError(f"{path}: not a truth.csv (a header with {', '.join(needed)} expected)")
    has_quat = all(c in header for c in _QUAT_COLUMNS)
    wanted = needed + (_QUAT_COLUMNS if has_quat else ())
    cols = [header.index(c) for c in wanted]
    values = []
    for row in reader:
        if len(row) != len(header):
            dropped += 1
            continue
        try:
            values.append([float(row[c]) for c in cols])
        except ValueError:
            dropped += 1
    table = np.array(values, dtype=float).reshape(-1, len(wanted))
    table = table[np.isfinite(table).all(axis=1)]
    vehicle = table[:, 1].astype(int)
    n = n_vehicles if n_vehicles is not None else (int(vehicle.max()) + 1 if len(table) else 0)
    inside = (vehicle >= 0) & (vehicle < n)
    dropped += int(np.count_nonzero(~inside)) + (len(values) - len(table))
    table, vehicle = table[inside], vehicle[inside]
    if n == 0 or len(table) == 0:
        raise ReplayError(f"{path}: no samples recorded (the run stopped before the first one)")
    times, sample = np.unique(table[:, 0], return_inverse=True)
    width = len(wanted) - 2
    data = np.full((len(times), n, width), np.nan)
    data[sample, vehicle] = table[:, 2:]
    complete = np.isfinite(data).all(axis=(1, 2))
    dropped += int(np.count_nonzero(~complete[sample]))
    if not complete.any():
        raise ReplayError(f"{path}: no sample holds all {n} vehicles")
    data = data[complete]
    return TruthTrack(
        time_s=times[complete],
        position_enu_m=np.ascontiguousarray(data[:, :, :3]),
        quaternion_xyzw=np.ascontiguousarray(data[:, :, 3:7]) if has_quat else None,
        dropped_rows=dropped,
    )


@dataclass
class ReplayRun:
    """What a replay shows: the truth, the airframes, the world, and the fallbacks taken."""

    run_dir: Path
    track: TruthTrack
    airframes: tuple[str, ...]
    """Airframe of each vehicle."""
    world: worlds.World | None
    """The run's world, None: plain ground."""
    manifest: RunManifest | None
    notes: list[str] = field(default_factory=list)
    """Fallbacks taken and data left out, one sentence each, for the user."""


def load_run(run_dir: Path) -> ReplayRun:
    """Read a run directory: manifest (if any), truth.csv, and the world file (if any).

    Raises:
        ReplayError: not a directory, no usable truth.csv, a corrupt or newer manifest, a world
            file that fails its schema.
    """
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise ReplayError(f"{run_dir}: no such run directory")
    notes: list[str] = []
    manifest: RunManifest | None
    try:
        manifest = read_manifest(run_dir)
    except ManifestError as exc:
        if (run_dir / MANIFEST_FILE).exists():
            raise ReplayError(str(exc)) from exc
        manifest = None
        notes.append(
            f"no manifest.json in {run_dir}: every vehicle shown as {DEFAULT_AIRFRAME}, "
            "on plain ground"
        )
    track = load_truth(run_dir / TRUTH_FILE, manifest.n_vehicles if manifest else None)
    if track.dropped_rows:
        notes.append(
            f"{TRUTH_FILE}: {track.dropped_rows} row(s) left out (cut off or incomplete; "
            "a run stopped while writing?)"
        )
    airframes = manifest.airframes if manifest else (DEFAULT_AIRFRAME,) * track.n_vehicles
    world = None
    if manifest is not None and manifest.world is not None:
        path = run_dir / manifest.world
        if not path.is_file():
            notes.append(f"{path}: world file missing, shown on plain ground")
        else:
            try:
                world = worlds.build(worlds.load_world(path))
            except (worlds.WorldSpecError, ValueError) as exc:
                raise ReplayError(f"{exc}") from exc
    return ReplayRun(run_dir, track, tuple(airframes), world, manifest, notes)


@dataclass(frozen=True)
class Camera:
    """A pinhole camera as PyBullet's view and projection matrices (OpenGL, column-major)."""

    view: tuple[float, ...]
    projection: tuple[float, ...]
    size_px: tuple[int, int]
    """(width, height) of the image, px."""
    distance_m: float
    """Distance from the camera to what it looks at, m (sets the ground grid's spacing)."""

    def project(self, points_enu_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates (K, 2) of world points (K, 3), and which lie in front of the camera."""
        pts = np.asarray(points_enu_m, dtype=float).reshape(-1, 3)
        view = np.array(self.view).reshape(4, 4).T
        proj = np.array(self.projection).reshape(4, 4).T
        homo = np.column_stack([pts, np.ones(len(pts))])
        clip = homo @ (proj @ view).T
        w = clip[:, 3]
        front = w > 1e-6
        safe = np.where(front, w, 1.0)
        width, height = self.size_px
        x = (clip[:, 0] / safe + 1.0) * 0.5 * width
        y = (1.0 - clip[:, 1] / safe) * 0.5 * height
        return np.column_stack([x, y]), front


def _camera(
    target: np.ndarray, distance_m: float, yaw_deg: float, pitch_deg: float, size: tuple[int, int]
) -> Camera:
    view = p.computeViewMatrixFromYawPitchRoll(
        [float(v) for v in target], float(distance_m), yaw_deg, pitch_deg, 0.0, 2
    )
    near = max(0.05, distance_m / 1000.0)
    far = max(100.0, distance_m * 20.0)
    proj = p.computeProjectionMatrixFOV(CAMERA_FOV_DEG, size[0] / size[1], near, far)
    return Camera(tuple(view), tuple(proj), size, float(distance_m))


def overview_camera(track: TruthTrack, size_px: tuple[int, int]) -> Camera:
    """A fixed camera that frames every trajectory of ``track`` (a sphere around their box)."""
    pts = track.position_enu_m.reshape(-1, 3)
    low, high = pts.min(axis=0), pts.max(axis=0)
    low[2] = min(low[2], 0.0)
    centre = (low + high) / 2.0
    radius = max(float(np.linalg.norm(high - low)) / 2.0, 2.0) * 1.15
    vfov = math.radians(CAMERA_FOV_DEG)
    hfov = 2.0 * math.atan(math.tan(vfov / 2.0) * size_px[0] / size_px[1])
    distance = radius / math.sin(min(vfov, hfov) / 2.0)
    return _camera(centre, distance, OVERVIEW_YAW_DEG, OVERVIEW_PITCH_DEG, size_px)


def follow_camera(position_enu_m: np.ndarray, size_px: tuple[int, int]) -> Camera:
    """A camera FOLLOW_DISTANCE_M from a vehicle at ``position_enu_m``, looking at it."""
    return _camera(position_enu_m, FOLLOW_DISTANCE_M, OVERVIEW_YAW_DEG, FOLLOW_PITCH_DEG, size_px)


def _nice_step(span_m: float) -> float:
    """A 1-2-5 x 10^k step giving about ten grid lines over ``span_m``."""
    raw = max(span_m, 1.0) / 10.0
    exp = 10.0 ** math.floor(math.log10(raw))
    return next(m * exp for m in (1.0, 2.0, 5.0, 10.0) if m * exp >= raw)


class ReplayScene:
    """A PyBullet client holding the run's ground, world solids and vehicle bodies.

    The bodies are posed, never simulated (no stepping, no gravity).
    """

    def __init__(self, run: ReplayRun, gui: bool = False) -> None:
        self._cid = p.connect(p.GUI if gui else p.DIRECT)
        if self._cid < 0:
            raise ReplayError("PyBullet could not open " + ("a window" if gui else "a client"))
        self.notes: list[str] = []
        """Fallbacks taken while building (airframes that did not load)."""
        try:
            self._build(run)
        except BaseException:
            self.close()
            raise

    def _build(self, run: ReplayRun) -> None:
        cid = self._cid
        gui = p.getConnectionInfo(cid).get("connectionMethod") == p.GUI
        if gui:
            p.configureDebugVisualizer(p.COV_ENABLE_GUI, 0, physicsClientId=cid)
        world = run.world
        self.ground_rgba: tuple[float, ...] = (
            PLAIN_GROUND_RGBA if world is None else tuple(world.surface.rgba)
        )
        """Colour of the ground (the world's surface colour)."""
        pts = run.track.position_enu_m.reshape(-1, 3)
        span = float(max(pts[:, :2].max(axis=0) - pts[:, :2].min(axis=0)))
        if gui:
            # The window draws a ground body; videos paint the ground per pixel (GroundPainter):
            # a ground-sized triangle costs TinyRenderer ~15x the rest of the scene.
            low, high = pts[:, :2].min(axis=0), pts[:, :2].max(axis=0)
            pad = max(50.0, span)
            if world is not None:
                b = world.bounds_xy_m
                low, high = np.minimum(low, b[:2]), np.maximum(high, b[2:])
            low, high = low - pad, high + pad
            half = [*((high - low) / 2.0).tolist(), 0.05]
            visual = p.createVisualShape(
                p.GEOM_BOX, halfExtents=half, rgbaColor=list(self.ground_rgba), physicsClientId=cid
            )
            centre = [*((low + high) / 2.0).tolist(), -0.05]
            p.createMultiBody(0.0, -1, visual, basePosition=centre, physicsClientId=cid)
        self._movers: MovingSolids | None = None
        if world is not None:
            ids = add_solids(cid, world.solids)
            movers = MovingSolids(cid, world.solids, ids)
            self._movers = movers if len(movers) else None
        self.body_ids = [self._vehicle_body(name) for name in run.airframes]

    def _vehicle_body(self, airframe: str) -> int:
        """The airframe's URDF body; a 0.5 m sphere if the airframe no longer loads."""
        try:
            urdf = load_airframe(airframe).urdf_path
            return p.loadURDF(str(urdf), useFixedBase=False, physicsClientId=self._cid)
        except (OSError, ValueError, KeyError, p.error) as exc:
            self.notes.append(f"airframe {airframe!r} did not load ({exc}); shown as a sphere")
            visual = p.createVisualShape(
                p.GEOM_SPHERE, radius=0.25, rgbaColor=[0.9, 0.2, 0.2, 1], physicsClientId=self._cid
            )
            return p.createMultiBody(0.0, -1, visual, physicsClientId=self._cid)

    @property
    def client_id(self) -> int:
        """PyBullet client id."""
        return self._cid

    def pose(self, t_s: float, position_enu_m: np.ndarray, quaternion_xyzw: np.ndarray) -> None:
        """Place the vehicles (N, 3), (N, 4) and the world's moving solids as at ``t_s``."""
        for body, pos, quat in zip(
            self.body_ids, position_enu_m.tolist(), quaternion_xyzw.tolist(), strict=True
        ):
            p.resetBasePositionAndOrientation(body, pos, quat, physicsClientId=self._cid)
        if self._movers is not None:
            self._movers.update(t_s)

    def render(self, camera: Camera, background: np.ndarray) -> np.ndarray:
        """The scene through ``camera`` with TinyRenderer over ``background`` (H, W, 3) BGR.

        Pixels where TinyRenderer drew nothing show ``background`` (the painted ground and sky).
        """
        width, height = camera.size_px
        _, _, rgba, _, seg = p.getCameraImage(
            width,
            height,
            viewMatrix=list(camera.view),
            projectionMatrix=list(camera.projection),
            renderer=p.ER_TINY_RENDERER,
            shadow=0,
            lightDirection=[0.4, -0.3, 1.0],
            physicsClientId=self._cid,
        )
        img = cv2.cvtColor(
            np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4), cv2.COLOR_RGBA2BGR
        )
        empty = np.asarray(seg).reshape(height, width) < 0
        img[empty] = background[empty]
        return img

    def close(self) -> None:
        """Disconnect the PyBullet client (once)."""
        if self._cid >= 0:
            with contextlib.suppress(p.error):  # the user closed the window
                p.disconnect(physicsClientId=self._cid)
            self._cid = -1


SKY_BGR = (235, 215, 190)
"""Colour above the horizon, OpenCV BGR."""


def paint_ground(
    camera: Camera, rgba: Sequence[float], spills: Sequence[worlds.OilSpill] = ()
) -> np.ndarray:
    """The ground plane z = 0 in ``rgba`` with grid lines, and the sky, as ``camera`` sees them.

    The grid lines are a 1-2-5 x 10^k m apart, about ten over the camera's distance, so that
    motion reads against them at any scale. ``spills`` are painted on the plane in their colour.

    Each pixel's ray is intersected with the plane (numpy, the whole image at once): what the
    cameras of ``sitl`` do for their ground, far cheaper than rasterising a ground body.
    Returns (H, W, 3) BGR uint8.
    """
    width, height = camera.size_px
    view = np.array(camera.view).reshape(4, 4).T
    proj = np.array(camera.projection).reshape(4, 4).T
    inv = np.linalg.inv(proj @ view)
    xs = (np.arange(width) + 0.5) / width * 2.0 - 1.0
    ys = 1.0 - (np.arange(height) + 0.5) / height * 2.0
    gx, gy = np.meshgrid(xs, ys)
    ones = np.ones_like(gx)
    near = np.stack([gx, gy, -ones, ones], axis=-1) @ inv.T
    far = np.stack([gx, gy, ones, ones], axis=-1) @ inv.T
    near = near[..., :3] / near[..., 3:]
    far = far[..., :3] / far[..., 3:]
    direction = far - near
    with np.errstate(divide="ignore", invalid="ignore"):
        s = -near[..., 2] / direction[..., 2]
    hit = np.isfinite(s) & (s > 0.0)
    s = np.where(hit, s, 0.0)
    point = near + s[..., None] * direction
    distance = np.linalg.norm(point - near, axis=-1)
    # Ground length one pixel spans at each hit, m: far lines thin out to a faint tint.
    pixel_m = distance * math.radians(CAMERA_FOV_DEG) / height + 1e-9
    grid_step_m = _nice_step(camera.distance_m)
    half_width = grid_step_m / 80.0
    line = np.zeros((height, width))
    for axis in (0, 1):
        offset = np.abs(point[..., axis] - grid_step_m * np.round(point[..., axis] / grid_step_m))
        coverage = np.clip((half_width + pixel_m / 2.0 - offset) / pixel_m, 0.0, 1.0)
        line = np.maximum(line, coverage * np.clip(2.0 * half_width / pixel_m, 0.35, 1.0))
    base = np.array([rgba[2], rgba[1], rgba[0]]) * 255.0
    shade = 0.75 if float(np.mean(rgba[:3])) > 0.5 else 1.45
    lines = np.clip(base * shade + (0 if shade < 1 else 25), 0, 255)
    ground = base + line[..., None] * (lines - base)
    from matplotlib.path import Path as MplPath  # here: importing matplotlib slows every start

    for spill in spills:
        outline = np.asarray(spill.outline_xy_m, dtype=float)
        low, high = outline.min(axis=0), outline.max(axis=0)
        xy = point[..., :2]
        near_box = hit & np.all((xy >= low) & (xy <= high), axis=-1)
        inside = np.zeros_like(hit)
        inside[near_box] = MplPath(outline).contains_points(xy[near_box])
        ground[inside] = np.array([spill.rgba[2], spill.rgba[1], spill.rgba[0]]) * 255.0
    out = np.where(hit[..., None], ground, np.array(SKY_BGR, dtype=float))
    return out.astype(np.uint8)


def draw_overlay(
    frame: np.ndarray, camera: Camera, track: TruthTrack, t_s: float, positions: np.ndarray
) -> None:
    """Draw each vehicle's trail up to ``t_s``, a numbered marker, and the time onto ``frame``."""
    k = track.index_at(t_s) + 1
    for i in range(track.n_vehicles):
        colour = VEHICLE_COLOURS_BGR[i % len(VEHICLE_COLOURS_BGR)]
        trail = np.vstack([track.position_enu_m[:k, i], positions[i : i + 1]])
        px, front = camera.project(trail)
        if front.all() and len(px) > 1:
            cv2.polylines(frame, [np.round(px).astype(np.int32)], False, colour, 2, cv2.LINE_AA)
        if front[-1]:
            x, y = (round(float(v)) for v in px[-1])
            cv2.circle(frame, (x, y), 5, colour, 2, cv2.LINE_AA)
            cv2.putText(
                frame, str(i + 1), (x + 7, y - 7), cv2.FONT_HERSHEY_SIMPLEX, 0.5, colour, 1,
                cv2.LINE_AA,
            )  # fmt: skip
    label = f"t = {t_s:7.2f} s"
    for colour, thickness in (((20, 20, 20), 4), ((245, 245, 245), 1)):  # light on a dark rim
        cv2.putText(
            frame, label, (10, 22), cv2.FONT_HERSHEY_SIMPLEX, 0.6, colour, thickness, cv2.LINE_AA
        )


class _VideoWriter:
    """Frames to an MP4 (OpenCV, mp4v) or a GIF (Pillow), chosen by the file's extension."""

    def __init__(self, path: Path, fps: float, size_px: tuple[int, int]) -> None:
        self.path = path
        self._fps = fps
        suffix = path.suffix.lower()
        self._gif: list | None = None
        self._mp4: cv2.VideoWriter | None = None
        if not path.parent.is_dir():
            raise ReplayError(f"{path}: its directory {path.parent} does not exist")
        if suffix == ".gif":
            try:
                import PIL.Image  # noqa: F401  (optional: only GIFs need it)
            except ImportError as exc:
                raise ReplayError(
                    f"{path}: GIF output needs Pillow (pip install pillow); or write an .mp4"
                ) from exc
            self._gif = []
        elif suffix == ".mp4":
            self._mp4 = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, size_px)
            if not self._mp4.isOpened():
                raise ReplayError(f"{path}: OpenCV cannot write an MP4 (mp4v) there")
        else:
            raise ReplayError(f"{path}: unknown video type {suffix!r}; use .mp4 or .gif")

    def write(self, frame_bgr: np.ndarray) -> None:
        if self._mp4 is not None:
            self._mp4.write(frame_bgr)
        elif self._gif is not None:
            import PIL.Image

            rgb = cv2.cvtColor(frame_bgr, cv2.COLOR_BGR2RGB)
            self._gif.append(PIL.Image.fromarray(rgb).quantize(colors=128))

    def close(self) -> None:
        if self._mp4 is not None:
            self._mp4.release()
            self._mp4 = None
        elif self._gif:
            first, *rest = self._gif
            first.save(
                self.path,
                save_all=True,
                append_images=rest,
                duration=round(1000.0 / self._fps),
                loop=0,
            )
            self._gif = None


@dataclass(frozen=True)
class VideoResult:
    """What ``render_video`` wrote."""

    path: Path
    frames: int
    start_s: float
    """Simulation time of the first frame, s."""
    end_s: float
    """Simulation time of the last frame, s."""


def frame_times(track: TruthTrack, speed: float, fps: float) -> np.ndarray:
    """Simulation times of the video's frames: from the first sample, ``speed / fps`` apart."""
    if not (speed > 0 and math.isfinite(speed)):
        raise ReplayError(f"speed must be a positive number, got {speed}")
    if not (fps > 0 and math.isfinite(fps)):
        raise ReplayError(f"fps must be a positive number, got {fps}")
    t0, t1 = float(track.time_s[0]), float(track.time_s[-1])
    step = speed / fps
    return t0 + step * np.arange(math.floor((t1 - t0) / step + 1e-9) + 1)


def _check_follow(follow: int | None, n: int) -> None:
    if follow is not None and not 1 <= follow <= n:
        raise ReplayError(f"follow: no vehicle {follow}; the run has vehicles 1..{n}")


def render_video(
    run: ReplayRun,
    path: Path,
    speed: float = 1.0,
    fps: float = VIDEO_FPS,
    size_px: tuple[int, int] = VIDEO_SIZE_PX,
    follow: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> VideoResult:
    """Render the run headless (TinyRenderer) to an MP4 or GIF at ``fps`` frames per second.

    Args:
        run: The loaded run.
        path: Output file, ``.mp4`` or ``.gif``.
        speed: Simulated seconds per video second.
        fps: Frames per video second.
        size_px: (width, height) of the frames, px.
        follow: Vehicle number (1-based) the camera follows; None: the overview camera.
        progress: Called with (frames done, frames in all) after each frame.
    """
    width, height = size_px
    if width < 16 or height < 16:
        raise ReplayError(f"size must be at least 16x16 px, got {width}x{height}")
    _check_follow(follow, run.track.n_vehicles)
    times = frame_times(run.track, speed, fps)
    writer = _VideoWriter(Path(path), fps, size_px)
    scene = ReplayScene(run)
    run.notes.extend(scene.notes)
    try:
        overview = overview_camera(run.track, size_px)
        world = run.world
        shown: tuple[str, ...] | None = None
        ground = None
        for k, t in enumerate(times.tolist()):
            pos, quat = run.track.at(t)
            scene.pose(t, pos, quat)
            camera = overview if follow is None else follow_camera(pos[follow - 1], size_px)
            spills = world.spills_at(t) if world is not None else []
            names = tuple(spill.name for spill in spills)
            if ground is None or follow is not None or names != shown:
                ground, shown = paint_ground(camera, scene.ground_rgba, spills), names
            frame = scene.render(camera, ground)
            draw_overlay(frame, camera, run.track, t, pos)
            writer.write(frame)
            if progress is not None:
                progress(k + 1, len(times))
    finally:
        scene.close()
        writer.close()
    return VideoResult(Path(path), len(times), float(times[0]), float(times[-1]))


def has_display() -> bool:
    """Whether a window can open: DISPLAY (X11) or WAYLAND_DISPLAY is set."""
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def play_gui(run: ReplayRun, speed: float = 1.0, follow: int | None = None) -> None:
    """Play the run in the PyBullet GUI at ``speed`` x real time, trails as debug lines.

    Returns when the user closes the window (or on Ctrl-C); the last pose stays on screen after
    the end of the recording until then.
    """
    if not (speed > 0 and math.isfinite(speed)):
        raise ReplayError(f"speed must be a positive number, got {speed}")
    track = run.track
    _check_follow(follow, track.n_vehicles)
    scene = ReplayScene(run, gui=True)
    run.notes.extend(scene.notes)
    cid = scene.client_id
    pts = track.position_enu_m.reshape(-1, 3)
    centre = (pts.min(axis=0) + pts.max(axis=0)) / 2.0
    radius = max(float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0))) / 2.0, 2.0)
    distance = FOLLOW_DISTANCE_M if follow else 1.3 * radius / math.tan(math.radians(25.0))
    colours = [[c / 255.0 for c in reversed(b)] for b in VEHICLE_COLOURS_BGR]
    try:
        p.resetDebugVisualizerCamera(
            distance, OVERVIEW_YAW_DEG, OVERVIEW_PITCH_DEG, centre.tolist(), physicsClientId=cid
        )
        t0, t1 = float(track.time_s[0]), float(track.time_s[-1])
        wall0 = time.monotonic()
        last = track.at(t0)[0]
        next_trail_s = t0
        while p.isConnected(cid):
            t = min(t0 + (time.monotonic() - wall0) * speed, t1)
            pos, quat = track.at(t)
            scene.pose(t, pos, quat)
            if t >= next_trail_s:
                for i in range(track.n_vehicles):
                    colour = colours[i % len(colours)]
                    p.addUserDebugLine(last[i], pos[i], colour, 2.0, physicsClientId=cid)
                last, next_trail_s = pos, t + 0.25 * speed
            if follow:
                p.resetDebugVisualizerCamera(
                    distance, OVERVIEW_YAW_DEG, FOLLOW_PITCH_DEG, pos[follow - 1].tolist(),
                    physicsClientId=cid,
                )  # fmt: skip
            time.sleep(1.0 / 60.0)
    except (KeyboardInterrupt, p.error):
        pass  # Ctrl-C, or the window was closed between two calls
    finally:
        scene.close()
