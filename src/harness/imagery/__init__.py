"""Images of the project's scenes from the simulator's camera pipeline (training the codec).

``render_images`` yields them; ``python -m harness.imagery`` writes them as PNG files (see
docs/compression.md, "Training images").
"""

from harness.imagery.render import (
    SCENES,
    SPLITS,
    ImageInfo,
    render_images,
    scene_counts,
    world_seed,
)

__all__ = ["SCENES", "SPLITS", "ImageInfo", "render_images", "scene_counts", "world_seed"]
