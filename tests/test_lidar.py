"""2-D LiDAR (Sick LMS111 on the mobile manipulator): ranges, field of view, own body, seeded noise."""

import math

import numpy as np
import pybullet
import pytest

from marsupial.api.model import LidarSpec
from marsupial.world import World
from marsupial.world.sensors.base import SensorConfig
from marsupial.world.sensors.lidar import Lidar

WALL_X = 3.0  # m, centre of a 0.2 m thick wall in front of the robot
LIDAR_X = 0.17  # m, LiDAR ahead of base_footprint (URDF)


def _wall(world, center, half_extents):
    cid = world.client_id
    shape = pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half_extents, physicsClientId=cid)
    visual = pybullet.createVisualShape(pybullet.GEOM_BOX, halfExtents=half_extents, physicsClientId=cid)
    return pybullet.createMultiBody(0.0, shape, visual, center, physicsClientId=cid)


def _carrier(world, **options):
    mm = world.add_robot("mobile_manipulator", sensors={"lidar": {"noise_std": 0.0, "beam_dropout": 0.0}}, **options)
    _wall(world, [WALL_X, 0, 1], [0.1, 8, 1])
    return mm


def test_lidar_sees_a_wall_at_the_right_distance_over_270_degrees():
    with World(seed=0) as world:
        mm = _carrier(world)
        scan = mm.lidar.read().data
        assert len(scan.ranges) == 541 and scan.ranges.dtype == np.float32  # 270° / 0.5° + 1
        assert math.degrees(scan.angles[0]) == pytest.approx(-135.0)
        assert math.degrees(scan.angles[-1]) == pytest.approx(135.0)
        ahead = WALL_X - 0.1 - LIDAR_X
        front = np.abs(scan.angles) < math.radians(60)
        expected = ahead / np.cos(scan.angles[front])
        assert np.abs(scan.ranges[front] - expected).max() < 1e-3
        assert np.all(np.isinf(scan.ranges[np.abs(scan.angles) > math.radians(100)]))  # nothing else around
        points = scan.points_world()
        assert np.abs(points[:, 0] - (WALL_X - 0.1)).max() < 1e-3


def test_lidar_has_no_rear_sector_and_a_full_turn_option():
    with World(seed=0) as world:
        mm = world.add_robot("mobile_manipulator", sensors={"lidar": {"noise_std": 0.0}})
        wall = _wall(world, [-3.0, 0, 1], [0.1, 0.8, 1])  # behind the robot, within ±15° of its rear
        assert wall not in mm.lidar.read().data.hit_bodies
        full = Lidar(mm, "full_turn", LidarSpec(fov_deg=360.0), SensorConfig(rate_hz=10.0), link="lidar")
        scan = full.read().data
        assert len(scan.angles) == 720 and wall in scan.hit_bodies


def test_lidar_ignores_the_robot_itself():
    with World(seed=0) as world:
        mm = _carrier(world, arm_pose=[0.0, 1.4, 1.0, 0.0, 0.0, 0.0])  # forearm dips through the scan plane ahead
        p_lidar, _ = mm.link_pose("lidar")
        blocked = pybullet.rayTest(
            (p_lidar + [0.06, 0, 0]).tolist(), (p_lidar + [5, 0, 0]).tolist(), physicsClientId=world.client_id
        )[0]
        assert blocked[0] == mm.body_id  # the arm really is in the beam
        scan = mm.lidar.read().data
        assert mm.body_id not in scan.hit_bodies
        ahead = np.abs(scan.angles) < math.radians(5)
        assert np.abs(scan.ranges[ahead] - (WALL_X - 0.1 - LIDAR_X) / np.cos(scan.angles[ahead])).max() < 1e-3


def test_lidar_noise_and_lost_echoes_are_seeded():
    settings = {"lidar": {"noise_std": 0.012, "beam_dropout": 0.1}}  # LMS111: 12 mm statistical error (1σ)

    def scan(seed):
        with World(seed=seed) as world:
            world.add_robot("mobile_manipulator", sensors=settings)
            _wall(world, [WALL_X, 0, 1], [0.1, 40, 1])
            return world.robot("mobile_manipulator").lidar.read().data

    a, b, c = scan(3), scan(3), scan(4)
    assert np.array_equal(a.ranges, b.ranges)
    assert not np.array_equal(a.ranges, c.ranges)
    front = np.abs(a.angles) < math.radians(80)
    exact = (WALL_X - 0.1 - LIDAR_X) / np.cos(a.angles[front])
    echoed = np.isfinite(a.ranges[front])
    assert 0.05 < 1 - echoed.mean() < 0.16
    assert np.std(a.ranges[front][echoed] - exact[echoed]) == pytest.approx(0.012, rel=0.25)


def test_lidar_spec_rejects_bad_geometry():
    with pytest.raises(ValueError, match="fov_deg"):
        LidarSpec(fov_deg=400.0)
    with pytest.raises(ValueError, match="start_range"):
        LidarSpec(start_range=30.0)
