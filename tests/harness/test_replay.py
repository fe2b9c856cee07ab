"""`swarmsitl replay`: a real lockstep run replayed as a video; bad run directories fail clean."""

from __future__ import annotations

import csv
import shutil

import cv2
import numpy as np
import pytest
from typer.testing import CliRunner

from harness.cli import app
from harness.report.replay import (
    ReplayScene,
    TruthTrack,
    frame_times,
    load_run,
    load_truth,
    overview_camera,
    paint_ground,
)
from harness.run.manifest import RunManifest, write_manifest
from harness.sim.simulation import Simulation, SimulationConfig

SIZE = "160x96"


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    """Two Typhoons: 2 s on the ground, then both take off for 3 s (lockstep, no sockets)."""
    out = tmp_path_factory.mktemp("run")
    config = SimulationConfig(n_vehicles=2, seed=4, mavlink=False, out_dir=out, record_hz=20.0)
    with Simulation(config) as sim:
        manifest = RunManifest.from_simulation(sim, 5.0, roles=("edge", "fog"))
        write_manifest(out, manifest)
        for params in sim.fleet.params:
            params.set("MIS_TAKEOFF_ALT", 4.0)
        sim.run_lockstep(2.0)
        for i in range(2):
            vehicle = sim.fleet.vehicle(i)
            assert vehicle.arm(False) == 0 and vehicle.takeoff(None) == 0
        sim.run_lockstep(3.0)
        write_manifest(out, manifest.finished(sim.time_s, True))
    return out


def _copy(run_dir, tmp_path):
    dst = tmp_path / "run"
    shutil.copytree(run_dir, dst)
    return dst


def _frames(path) -> list[np.ndarray]:
    cap = cv2.VideoCapture(str(path))
    frames = []
    while True:
        ok, frame = cap.read()
        if not ok:
            break
        frames.append(frame)
    cap.release()
    return frames


def _replay(*args):
    return CliRunner().invoke(app, ["replay", *map(str, args)])


def test_help_has_example():
    result = _replay("--help")
    assert result.exit_code == 0 and "Example:" in result.output


def test_video_shows_the_flight_frame_by_frame(run_dir, tmp_path):
    """The MP4 holds one frame per 1/fps of simulated time at --speed 1, and the picture
    changes as the vehicles climb (compared away from the time label)."""
    video = tmp_path / "x.mp4"
    result = _replay(run_dir, "--video", video, "--no-gui", "--size", SIZE, "--fps", 10)
    assert result.exit_code == 0, result.output
    assert str(video) in result.output.replace("\n", "")
    frames = _frames(video)
    track = load_truth(run_dir / "truth.csv")
    assert len(frames) == len(frame_times(track, 1.0, 10.0)) == 50
    assert frames[0].shape == (96, 160, 3)
    body = [f[30:, :].astype(int) for f in frames]

    def changed_px(a: int, b: int) -> int:
        return int(np.count_nonzero(np.abs(body[b] - body[a]).sum(axis=-1) > 40))

    # On the ground (first 2 s) nothing moves but codec noise; the climb moves bodies and trails.
    assert changed_px(0, 15) < 30
    assert changed_px(30, 49) > 200


def test_without_a_display_the_video_goes_to_the_run_dir(run_dir, tmp_path, monkeypatch):
    """No DISPLAY, no --video: RUN_DIR/replay.mp4, --speed simulated seconds per video second."""
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    run = _copy(run_dir, tmp_path)
    result = _replay(run, "--speed", 5, "--size", SIZE)
    assert result.exit_code == 0, result.output
    assert len(_frames(run / "replay.mp4")) == 20  # 5 s at 5x, 20 fps


def test_gif_output(run_dir, tmp_path):
    from PIL import Image

    gif = tmp_path / "x.gif"
    result = _replay(run_dir, "--video", gif, "--speed", 5, "--size", SIZE, "--fps", 4)
    assert result.exit_code == 0, result.output
    with Image.open(gif) as img:
        assert img.n_frames == len(frame_times(load_truth(run_dir / "truth.csv"), 5.0, 4.0)) == 4


def test_bodies_are_drawn_where_the_truth_puts_them(run_dir):
    """Rendered vehicle pixels sit around the camera projection of their recorded positions
    (what the trails are drawn with): scene and overlay agree."""
    run = load_run(run_dir)
    size = (320, 192)
    scene = ReplayScene(run)
    try:
        camera = overview_camera(run.track, size)
        ground = paint_ground(camera, scene.ground_rgba)
        t = float(run.track.time_s[-1])
        pos, quat = run.track.at(t)
        scene.pose(t, pos, quat)
        with_vehicles = scene.render(camera, ground).astype(int)
        px, front = camera.project(pos)
        assert front.all()
        for i in range(2):
            away = pos.copy()
            away[i] += 1000.0
            scene.pose(t, away, quat)
            changed = np.argwhere(np.abs(scene.render(camera, ground) - with_vehicles).sum(-1) > 30)
            assert len(changed) > 5
            centroid = changed.mean(axis=0)[::-1]  # (x, y)
            assert np.linalg.norm(centroid - px[i]) < 6.0, (i, centroid, px[i])
    finally:
        scene.close()


def test_recorded_attitude_matches_the_recorded_tilt(run_dir):
    """truth.csv's quaternion columns agree with its tilt column (angle of body up to world up)."""
    with (run_dir / "truth.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    q = np.array([[float(r[f"quat_{c}"]) for c in "xyzw"] for r in rows])
    tilt = np.array([float(r["tilt_deg"]) for r in rows])
    x, y = q[:, 0], q[:, 1]
    body_up_z = 1.0 - 2.0 * (x * x + y * y)  # world z of body z, from the quaternion
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-4)
    assert np.allclose(np.degrees(np.arccos(np.clip(body_up_z, -1, 1))), tilt, atol=0.05)
    assert tilt.max() > 0.5  # the climb tilts them a little: the check is not vacuous


def test_truncated_truth_keeps_its_whole_samples(run_dir, tmp_path):
    """A run killed while writing truth.csv: the cut-off row and the half sample are left out,
    everything before replays."""
    run = _copy(run_dir, tmp_path)
    truth = run / "truth.csv"
    text = truth.read_text()
    lines = text.splitlines(keepends=True)
    # The header, 30 samples of two vehicles, vehicle 0 of the next, half a row.
    cut = "".join(lines[:62]) + lines[62][:17]
    truth.write_text(cut)
    track = load_truth(truth, 2)
    assert len(track.time_s) == 30 and track.dropped_rows == 2
    assert np.isfinite(track.position_enu_m).all()
    result = _replay(run, "--video", tmp_path / "t.mp4", "--size", SIZE, "--fps", 10)
    assert result.exit_code == 0, result.output
    assert "left out" in result.output
    assert len(_frames(tmp_path / "t.mp4")) == len(frame_times(track, 1.0, 10.0))


def test_older_truth_without_attitude_replays_upright(run_dir, tmp_path):
    run = _copy(run_dir, tmp_path)
    truth = run / "truth.csv"
    with truth.open() as fh:
        rows = list(csv.reader(fh))
    keep = [k for k, name in enumerate(rows[0]) if not name.startswith("quat_")]
    with truth.open("w", newline="") as fh:
        csv.writer(fh).writerows([[r[k] for k in keep] for r in rows])
    track = load_truth(truth)
    assert track.quaternion_xyzw is None
    _, quat = track.at(3.0)
    assert np.allclose(quat, [[0, 0, np.sqrt(0.5), np.sqrt(0.5)]] * 2)  # FLU x to north
    result = _replay(run, "--video", tmp_path / "u.mp4", "--size", SIZE, "--speed", 5)
    assert result.exit_code == 0, result.output


def test_missing_world_file_falls_back_to_plain_ground(run_dir, tmp_path):
    run = _copy(run_dir, tmp_path)
    manifest = load_run(run).manifest
    write_manifest(run, RunManifest(**{**manifest.__dict__, "world": "world.yaml"}))
    result = _replay(run, "--video", tmp_path / "w.mp4", "--size", SIZE, "--speed", 5)
    assert result.exit_code == 0, result.output
    assert "world file missing" in result.output


def test_world_is_built_into_the_scene(run_dir, tmp_path):
    from worlds.examples import example_path

    run = _copy(run_dir, tmp_path)
    shutil.copy(example_path("indoor"), run / "world.yaml")
    manifest = load_run(run).manifest
    write_manifest(run, RunManifest(**{**manifest.__dict__, "world": "world.yaml"}))
    loaded = load_run(run)
    assert loaded.world is not None and loaded.world.kind == "indoor"
    scene = ReplayScene(loaded)
    try:
        assert scene.ground_rgba == loaded.world.surface.rgba
    finally:
        scene.close()


def test_no_manifest_assumes_the_default_airframe(run_dir, tmp_path):
    run = _copy(run_dir, tmp_path)
    (run / "manifest.json").unlink()
    loaded = load_run(run)
    assert loaded.airframes == ("typhoon_h480", "typhoon_h480") and loaded.world is None
    assert any("no manifest.json" in note for note in loaded.notes)


@pytest.mark.parametrize(
    ("prepare", "args", "message"),
    [
        (lambda run: (run / "truth.csv").unlink(), (), "no ground truth recorded"),
        (lambda run: (run / "truth.csv").write_text("time_s,vehicle\n"), (), "not a truth.csv"),
        (lambda run: (run / "truth.csv").write_text((run / "truth.csv").read_text()[:400]), (),
         "no samples"),
        (lambda run: (run / "manifest.json").write_text("{"), (), "corrupt run manifest"),
        (lambda run: shutil.rmtree(run), (), "no such run directory"),
        (None, ("--follow", "3"), "no vehicle 3"),
        (None, ("--video", "x.avi"), "use .mp4 or .gif"),
        (None, ("--speed", "0"), "speed must be a positive"),
        (None, ("--gui",), "no display"),
    ],
)  # fmt: skip
def test_bad_input_exits_2_with_a_message(run_dir, tmp_path, monkeypatch, prepare, args, message):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.chdir(tmp_path)
    run = _copy(run_dir, tmp_path)
    if prepare is not None:
        prepare(run)
    result = _replay(run, "--size", SIZE, *args)
    assert result.exit_code == 2, result.output
    assert message in " ".join(result.output.split())
    assert "Traceback" not in result.output


def test_invalid_world_file_is_named(run_dir, tmp_path):
    run = _copy(run_dir, tmp_path)
    (run / "world.yaml").write_text("kind: city\nseed: 1\nwrong_key: 3\n")
    manifest = load_run(run).manifest
    write_manifest(run, RunManifest(**{**manifest.__dict__, "world": "world.yaml"}))
    result = _replay(run, "--size", SIZE, "--no-gui")
    assert result.exit_code == 2
    assert "world.yaml" in result.output


def test_frame_times_step_by_speed_over_fps():
    track = TruthTrack(np.array([1.0, 2.0, 3.0]), np.zeros((3, 1, 3)), None)
    assert np.allclose(frame_times(track, 2.0, 4.0), [1.0, 1.5, 2.0, 2.5, 3.0])


def test_window_plays_to_the_last_pose_and_ends_when_closed(run_dir, monkeypatch):
    """The GUI loop (on a DIRECT client here: no display in CI) poses the bodies up to the last
    recorded sample at --speed and returns once the window is gone."""
    import pybullet

    import harness.report.replay as replay_module

    checks = {"n": 0}
    poses: dict[int, list[float]] = {}

    class WindowlessPyBullet:
        GUI = pybullet.DIRECT

        def __getattr__(self, name):
            return getattr(pybullet, name)

        def isConnected(self, cid):
            checks["n"] += 1
            return checks["n"] < 120 and pybullet.isConnected(cid)

        def resetBasePositionAndOrientation(self, body, pos, quat, physicsClientId):
            poses[body] = pos
            pybullet.resetBasePositionAndOrientation(
                body, pos, quat, physicsClientId=physicsClientId
            )

    monkeypatch.setattr(replay_module, "p", WindowlessPyBullet())
    run = load_run(run_dir)
    replay_module.play_gui(run, speed=20.0, follow=1)  # >= 2 s of wall time: 40 s of flight
    assert checks["n"] == 120
    last = run.track.position_enu_m[-1]
    assert np.allclose([poses[b] for b in sorted(poses)], last, atol=1e-9)


def test_airframe_that_no_longer_loads_is_a_marker(run_dir, tmp_path):
    run = _copy(run_dir, tmp_path)
    manifest = load_run(run).manifest
    airframes = ("typhoon_h480", str(tmp_path / "moved_airframe"))
    write_manifest(run, RunManifest(**{**manifest.__dict__, "airframes": airframes}))
    result = _replay(run, "--video", tmp_path / "m.mp4", "--size", SIZE, "--speed", 5)
    assert result.exit_code == 0, result.output
    assert "shown as a sphere" in " ".join(result.output.split())
    assert len(_frames(tmp_path / "m.mp4")) == 20


def test_painted_ground_puts_a_spill_where_the_camera_projects_it():
    """The per-pixel ground agrees with the camera's projection: the pixel of a spill's centre is
    the spill's colour, a pixel 10 m beside it is the sea's; with no spill both are sea."""
    from worlds import OilSpill

    track = TruthTrack(np.array([0.0, 1.0]), np.array([[[-40.0, -30, 0]], [[40.0, 30, 20]]]), None)
    camera = overview_camera(track, (320, 192))
    square = ((-5.0, -5.0), (5.0, -5.0), (5.0, 5.0), (-5.0, 5.0))
    spill = OilSpill("s", square, 0.0, (1.0, 0.0, 0.0, 1.0))  # pure red: BGR (0, 0, 255)
    sea = (0.05, 0.22, 0.35, 1.0)
    painted = paint_ground(camera, sea, [spill])
    plain = paint_ground(camera, sea)
    (cx, cy), (ox, oy) = np.round(camera.project(np.array([[0, 0, 0], [10, 10, 0]]))[0]).astype(int)
    assert tuple(painted[cy, cx]) == (0, 0, 255)
    assert tuple(painted[oy, ox]) == tuple(plain[oy, ox]) != (0, 0, 255)
    assert tuple(plain[cy, cx]) != (0, 0, 255)
    assert np.count_nonzero(np.all(painted == (0, 0, 255), axis=-1)) > 50
