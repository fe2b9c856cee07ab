import pybullet as p
import pytest

from sitl.physics.obstacles import BoxObstacle
from sitl.world import World, WorldConfig


def test_a_box_stops_a_ray_at_its_face():
    """A wall whose near face is 2 m north of the origin stops a northward ray at 2 m."""
    wall = BoxObstacle((0.0, 2.1, 1.5), (10.0, 0.2, 3.0))
    with World(WorldConfig(obstacles=(wall,), spawn_altitude_m=1.0)) as world:
        cid = world._scene.client_id
        [(body, _, _, hit, _)] = p.rayTestBatch(
            [[0.0, -5.0, 1.0]], [[0.0, 5.0, 1.0]], physicsClientId=cid
        )
        assert body == world.obstacle_ids[0]
        assert hit[1] == pytest.approx(2.0, abs=1e-6)


def test_a_yawed_box_is_rotated_about_the_vertical():
    """A 4 m x 0.2 m wall yawed 90 deg runs north-south: an eastward ray meets its 0.1 m face."""
    wall = BoxObstacle((3.0, 0.0, 1.0), (4.0, 0.2, 2.0), yaw_deg=90.0)
    with World(WorldConfig(obstacles=(wall,))) as world:
        cid = world._scene.client_id
        [(_, _, _, hit, _)] = p.rayTestBatch(
            [[0.0, 1.5, 1.0]], [[6.0, 1.5, 1.0]], physicsClientId=cid
        )
        assert hit[0] == pytest.approx(2.9, abs=1e-6)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"center_enu_m": (0, 0, 1), "size_m": (1, 0, 1)}, "size_m"),
        ({"center_enu_m": (0, 0), "size_m": (1, 1, 1)}, "center_enu_m"),
        ({"center_enu_m": (0, 0, 1), "size_m": (1, 1, 1), "rgba": (2, 0, 0, 1)}, "rgba"),
        ({"center_enu_m": (0, float("nan"), 1), "size_m": (1, 1, 1)}, "center_enu_m"),
    ],
)
def test_bad_boxes_name_the_field(kwargs, field):
    with pytest.raises(ValueError, match=field):
        BoxObstacle(**kwargs)


def test_world_rejects_what_is_not_a_box():
    with pytest.raises(ValueError, match=r"obstacles\[0\]"):
        WorldConfig(obstacles=((0, 0, 1),))
