"""Camera: metric depth, analytic floor fill, intrinsics consistent with the render, seeded noise."""

import math

import numpy as np
import pybullet
import pytest

from marsupial.api.model import Intrinsics
from marsupial.world import World
from marsupial.world.robots.base import Robot
from marsupial.world.sensors.base import SensorConfig
from marsupial.world.sensors.camera import OPTICAL_DOWN, OPTICAL_FORWARD, Camera

FLOOR_RGB = (128, 128, 128)  # floor of the bare world


def _camera(world, position, rpy=(0.0, 0.0, 0.0), R_link_optical=OPTICAL_FORWARD, size=(320, 240), fov=60.0, **options):
    """A camera on the base of an invisible static body at ``position`` with roll/pitch/yaw ``rpy`` (rad)."""
    rig = Robot(world, "rig")
    rig.body_id = pybullet.createMultiBody(
        0.0, -1, -1, position, pybullet.getQuaternionFromEuler(rpy), physicsClientId=world.client_id
    )
    config = SensorConfig(rate_hz=30.0, noise_std=options.pop("noise_std", 0.0))
    return Camera(
        rig, "eye", Intrinsics(*size, fov), config, R_link_optical=R_link_optical, segmentation=True, **options
    )


def _box(world, half_extents, position, rgba=(1.0, 0.0, 0.0, 1.0)):
    cid = world.client_id
    collision = pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half_extents, physicsClientId=cid)
    visual = pybullet.createVisualShape(
        pybullet.GEOM_BOX, halfExtents=half_extents, rgbaColor=rgba, physicsClientId=cid
    )
    return pybullet.createMultiBody(0.0, collision, visual, position, physicsClientId=cid)


def test_depth_of_a_box_top_and_of_the_floor():
    with World(noise_scale=0.0) as world:  # geometry: no white balance / exposure error
        box = _box(world, [0.3, 0.3, 0.5], [0, 0, 0.5])  # top at z = 1 m
        frame = _camera(world, [0, 0, 3.0], R_link_optical=OPTICAL_DOWN).measure()
        on_box = frame.segmentation == box
        on_floor = frame.segmentation == world.scene.floor.body_id
        assert on_box.sum() > 1000 and on_floor.sum() > 30000 and on_box.sum() + on_floor.sum() == 320 * 240
        # straight down, depth along the optical axis is the height difference
        np.testing.assert_allclose(frame.depth[on_box], 2.0, atol=2e-3)
        np.testing.assert_allclose(frame.depth[on_floor], 3.0, rtol=1e-5)
        assert frame.depth.dtype == np.float32 and frame.rgb.dtype == np.uint8 and frame.rgb.flags.c_contiguous
        assert (frame.rgb[on_floor] == FLOOR_RGB).all()
        assert (frame.rgb[on_box][:, 0] > 150).all() and (frame.rgb[on_box][:, 1:] == 0).all()


def test_floor_fills_only_empty_pixels_and_lies_on_the_floor_plane():
    with World(noise_scale=0.0) as world:  # geometry: no white balance / exposure error
        near_box = _box(world, [0.25, 0.25, 0.25], [2.0, 0.3, 0.25])
        # looking forward and 20 degrees down from 1.2 m: horizon, floor and a box in view
        camera = _camera(world, [0, 0, 1.2], rpy=(0.0, math.radians(20), 0.0))
        frame = camera.measure()
        on_box = frame.segmentation == near_box
        on_floor = frame.segmentation == world.scene.floor.body_id
        empty = frame.segmentation == -1
        assert on_box.any() and on_floor.any() and empty.any()
        assert (frame.rgb[on_box][:, 0] > 150).all() and (frame.rgb[on_box][:, 1:] == 0).all()  # box kept
        assert (frame.rgb[on_floor] == FLOOR_RGB).all()
        assert empty[0].all()  # sky above the horizon
        np.testing.assert_allclose(frame.depth[empty], camera.intrinsics.far, rtol=1e-4)
        # back-project every floor pixel with K and the pose: it lands on z = 0
        v, u = np.nonzero(on_floor)
        rays = np.linalg.inv(frame.K) @ np.stack([u, v, np.ones_like(u)]).astype(float)
        points = frame.position[:, None] + frame.rotation @ (rays * frame.depth[v, u])
        np.testing.assert_allclose(points[2], 0.0, atol=1e-5 * frame.depth[v, u].max() ** 2 + 1e-4)
        # the floor behind the box is hidden by it: its depth there is the box's
        rays_box = np.linalg.inv(frame.K) @ np.array([*np.argwhere(on_box)[0][::-1], 1.0])
        hidden_floor_depth = -frame.position[2] / (frame.rotation @ rays_box)[2]
        assert frame.depth[on_box][0] < hidden_floor_depth


def test_floor_out_of_view_leaves_the_frame_empty():
    with World(noise_scale=0.0) as world:  # geometry: no white balance / exposure error
        camera = _camera(world, [0, 0, 1.0], rpy=(0.0, math.radians(-60), 0.0))  # looking 60 degrees up
        frame = camera.measure()
        assert (frame.segmentation == -1).all()
        np.testing.assert_allclose(frame.depth, camera.intrinsics.far, rtol=1e-4)


@pytest.mark.parametrize("size", [(320, 240), (160, 90)])
def test_K_projects_known_points_onto_their_rendered_pixels(size):
    with World(noise_scale=0.0) as world:  # geometry: no white balance / exposure error
        camera = _camera(world, [0.5, -0.3, 1.5], rpy=(0.1, math.radians(15), math.radians(30)), size=size, fov=50.0)
        position, R = camera.optical_pose()
        cid = world.client_id
        sphere = pybullet.createVisualShape(pybullet.GEOM_SPHERE, radius=0.03, physicsClientId=cid)
        points = {}
        for x, y in [(-0.4, -0.25), (0.5, 0.3), (0.0, 0.0), (0.3, -0.35)]:  # optical-frame directions, z = 1
            p_world = position + R @ (np.array([x, y, 1.0]) * 3.0)
            points[pybullet.createMultiBody(0.0, -1, sphere, p_world.tolist(), physicsClientId=cid)] = p_world
        frame = camera.measure()
        K = camera.K
        for body, p_world in points.items():
            p_optical = R.T @ (p_world - position)
            expected = (K @ (p_optical / p_optical[2]))[:2]
            v, u = np.nonzero(frame.segmentation == body)
            assert u.size > 0
            np.testing.assert_allclose([u.mean(), v.mean()], expected, atol=0.4)  # well within a pixel


def test_noise_is_seeded():
    def frame(seed):
        with World(seed=seed) as world:
            _box(world, [0.3, 0.3, 0.5], [0, 0, 0.5])
            return _camera(
                world, [0, 0, 3.0], R_link_optical=OPTICAL_DOWN, noise_std=8.0, depth_noise_per_m=0.01
            ).measure()

    a, b, c = frame(3), frame(3), frame(4)
    np.testing.assert_array_equal(a.rgb, b.rgb)
    np.testing.assert_array_equal(a.depth, b.depth)
    assert not np.array_equal(a.rgb, c.rgb) and not np.array_equal(a.depth, c.depth)
    on_floor = a.segmentation == a.segmentation[0, 0]
    assert a.rgb[on_floor].astype(float).std(axis=0) == pytest.approx([8.0] * 3, rel=0.05)  # per channel
    assert a.depth[on_floor].std() == pytest.approx(0.03, rel=0.05)  # 0.01 per metre at 3 m
