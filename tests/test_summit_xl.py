"""Summit XL with the red landing platform (Palafox et al. 2019): drive, wheel slip, riding payload, red-blob view."""

import math

import cv2
import numpy as np
import pybullet
import pytest

from marsupial.world import World
from marsupial.world.robots.base import yaw_of
from marsupial.world.robots.summit_xl import SummitXL


def _fit_circle(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares circle through 2-D points: centre and radius."""
    A = np.c_[2 * points, np.ones(len(points))]
    cx, cy, c = np.linalg.lstsq(A, (points**2).sum(axis=1), rcond=None)[0]
    return np.array([cx, cy]), math.sqrt(c + cx * cx + cy * cy)


def test_kind_geometry_and_state():
    with World() as world:
        ugv = world.add_robot("summit_xl", pose=[1.0, 2.0, 0.3])
        assert isinstance(ugv, SummitXL)
        assert ugv.platform_size == pytest.approx((1.0, 1.0))
        p_platform, q_platform = ugv.platform_pose()
        assert p_platform == pytest.approx([1.0, 2.0, 0.40], abs=1e-6)
        assert yaw_of(q_platform) == pytest.approx(0.3, abs=1e-6)
        assert ugv.footprint_pose()[0][2] == pytest.approx(0.0, abs=1e-6)
        assert {"speed", "yaw_rate", "platform_position"} <= set(ugv.state())
        with pytest.raises(ValueError, match="unknown drive limit"):
            world.add_robot("summit_xl", name="bad", limits={"max_sped": 1.0})


def test_straight_line_at_nominal_speed():
    with World(seed=2) as world:
        ugv = world.add_robot("summit_xl")
        ugv.drive(0.5, 0.0)  # nominal speed of the linear track, §4.2.1
        world.step(20.0)
        p, _ = ugv.pose()
        assert ugv.speed() == pytest.approx(0.5, abs=0.02)
        assert p[0] == pytest.approx(0.5 * 20.0 - 0.5 * 0.5 / 1.0 / 2, abs=0.05)  # ramp at 1 m/s²
        assert abs(p[1]) < 0.05  # stays within a few cm of the line (Fig. 6)
        ugv.safe_stop()
        world.step(1.0)
        assert abs(ugv.speed()) < 1e-3


def test_circle_comes_out_wider_as_observed():
    with World(seed=3) as world:
        ugv = world.add_robot("summit_xl")
        ugv.drive(0.5, 0.05)  # a 10 m circle in theory, §4.2.1
        points = []
        for _ in range(60):
            world.step(1.0)
            points.append(ugv.pose()[0][:2])
        _, radius = _fit_circle(np.array(points[2:]))
        assert radius == pytest.approx(12.0, abs=0.3)  # "a circle of radius 12 m"


def test_a_payload_and_a_landed_uav_ride_on_the_platform():
    with World() as world:
        ugv = world.add_robot("summit_xl", limits={"noise_std": 0.0})
        cid = world.client_id
        half = [0.15, 0.15, 0.05]
        box = pybullet.createMultiBody(
            0.5,
            pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half, physicsClientId=cid),
            pybullet.createVisualShape(pybullet.GEOM_BOX, halfExtents=half, physicsClientId=cid),
            [0.1, -0.1, 0.40 + 0.05 + 0.02],
            physicsClientId=cid,
        )
        drone = world.add_robot("ardrone2", pose=[-0.25, 0.2, 0.40 + 0.061 + 0.01, 0.0], motors_on=False)
        world.step(1.0)  # dropped from 1-2 cm, settles
        ugv.drive(0.5, 0.0)
        world.step(6.0)
        p_box = np.array(pybullet.getBasePositionAndOrientation(box, physicsClientId=cid)[0])
        v_box = np.array(pybullet.getBaseVelocity(box, physicsClientId=cid)[0])
        p_platform, _ = ugv.platform_pose()
        assert p_box - p_platform == pytest.approx([0.1, -0.1, 0.05], abs=0.01)
        assert v_box[0] == pytest.approx(0.5, abs=0.01)
        assert drone.pose()[0] - p_platform == pytest.approx([-0.25, 0.2, 0.061], abs=0.01)  # a landed UAV rides too


def test_red_platform_is_segmentable_from_4_m():
    with World() as world:
        ugv = world.add_robot("summit_xl", pose=[0.3, -0.2, 0.4])
        drone = world.add_robot("ardrone2", pose=[0.0, 0.0, 4.0, 0.0])  # nominal tracking height, §3.1
        frame = drone.sensor("bottom_camera").measure()
        hsv = cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2HSV)
        red = cv2.inRange(hsv, (0, 120, 60), (10, 255, 255)) | cv2.inRange(hsv, (170, 120, 60), (180, 255, 255))
        moments = cv2.moments(red, binaryImage=True)
        assert moments["m00"] > 0
        centroid = np.array([moments["m10"], moments["m01"]]) / moments["m00"]
        p_platform, _ = ugv.platform_pose()
        p_optical = frame.rotation.T @ (p_platform - frame.position)
        expected = (frame.K @ (p_optical / p_optical[2]))[:2]
        assert np.linalg.norm(centroid - expected) < 2.0  # px
        assert (frame.K[0, 0], frame.rgb.shape) == (pytest.approx(320.0, abs=0.5), (240, 320, 3))  # QVGA, 64° diagonal
        side_px = ugv.platform_size[0] * frame.K[0, 0] / p_optical[2]
        assert moments["m00"] == pytest.approx(side_px**2, rel=0.08)
