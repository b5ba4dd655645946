"""Quadrotors: position hold, velocity commands within the SDK limits, attitude lag, wind,
docking hand-over, flight sensors and the Bebop 2's AprilTag bundle seen from below."""

import math

import cv2
import numpy as np
import pybullet
import pytest

from marsupial.api.errors import UnknownNameError, WorldError
from marsupial.api.model import Intrinsics
from marsupial.api.tags import load_tag_bundle
from marsupial.world import World
from marsupial.world.robots.base import Robot
from marsupial.world.sensors.base import SensorConfig
from marsupial.world.sensors.camera import OPTICAL_UP, Camera

STEP = 1.0 / 240


class SteadyWind:
    """Uniform, constant air velocity (m/s, world frame)."""

    def __init__(self, velocity):
        self.v = np.asarray(velocity, dtype=float)

    def velocity(self, t, position):
        return self.v


class GustyWind:
    """A new random gust every 0.5 s, drawn from the world's seeded stream."""

    def __init__(self, world):
        self.rng = world.rng_for("test/wind")
        self.t_next, self.v = 0.0, np.zeros(3)

    def velocity(self, t, position):
        if t >= self.t_next:
            self.t_next = t + 0.5
            self.v = self.rng.normal(0.0, 1.5, 3) * [1, 1, 0.2]
        return self.v


class Post(Robot):
    """A fixed, visual-only post (for cameras looking at a drone)."""

    kind = "post"

    def __init__(self, world, name, position, yaw=0.0):
        super().__init__(world, name)
        cid = world.client_id
        shape = pybullet.createVisualShape(pybullet.GEOM_BOX, halfExtents=[0.02] * 3, physicsClientId=cid)
        orientation = [0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)]
        self.body_id = pybullet.createMultiBody(0.0, -1, shape, position, orientation, physicsClientId=cid)
        self.links = {"base": -1}

    def safe_stop(self):
        pass


def _pitch(q):
    x, y, z, w = q
    return math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))


def _trace(world, uav, seconds):
    """Per-step (position, velocity, pitch) over ``seconds``."""
    ps, vs, pitch = [], [], []
    for _ in range(world.clock.steps_for(seconds)):
        world.step()
        p, q = uav.pose()
        ps.append(p)
        vs.append(uav.velocity()[0])
        pitch.append(_pitch(q))
    return np.array(ps), np.array(vs), np.array(pitch)


def test_bebop2_holds_its_estimate_within_3cm_and_drifts_boundedly_for_30s():
    """The position hold runs on the onboard estimate: the estimate holds, the truth drifts (optical-flow
    dead reckoning); at perfect sensing the truth holds too."""
    for noise_scale, true_bound in ((1.0, 0.25), (0.0, 0.02)):
        with World(noise_scale=noise_scale) as world:
            uav = world.add_robot("bebop2", pose=[1.0, -2.0, 1.5, 0.7])
            assert uav.motors_on and uav.mass == pytest.approx(0.5)
            start = uav.pose()[0]
            estimates = []
            for _ in range(30):
                world.step(1.0)
                estimates.append(uav.estimator.estimate().position)
            assert np.linalg.norm(np.array(estimates) - start, axis=1).max() < 0.03
            assert np.linalg.norm(uav.pose()[0] - start) < true_bound


def test_velocity_step_in_body_frame_reaches_speed_and_tilts_with_lag():
    with World(noise_scale=0.0) as world:  # flight dynamics / geometry: perfect sensing
        uav = world.add_robot("bebop2", pose=[0.0, 0.0, 1.0, math.pi / 2])  # heading +y
        world.step(0.5)
        uav.command_velocity(2.0, 0.0, 0.5)
        _, vs, _ = _trace(world, uav, 3.0)
        k = round(1.5 / STEP) - 1
        assert vs[k, 1] == pytest.approx(2.0, abs=0.1)  # body x = world +y
        assert vs[k, 2] == pytest.approx(0.5, abs=0.05)
        assert abs(vs[:, 0]).max() < 0.05
        assert vs[:, 1].max() < 2.0 * 1.02  # no overshoot to speak of
        assert vs[-1] == pytest.approx([0.0, 2.0, 0.5], abs=0.02)
        body_z = pybullet.getMatrixFromQuaternion(uav.pose()[1])[2::3]
        assert body_z[1] > math.sin(math.radians(2))  # cruising leans forward (+y) against the drag


def test_acceleration_tilts_the_body_after_an_attitude_lag():
    with World(noise_scale=0.0) as world:  # flight dynamics / geometry: perfect sensing
        uav = world.add_robot("bebop2", pose=[0.0, 0.0, 1.0, 0.0])
        uav.command_velocity(3.0, 0.0, 0.0)
        _, vs, pitch = _trace(world, uav, 1.0)
        peak = pitch.max()
        assert peak > math.radians(10)  # nose down to accelerate forward
        t63 = (np.argmax(pitch > 0.63 * peak) + 1) * STEP
        assert 0.08 < t63 < 0.4  # first-order-like lag of the attitude loop
        assert pitch[round(0.05 / STEP)] < 0.5 * peak


def test_commands_are_clipped_to_the_sdk_limits():
    with World(noise_scale=0.0) as world:  # flight dynamics / geometry: perfect sensing
        uav = world.add_robot("bebop2", pose=[0.0, 0.0, 1.0, 0.0])
        uav.command_velocity(10.0, 0.0, 10.0, frame="world")
        _, vs, _ = _trace(world, uav, 4.0)
        lateral = np.hypot(vs[:, 0], vs[:, 1])
        assert lateral.max() <= 4.0 * 1.01  # §V-A: 4 m/s lateral
        assert vs[:, 2].max() <= 1.0 * 1.01  # §V-A: 1 m/s vertical
        assert lateral[-1] == pytest.approx(4.0, abs=0.03)
        assert vs[-1, 2] == pytest.approx(1.0, abs=0.02)
        with pytest.raises(ValueError, match="frame must be one of"):
            uav.command_velocity(1, 0, 0, frame="map")


def test_hover_stops_and_holds_and_yaw_rate_turns():
    with World(noise_scale=0.0) as world:  # flight dynamics / geometry: perfect sensing
        uav = world.add_robot("ardrone2", pose=[0.0, 0.0, 2.0, 0.0])
        uav.command_velocity(1.0, 0.0, 0.0, yaw_rate=0.5)
        world.step(2.0)
        yaw0 = math.atan2(*reversed(pybullet.getMatrixFromQuaternion(uav.pose()[1])[0:4:3]))
        world.step(1.0)
        yaw1 = math.atan2(*reversed(pybullet.getMatrixFromQuaternion(uav.pose()[1])[0:4:3]))
        assert (yaw1 - yaw0) == pytest.approx(0.5, abs=0.03)
        uav.safe_stop()
        world.step(3.0)
        stop = uav.pose()[0]
        world.step(5.0)
        assert np.linalg.norm(uav.pose()[0] - stop) < 0.02
        assert np.linalg.norm(uav.velocity()[0]) < 0.01


def test_steady_wind_pushes_and_the_integral_action_holds_the_reference():
    with World(noise_scale=0.0) as world:  # flight dynamics / geometry: perfect sensing
        uav = world.add_robot("bebop2", pose=[0.0, 0.0, 1.5, 0.0])
        world.wind = SteadyWind([2.0, 0.0, 0.0])
        ref = uav.reference()[0]
        ps, _, pitch = _trace(world, uav, 20.0)
        err = np.linalg.norm(ps - ref, axis=1)
        assert 0.02 < err.max() < 0.3  # pushed downwind, bounded
        assert err[-240:].max() < 0.01  # integral action removes the offset
        assert pitch[-1] < -math.radians(2)  # leans into the wind (thrust toward -x)


def test_motors_off_falls_and_motors_on_takes_off_from_the_floor():
    with World() as world:
        uav = world.add_robot("tello", pose=[0.0, 0.0, 0.0])  # standing on the floor: motors off
        assert not uav.motors_on
        world.step(1.0)
        assert uav.pose()[0][2] == pytest.approx(0.0215, abs=0.003)
        uav.set_motors(True)
        uav.command_velocity(0.0, 0.0, 0.5)
        world.step(2.0)
        uav.hover()
        world.step(1.0)
        assert uav.pose()[0][2] > 0.8
        uav.set_motors(False)
        world.step()
        assert uav.power == 0.0 and uav.battery.current_A == 0.0
        world.step(1.0)
        assert uav.pose()[0][2] < 0.05


def test_docking_hand_over_holds_charges_and_releases_into_hover():
    with World(noise_scale=0.0) as world:  # the hand-over mechanics; drift is tested in test_estimation.py
        uav = world.add_robot("bebop2", pose=[0.0, 0.0, 1.2, 0.0], battery_soc=0.5)
        cid = world.client_id
        world.step(0.5)
        p, q = uav.pose()
        # the docking device: a rigid attachment to the world, then the hand-over call
        constraint = pybullet.createConstraint(
            uav.body_id, -1, -1, -1, pybullet.JOINT_FIXED, [0, 0, 0], [0, 0, 0], p,
            childFrameOrientation=q, physicsClientId=cid,
        )
        uav.on_docked(charger=True)
        assert uav.docked and uav.charging and not uav.motors_on
        world.step(60.0)
        assert np.linalg.norm(uav.pose()[0] - p) < 1e-3  # does not fight the attachment
        assert uav.battery.current_A == pytest.approx(-3.5)  # §V-A charger: 3.5 A
        assert uav.battery.charged_mAh == pytest.approx(3.5 * 60 / 3.6, rel=1e-3)
        assert uav.sensor("battery").read().data.current == pytest.approx(-3.5)
        uav.set_motors(True)  # arm before the release
        pybullet.removeConstraint(constraint, physicsClientId=cid)
        uav.on_released()
        released = uav.pose()[0]
        world.step(3.0)
        assert not uav.docked and uav.motors_on
        assert np.linalg.norm(uav.pose()[0] - released) < 0.02
        assert uav.battery.current_A > 5.0  # flying again


def test_same_seed_same_flight_other_seed_other_flight():
    def flight(seed):
        with World(seed=seed) as world:
            uav = world.add_robot("bebop2", pose=[0.0, 0.0, 1.0, 0.0])
            world.wind = GustyWind(world)
            uav.command_velocity(1.0, 0.5, 0.2, 0.3)
            ps, _, _ = _trace(world, uav, 3.0)
            return ps, uav.sensor("sonar").read().data.range, uav.sensor("imu").read().data.linear_acceleration

    a, b, c = flight(5), flight(5), flight(6)
    assert np.array_equal(a[0], b[0]) and a[1] == b[1] and np.array_equal(a[2], b[2])
    assert not np.allclose(a[0], c[0], atol=1e-3)


def test_flight_sensors_read_height_gravity_and_altitude():
    with World() as world:
        uav = world.add_robot("bebop2", pose=[0.0, 0.0, 1.2, 0.0], sensors={"sonar": {"noise_std": 0.01}})
        world.step(1.0)
        sonar = uav.sensor("sonar")
        assert sonar.config.noise_std == 0.01
        ranges = []
        for _ in range(20):
            world.step(0.04)
            ranges.append(sonar.read().data.range)
        height = uav.pose()[0][2]
        assert np.mean(ranges) == pytest.approx(height - 0.036, abs=0.01)  # sonar 3.6 cm under the base
        assert np.std(ranges) == pytest.approx(0.01, abs=0.006)
        reading = sonar.read().data
        assert reading.half_angle == pytest.approx(math.radians(15)) and reading.max_range == 5.0
        imu = uav.sensor("imu").read().data
        assert imu.linear_acceleration == pytest.approx([0.0, 0.0, 9.81], abs=0.2)
        R = np.array(pybullet.getMatrixFromQuaternion(uav.pose()[1])).reshape(3, 3)
        assert imu.angular_velocity == pytest.approx(R.T @ uav.velocity()[1], abs=0.03)
        assert uav.sensor("barometer").read().data == pytest.approx(1.2, abs=0.4)
        # an obstacle under the drone shortens the range; nothing within 5 m reads inf
        cid = world.client_id
        box = pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=[0.3, 0.3, 0.25], physicsClientId=cid)
        pybullet.createMultiBody(0.0, box, -1, [0, 0, 0.25], physicsClientId=cid)
        world.step(0.05)
        assert sonar.read().data.range == pytest.approx(uav.pose()[0][2] - 0.036 - 0.5, abs=0.05)
        uav.command_velocity(0.0, 0.0, 1.0)
        world.step(5.0)
        assert sonar.read().data.range == math.inf


def test_sensor_overrides_are_checked():
    with World() as world, pytest.raises(UnknownNameError, match="sonr"):
        world.add_robot("bebop2", pose=[0, 0, 1, 0], sensors={"sonr": {"noise_std": 0.1}})
    with World() as world, pytest.raises(ValueError, match="unknown sensor setting"):
        world.add_robot("bebop2", pose=[0, 0, 1, 0], sensors={"sonar": {"noise": 0.1}})


def test_ardrone2_bottom_camera_sees_a_red_platform_below():
    with World() as world:
        cid = world.client_id
        pad = pybullet.createVisualShape(
            pybullet.GEOM_BOX, halfExtents=[0.3, 0.3, 0.05], rgbaColor=[0.9, 0.1, 0.1, 1], physicsClientId=cid
        )
        pybullet.createMultiBody(0.0, -1, pad, [0.5, 0.0, 0.05], physicsClientId=cid)
        uav = world.add_robot("ardrone2", pose=[0.0, 0.0, 2.0, 0.0])
        camera = uav.sensor("bottom_camera")
        assert camera.read() is None  # the first frame is taken now and arrives 0.1 s late
        reading = None
        while reading is None:  # (a frame may be lost)
            world.step(1.0 / 30.0)
            reading = camera.read()
        assert world.now - reading.stamp == pytest.approx(0.1, abs=0.01)
        frame = reading.data
        assert frame.rgb.shape == (240, 320, 3)
        assert frame.K[1, 1] == pytest.approx(120 / math.tan(math.radians(41.1) / 2), rel=0.01)  # 64° diagonal QVGA
        # the pad is ahead of the drone (+x), which is image up for the downward camera
        red = (frame.rgb[..., 0] > 150) & (frame.rgb[..., 1] < 80)
        rows = np.nonzero(red.any(axis=1))[0]
        assert red.sum() > 1000 and rows.mean() < 120


def test_tag_bundle_layout_matches_the_urdf_links():
    bundle = load_tag_bundle()
    assert bundle.family == "tag36h11" and bundle.ids == [0, 1, 2, 3, 4]  # 4: the 2.4 cm contact tag
    assert bundle.object_points([2, 0]).shape == (8, 3)
    with World() as world:
        uav = world.add_robot("bebop2", pose=[0, 0, 1, 0.4])
        p_base, q_base = uav.pose()
        p_tag, q_tag = uav.link_pose(bundle.link)
        assert np.allclose(p_tag, p_base) and np.allclose(q_tag, q_base)  # corners are base-frame corners
        p_b = uav.link_pose("part_b")[0]
        assert 0.04 < p_base[2] - p_b[2] < 0.09  # adapter hangs below the front of the body
    with pytest.raises(UnknownNameError):
        bundle.tag(7)
    with pytest.raises(WorldError, match="bad tag bundle layout"):
        load_tag_bundle("bebop2.urdf")


@pytest.mark.parametrize("distance, yaw", [(0.5, 0.4), (1.5, -1.2)])
def test_tag_bundle_is_detected_unmirrored_from_below(distance, yaw):
    bundle = load_tag_bundle()
    with World(noise_scale=0.0) as world:  # flight dynamics / geometry: perfect sensing
        uav = world.add_robot("bebop2", pose=[0.0, 0.0, 2.5, 0.3])
        world.step(0.2)
        p_uav = uav.pose()[0]
        post = Post(world, "post", [p_uav[0] + 0.05, p_uav[1] - 0.03, p_uav[2] + bundle.plate_z - distance], yaw)
        camera = Camera(post, "eye", Intrinsics(640, 480, 60.0), SensorConfig(rate_hz=30.0), R_link_optical=OPTICAL_UP)
        frame = camera.read().data
        gray = cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2GRAY)
        dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, bundle.aruco_dictionary))
        detector = cv2.aruco.ArucoDetector(dictionary, cv2.aruco.DetectorParameters())
        corners, ids, _ = detector.detectMarkers(gray)
        assert ids is not None and 0 in ids.ravel()
        p_link, q_link = uav.link_pose(bundle.link)
        R_world_link = np.array(pybullet.getMatrixFromQuaternion(q_link)).reshape(3, 3)
        for image_corners, tag_id in zip(corners, ids.ravel(), strict=True):
            p_world = bundle.tag(int(tag_id)).corners @ R_world_link.T + p_link
            p_cam = (p_world - frame.position) @ frame.rotation
            uv = p_cam @ frame.K.T
            uv = uv[:, :2] / uv[:, 2:]
            assert np.abs(uv - image_corners[0]).max() < 2.5  # same ids, same corner order, not mirrored
        # and the bundle gives the drone's pose back through solvePnP
        points = bundle.object_points(ids.ravel())
        pixels = np.concatenate(corners).reshape(-1, 2)
        ok, rvec, tvec = cv2.solvePnP(points, pixels, frame.K, None, flags=cv2.SOLVEPNP_SQPNP)
        R_cam_link = cv2.Rodrigues(rvec)[0]
        p_est = frame.rotation @ tvec.ravel() + frame.position
        # 3 % of the range: at 1.5 m only the 10.4 cm tag is resolved (it gave plate room to the contact tag)
        assert ok and np.linalg.norm(p_est - p_link) < 0.03 * distance + 0.005
        R_err = (frame.rotation @ R_cam_link).T @ R_world_link
        angle = math.acos(min(1.0, (np.trace(R_err) - 1) / 2))
        assert angle < 0.02 + 0.12 * distance  # a small planar target: its tilt blurs with range
