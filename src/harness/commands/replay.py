"""``swarmsitl replay RUN_DIR``: show a finished run in 3-D (a window, or a video file)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

from harness.report.replay import (
    VIDEO_FPS,
    VIDEO_SIZE_PX,
    ReplayError,
    has_display,
    load_run,
    play_gui,
    render_video,
)
from harness.run.launch import console

VIDEO_FILE = "replay.mp4"
"""Where a headless replay without --video goes, in the run directory."""


def _parse_size(size: str) -> tuple[int, int]:
    width, sep, height = size.lower().partition("x")
    try:
        parsed = (int(width), int(height))
    except ValueError:
        sep = ""
    if not sep or min(parsed) < 16:
        raise typer.BadParameter(f"{size!r}: expected WIDTHxHEIGHT of at least 16x16, e.g. 640x360")
    return parsed


def replay(
    run_dir: Annotated[
        Path,
        typer.Argument(help="run directory with truth.csv (and manifest.json), e.g. runs/demo"),
    ],
    speed: Annotated[
        float,
        typer.Option(help="simulated seconds per wall (or video) second, e.g. --speed 4"),
    ] = 1.0,
    video: Annotated[
        Path | None,
        typer.Option(
            help="write the replay to this .mp4 or .gif (headless, TinyRenderer), "
            "e.g. --video runs/demo/replay.mp4"
        ),
    ] = None,
    gui: Annotated[
        bool | None,
        typer.Option(
            "--gui/--no-gui",
            help="open the PyBullet window (default: when a display exists and no --video); "
            f"--no-gui writes RUN_DIR/{VIDEO_FILE} unless --video is given",
            show_default=False,
        ),
    ] = None,
    follow: Annotated[
        int | None,
        typer.Option(help="camera follows this vehicle (1-based), e.g. --follow 2"),
    ] = None,
    fps: Annotated[float, typer.Option(help="video frames per second, e.g. --fps 30")] = VIDEO_FPS,
    size: Annotated[
        str, typer.Option(help="video frame size WIDTHxHEIGHT, e.g. --size 1280x720")
    ] = f"{VIDEO_SIZE_PX[0]}x{VIDEO_SIZE_PX[1]}",
) -> None:
    """Show a finished run in 3-D from its ground truth (truth.csv) and manifest.

    The world of the run (world.yaml) is built with the simulation's own code and every vehicle
    is its airframe's URDF, posed as recorded. With a display the PyBullet window plays it at
    --speed x real time; without one (or with --video) it renders with PyBullet's TinyRenderer
    to an MP4 or GIF, --fps frames per video second, --speed simulated seconds per video second,
    trails and numbered markers drawn over the frames.

    Example:  swarmsitl replay runs/demo --video demo.mp4 --speed 4 --follow 1
    """
    frame_size = _parse_size(size)
    try:
        run = load_run(run_dir)
        for note in run.notes:
            console.print(f"[yellow]note:[/yellow] {note}")
        window = video is None and gui is not False
        if window and not has_display():
            if gui:
                raise ReplayError(
                    "--gui: no display (DISPLAY and WAYLAND_DISPLAY are unset); "
                    "write a video instead with --video FILE.mp4"
                )
            window = False
        if window:
            console.print(f"replaying {run_dir} in the PyBullet window; close it to end")
            seen = len(run.notes)
            play_gui(run, speed=speed, follow=follow)
            for note in run.notes[seen:]:
                console.print(f"[yellow]note:[/yellow] {note}")
            return
        out = video if video is not None else run_dir / VIDEO_FILE
        seen = len(run.notes)
        with Progress(
            TextColumn("rendering"),
            BarColumn(),
            TextColumn("{task.completed}/{task.total} frames"),
            TimeRemainingColumn(),
            console=console,
            transient=True,
        ) as bar:
            task = bar.add_task("render", total=None)
            result = render_video(
                run,
                out,
                speed=speed,
                fps=fps,
                size_px=frame_size,
                follow=follow,
                progress=lambda done, total: bar.update(task, completed=done, total=total),
            )
        for note in run.notes[seen:]:
            console.print(f"[yellow]note:[/yellow] {note}")
    except (ReplayError, OSError) as exc:  # OSError: the video could not be written
        console.print(f"[red]error:[/red] {exc}")
        raise typer.Exit(2) from exc
    console.print(
        f"replay video: {result.path} ({result.frames} frames, simulated "
        f"{result.start_s:.2f}-{result.end_s:.2f} s at {speed:g}x, {fps:g} fps)"
    )
