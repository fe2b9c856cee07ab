import numpy as np
import pytest

from harness.imagery import render_images


@pytest.fixture(scope="session")
def scene_images() -> list[np.ndarray]:
    """A few held-out-split renders of the project's scenes (offshore, city, indoor, land)."""
    return [image for image, _ in render_images("heldout", 8, 320, 240, seed=7)]
