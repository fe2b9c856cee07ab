"""``python -m harness.imagery``: render images of the project's scenes into a folder.

Writes ``OUT/00000.png`` ... (RGB in PNG) and ``OUT/index.csv`` (file, scene, altitude_m, split,
seed, then world, time_s, heading_deg); see ``harness.imagery`` and docs/compression.md,
"Training images".
"""

from __future__ import annotations

import csv
import time
from pathlib import Path
from typing import Annotated

import cv2
import typer

from harness.imagery.render import SPLITS, render_images

INDEX_FILE = "index.csv"
"""The table of the images, in the output folder."""
INDEX_COLUMNS = ("file", "scene", "altitude_m", "split", "seed", "world", "time_s", "heading_deg")
"""Columns of ``index.csv``."""

app = typer.Typer(add_completion=False, help=__doc__.splitlines()[0])


@app.command()
def imagery(
    out: Annotated[
        Path, typer.Option(help="folder for the PNGs and index.csv, e.g. --out /tmp/img_train")
    ],
    split: Annotated[
        str,
        typer.Option(help="train or heldout (disjoint world instances), e.g. --split train"),
    ],
    count: Annotated[int, typer.Option(min=0, help="number of images, e.g. --count 600")],
    width: Annotated[int, typer.Option(min=16, help="image width, pixels, e.g. --width 320")] = 320,
    height: Annotated[
        int, typer.Option(min=16, help="image height, pixels, e.g. --height 240")
    ] = 240,
    seed: Annotated[
        int, typer.Option(min=0, help="run seed: other seeds, other world instances, e.g. --seed 1")
    ] = 0,
    quiet: Annotated[bool, typer.Option(help="no progress lines, e.g. --quiet")] = False,
) -> None:
    """Render COUNT images of offshore, city, indoor and land scenes into OUT.

    Example: python -m harness.imagery --out /tmp/img_train --split train --count 600
    """
    if split not in SPLITS:
        raise typer.BadParameter(f"{split!r}: one of {', '.join(SPLITS)}", param_hint="--split")
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    step = max(1, count // 10)
    with (out / INDEX_FILE).open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(INDEX_COLUMNS)
        for rgb, info in render_images(split, count, width, height, seed):
            name = f"{info.index:05d}.png"
            if not cv2.imwrite(str(out / name), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)):
                raise typer.BadParameter(f"could not write {out / name}", param_hint="--out")
            writer.writerow(
                (
                    name,
                    info.scene,
                    f"{info.altitude_m:.3f}",
                    info.split,
                    info.seed,
                    info.world,
                    f"{info.time_s:.3f}",
                    f"{info.heading_deg:.1f}",
                )
            )
            done = info.index + 1
            if not quiet and (done % step == 0 or done == count):
                elapsed = time.perf_counter() - start
                print(f"{done}/{count} images ({info.scene}), {elapsed:.1f} s", flush=True)
    if not quiet:
        print(f"wrote {count} images and {INDEX_FILE} to {out}")


def main() -> None:
    """Entry point of ``python -m harness.imagery``."""
    app()


if __name__ == "__main__":
    main()
