"""Platform detection of Palafox et al. (2019), Algorithm 1, on rendered AR.Drone 2 bottom-camera frames."""

import math

import numpy as np
import pybullet
import pytest

from marsupial.skills.landing.detection import DetectionParams, detect_platform, tilt_of
from marsupial.world import World
from marsupial.world.robots.quadrotor import ARDRONE2

UGV_POSE = [0.3, -0.2, 0.4]  # x, y, yaw: the platform is turned in the image
UAV_OFFSET = (-0.18, 0.2)  # m, UAV from the platform centre: the platform is off the image centre


def _fly_over_platform(world: World, height: float, sensors: dict | None = None):
    """Summit XL and an AR.Drone 2 hovering ``height`` m above its platform, offset by ``UAV_OFFSET``."""
    ugv = world.add_robot("summit_xl", pose=UGV_POSE)
    p_platform, _ = ugv.platform_pose()
    pose = [p_platform[0] + UAV_OFFSET[0], p_platform[1] + UAV_OFFSET[1], p_platform[2] + height, 0.0]
    uav = world.add_robot("ardrone2", pose=pose, sensors={"sonar": {"noise_std": 0.0}, **(sensors or {})})
    return ugv, uav


def _camera_height(uav, frame) -> float:
    """Z of eq. (3): the sonar range carried from the sonar to the camera's optical centre (m)."""
    sonar = uav.sensor("sonar").read().data.range
    z_sonar = uav.pose()[0][2] + ARDRONE2.sonar.offset[2]
    return sonar + z_sonar - frame.position[2]


def _projected(frame, p_world: np.ndarray) -> np.ndarray:
    p_camera = frame.rotation.T @ (p_world - frame.position)
    return (frame.K @ (p_camera / p_camera[2]))[:2]


@pytest.mark.parametrize("height", [1.0, 2.0, 3.0, 4.0])
def test_centroid_within_2_px_of_the_platform_centre(height):
    with World(scene="open_field", noise_scale=0.0) as world:  # geometry: perfect sensors
        ugv, uav = _fly_over_platform(world, height)
        frame = uav.sensor("bottom_camera").read().data
        Z = _camera_height(uav, frame)
        p_platform, _ = ugv.platform_pose()
        expected = _projected(frame, p_platform)
        params = DetectionParams(platform_side_m=ugv.platform_size[0])
        detection = detect_platform(frame.rgb, frame.K, Z, tilt_of(uav.pose()[1]), params)
        assert detection is not None
        assert np.linalg.norm(detection.centroid_px - expected) < 2.0
        # the 1 m platform fills 330 px at 1 m: cut by the border, completed from its seen sides
        assert detection.truncated == (height <= 2.0)
        assert len(detection.lines) >= 2 and len(detection.polygon) == 4
        # inverse pinhole (eq. 3) and P_world = T_world_cam P_cam (§3.3.2)
        assert detection.position_camera[2] == pytest.approx(Z)
        p_world = detection.position_in(frame.rotation, frame.position)
        assert p_world[:2] == pytest.approx(p_platform[:2], abs=0.01)
        if not detection.truncated:  # in full view the paper's pipeline needs no platform size
            paper = detect_platform(frame.rgb, frame.K, Z, 0.0)
            assert np.linalg.norm(paper.centroid_px - expected) < 2.0
            assert paper.area_px == pytest.approx((ugv.platform_size[0] * frame.K[0, 0] / Z) ** 2, rel=0.05)


def test_noisy_frame_at_tracking_height():
    with World(scene="open_field") as world:  # default realism (exposure, drops, latency off), twice the pixel noise
        camera = {"noise_std": 6.0, "latency_s": 0.0, "dropout": 0.0}
        ugv, uav = _fly_over_platform(world, 4.0, sensors={"bottom_camera": camera})
        frame = uav.sensor("bottom_camera").read().data
        detection = detect_platform(frame.rgb, frame.K, _camera_height(uav, frame), 0.0)
        assert np.linalg.norm(detection.centroid_px - _projected(frame, ugv.platform_pose()[0])) < 2.0


def test_no_platform_in_view():
    with World(scene="open_field", noise_scale=0.0) as world:  # geometry: perfect sensors
        world.add_robot("summit_xl", pose=UGV_POSE)
        uav = world.add_robot("ardrone2", pose=[8.0, 5.0, 4.0, 0.0])
        frame = uav.sensor("bottom_camera").read().data
        assert detect_platform(frame.rgb, frame.K, 4.0, 0.0) is None
        assert detect_platform(np.zeros((240, 320, 3), np.uint8), frame.K, 4.0, 0.0) is None


def test_frame_discarded_when_tilted_beyond_the_threshold():
    params = DetectionParams()
    assert math.degrees(params.max_tilt) == pytest.approx(10.0, abs=0.05)  # |q_x|, |q_y| < π/36
    with World(scene="open_field", noise_scale=0.0) as world:  # geometry: perfect sensors
        _, uav = _fly_over_platform(world, 4.0)
        p_uav, _ = uav.pose()
        roll = math.radians(12.0)
        pybullet.resetBasePositionAndOrientation(
            uav.body_id, p_uav, pybullet.getQuaternionFromEuler([roll, 0.0, 0.0]), physicsClientId=world.client_id
        )
        frame = uav.sensor("bottom_camera").read().data
        tilt = tilt_of(pybullet.getQuaternionFromEuler([roll, 0.0, 0.0]))  # what a settled attitude filter reports
        assert tilt == pytest.approx(roll, abs=1e-6)
        assert detect_platform(frame.rgb, frame.K, 4.0, tilt, params) is None
        assert detect_platform(frame.rgb, frame.K, 4.0, 0.0, params) is not None  # the platform is in view
        assert detect_platform(frame.rgb, frame.K, math.inf, 0.0, params) is None  # no sonar echo


def test_bad_input_and_parameters():
    K = np.array([[320.0, 0.0, 159.5], [0.0, 320.0, 119.5], [0.0, 0.0, 1.0]])
    with pytest.raises(ValueError, match=r"\(h, w, 3\) uint8"):
        detect_platform(np.zeros((240, 320), np.uint8), K, 4.0, 0.0)
    with pytest.raises(ValueError, match="blur_ksize"):
        DetectionParams(blur_ksize=4)
    with pytest.raises(ValueError, match="platform_side_m"):
        DetectionParams(platform_side_m=0.0)
