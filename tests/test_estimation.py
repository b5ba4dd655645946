"""Onboard estimation and sensor realism: the quadrotors' flight estimator and the autopilot flying on it,
wheel odometry and map localisation, arm encoders, noise_scale, camera latency, seeds."""

import math

import numpy as np
import pybullet
import pytest

from marsupial.tools.rig import live_view
from marsupial.world import World
from marsupial.world.sensors.imu import quat_yaw


def _error(robot):
    """Horizontal distance (m) between the estimate and the true base (footprint for ground robots)."""
    estimate = robot.estimator.estimate().position
    truth = robot.footprint_pose()[0] if hasattr(robot, "footprint_pose") else robot.pose()[0]
    return float(np.hypot(*(estimate - truth)[:2]))


def _hover_errors(seed, noise_scale, checkpoints=(10.0, 60.0)):
    with World(seed=seed, noise_scale=noise_scale) as world:
        uav = world.add_robot("bebop2", pose=[0.0, 0.0, 1.5, 0.3])
        errors = []
        for t in checkpoints:
            world.step(t - world.now)
            errors.append(_error(uav))
        return errors


# ----------------------------------------------------------- flight estimator
@pytest.mark.slow
def test_flight_estimate_drifts_with_time_at_default_sensing_and_not_at_noise_scale_0():
    errors = np.array([_hover_errors(seed, 1.0) for seed in range(3)])
    assert errors[:, 1].mean() > errors[:, 0].mean()  # dead reckoning: the error grows
    assert errors[:, 1].max() > 0.02  # and it is a real drift
    assert errors[:, 1].max() < 0.5  # of the order of an optical-flow drone's hover drift (docs/world.md)
    exact = np.array([_hover_errors(seed, 0.0) for seed in range(2)])
    assert exact.max() < 1e-3


def test_autopilot_holds_the_estimate_while_the_truth_drifts():
    with World(seed=2) as world:
        uav = world.add_robot("bebop2", pose=[1.0, 0.0, 1.5, 0.0])
        start = uav.pose()[0]
        estimates, truths = [], []
        for _ in range(60):
            world.step(1.0)
            estimates.append(uav.estimator.estimate().position)
            truths.append(uav.pose()[0])
        held = np.linalg.norm(np.array(estimates) - start, axis=1).max()
        drift = np.linalg.norm((np.array(truths) - start)[:, :2], axis=1).max()
        assert held < 0.03 and drift > 2 * held  # the estimate holds (flow noise: ±2-3 cm), the truth drifts


def test_world_commands_fly_in_the_estimate_frame_and_reset_estimate_restarts_it():
    with World(noise_scale=0.0) as world:  # exact sensing: only the reset separates estimate and truth
        uav = world.add_robot("bebop2", pose=[0.0, 0.0, 1.5, 0.0])
        port = live_view(uav.world, uav.name)
        world.step(0.5)
        # the carrier hands over a pose 2 m off and turned by +90°: odom x is then the true -y
        port.reset_estimate([2.0, 0.0, 1.5], math.pi / 2)
        estimate = port.estimate()
        assert estimate.position == pytest.approx([2.0, 0.0, 1.5]) and estimate.yaw == pytest.approx(math.pi / 2)
        assert estimate.frame == "odom" and np.allclose(estimate.velocity, 0.0)
        world.step(1.0)
        assert np.linalg.norm(uav.pose()[0] - [0.0, 0.0, 1.5]) < 0.01  # the autopilot holds the new estimate
        port.command_velocity(1.0, 0.0, 0.0, frame="world")
        world.step(2.0)
        p = uav.pose()[0]
        assert p[1] < -1.0 and abs(p[0]) < 0.05  # flew along odom +x = true -y
        assert port.estimate().position[0] > 3.0


def test_estimate_starts_at_the_spawn_pose_and_holds_with_the_motors_off():
    with World(seed=1) as world:
        uav = world.add_robot("tello", pose=[1.0, 2.0, 0.7])  # [x, y, yaw] on the floor: motors off
        estimate = uav.estimator.estimate()
        assert estimate.position == pytest.approx(uav.pose()[0], abs=1e-9)
        assert estimate.yaw == pytest.approx(0.7, abs=0.01)  # the IMU's attitude error only
        world.step(20.0)
        later = uav.estimator.estimate()
        assert later.position == pytest.approx(estimate.position) and np.allclose(later.velocity, 0.0)


def test_a_stored_uav_starts_its_estimate_on_the_dock_and_holds_it_while_carried():
    with World(seed=0) as world:
        carrier = world.add_robot("mobile_manipulator", pose=[0.0, 0.0, 0.0])
        uav = world.add_robot("bebop2", pose=[3.0, 3.0, 0.0])
        carrier.store(uav)  # set-up: the run starts with the UAV locked on Part A
        stored = uav.estimator.estimate()
        assert stored.position == pytest.approx(uav.pose()[0], abs=1e-6)
        carrier.drive(1.0, 0.0)
        world.step(3.0)
        assert uav.docked and uav.pose()[0][0] > stored.position[0] + 2.0  # carried 2+ m
        assert uav.estimator.estimate().position == pytest.approx(stored.position)  # held until a hand-over


def test_sonar_echoes_off_an_obstacle_below_do_not_move_the_height():
    with World(seed=4) as world:
        cid = world.client_id
        box = pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=[0.5, 0.5, 0.2], physicsClientId=cid)
        pybullet.createMultiBody(0.0, box, -1, [2.5, 0.0, 0.2], physicsClientId=cid)  # a 0.4 m platform
        uav = world.add_robot("ardrone2", pose=[0.0, 0.0, 1.0, 0.0])
        world.step(1.0)
        uav.command_velocity(1.0, 0.0, 0.0)
        heights = []
        for _ in range(50):
            world.step(0.1)
            heights.append((uav.pose()[0][2], uav.estimator.estimate().position[2]))
        true_z, est_z = np.array(heights).T
        # no jump when the echo comes off the platform (it would be 0.4 m): over it the barometer holds the
        # height, within a few cm
        assert np.abs(est_z - true_z).max() < 0.1
        assert np.abs(true_z - 1.0).max() < 0.1


def test_optical_flow_measures_the_velocity_over_the_surface_below():
    with World(noise_scale=0.0) as world:
        ugv = world.add_robot("summit_xl", pose=[0.0, 0.0, 0.0])
        uav = world.add_robot("ardrone2", pose=[0.0, 0.0, 1.5, 0.0])
        flow = uav.sensor("flow")
        ugv.drive(0.5, 0.0)
        world.step(2.0)
        reading = flow.read().data
        assert reading.valid and reading.range == pytest.approx(1.5 - 0.032 - 0.4, abs=0.05)  # over the platform
        assert reading.vx == pytest.approx(uav.velocity()[0][0] - ugv.velocity()[0][0], abs=0.02)


def test_a_drone_low_over_a_moving_platform_rides_along_and_believes_it_is_still():
    """The flow is relative to what fills the view: far above, the floor; just above, the platform."""
    moved = {}
    for height in (4.0, 1.2):
        with World(seed=1) as world:
            ugv = world.add_robot("summit_xl", pose=[0.0, 0.0, 0.0])
            uav = world.add_robot("ardrone2", pose=[0.0, 0.0, height, 0.0])
            ugv.drive(0.5, 0.0)
            world.step(4.0)
            moved[height] = (uav.pose()[0][0], uav.estimator.estimate().position[0], ugv.pose()[0][0])
    assert abs(moved[4.0][0]) < 0.2  # holds over the floor
    true_x, estimated_x, platform_x = moved[1.2]
    assert true_x > 0.8 * platform_x and abs(estimated_x) < 0.2  # carried along, unaware


# ----------------------------------------------------------- ground robots
def _odometry_error(seed, distance, noise_scale=1.0, kind="mobile_manipulator"):
    with World(seed=seed, noise_scale=noise_scale) as world:
        robot = world.add_robot(kind, pose=[0.0, 0.0, 0.0])
        robot.drive(1.0, 0.05)
        world.step(distance)  # ≈ 1 m/s
        return _error(robot)


@pytest.mark.slow
def test_wheel_odometry_drift_grows_with_distance():
    short = np.mean([_odometry_error(seed, 3.0) for seed in range(3)])
    long = np.mean([_odometry_error(seed, 24.0) for seed in range(3)])
    assert long > 2 * short and long > 0.05
    assert _odometry_error(0, 24.0, noise_scale=0.0) < 0.05  # left: the body's lag behind its drive reference
    skid = np.mean([_odometry_error(seed, 24.0, kind="summit_xl") for seed in range(3)])
    assert skid > long  # skid-steer odometry is worse


def test_wheel_speed_is_measured_and_the_odometry_frame_is_odom():
    with World(seed=0) as world:
        ugv = world.add_robot("mobile_manipulator", pose=[0.0, 0.0, 0.0])
        ugv.drive(0.8, 0.0)
        world.step(2.0)
        encoders = live_view(ugv.world, ugv.name).speed()
        assert encoders == pytest.approx(0.8, rel=0.05) and encoders != ugv.speed()
        assert ugv.estimator.estimate().frame == "odom" and ugv.estimator.estimate().source == "wheel_odometry"
        ugv.stop()
        world.step(2.0)
        parked = ugv.estimator.estimate()
        world.step(10.0)
        assert np.array_equal(ugv.estimator.estimate().position, parked.position)  # standing wheels: no drift
        assert ugv.wheel_speed() == 0.0


def test_map_localisation_error_stays_bounded_while_odometry_drifts():
    with World(seed=3) as world:
        mapped = world.add_robot("summit_xl", "mapped", pose=[0.0, 0.0, 0.0], localization="map")
        assert mapped.estimator.estimate().frame == "map"
        mapped.drive(1.0, 0.1)
        map_errors, odom_errors = [], []
        for _ in range(60):
            world.step(1.0)
            map_errors.append(_error(mapped))
            p, _ = mapped.footprint_pose()
            odom_errors.append(float(np.hypot(*(mapped.odometry.estimate().position - p)[:2])))
        assert max(map_errors) < 0.25  # σ 0.05 m per axis (+ odometry between 5 Hz fixes)
        assert np.mean(map_errors) > 0.01  # not the truth
        assert odom_errors[-1] > max(map_errors)
    with pytest.raises(ValueError, match="localization"):
        World().add_robot("summit_xl", localization="gps")


# ----------------------------------------------------------- arms
def test_arm_encoders_are_quantised_and_exact_at_noise_scale_0():
    with World(seed=0) as world:
        mm = world.add_robot("mobile_manipulator", arm_pose="docking_ready")
        q = mm.arm_encoders()
        count = 2 * math.pi / 4096
        assert np.allclose(q / count, np.round(q / count), atol=1e-9)
        assert np.abs(q - mm.joint_positions()).max() < 3 * count
    with World(noise_scale=0.0) as world:
        mm = world.add_robot("mobile_manipulator", arm_pose="docking_ready")
        assert np.array_equal(mm.arm_encoders(), mm.joint_positions())


# ----------------------------------------------------------- noise scale, cameras, seeds
def test_noise_scale_multiplies_the_nominal_figures_after_the_overrides():
    with World(noise_scale=2.0) as world:
        uav = world.add_robot("bebop2", pose=[0, 0, 1, 0], sensors={"sonar": {"noise_std": 0.03}})
        sonar, camera = uav.sensor("sonar"), uav.sensor("front_camera")
        assert sonar.nominal.noise_std == 0.03 and sonar.config.noise_std == pytest.approx(0.06)
        assert sonar.config.dropout == pytest.approx(0.04) and camera.config.latency_s == pytest.approx(0.2)
        assert uav.sensor("imu").gyro_noise_std == pytest.approx(0.01)
    with World(noise_scale=100.0) as world:
        assert world.add_robot("bebop2", pose=[0, 0, 1, 0]).sensor("sonar").config.dropout == 1.0


def test_noise_scale_0_gives_exact_sensors():
    with World(noise_scale=0.0) as world:
        mm = world.add_robot("mobile_manipulator", pose=[0.0, 0.0, 0.0])
        uav = world.add_robot("ardrone2", pose=[0.0, 2.0, 1.2, 0.5])
        world.step(0.5)
        p, q = uav.pose()
        imu = uav.sensor("imu").read().data
        R = np.array(pybullet.getMatrixFromQuaternion(q)).reshape(3, 3)
        assert np.allclose(imu.orientation, q) and np.allclose(imu.angular_velocity, R.T @ uav.velocity()[1])
        assert uav.sensor("barometer").read().data == pytest.approx(p[2])
        assert uav.sensor("sonar").read().data.range == pytest.approx(p[2] - 0.032, abs=0.005)
        assert uav.sensor("flow").read().data.vx == pytest.approx(0.0, abs=1e-6)
        camera = uav.sensor("bottom_camera")
        assert camera.config.latency_s == 0.0 and camera.white_balance == (1.0, 1.0, 1.0)
        assert mm.lidar.beam_dropout == 0.0 and mm.lidar.config.noise_std == 0.0
        assert quat_yaw(tuple(uav.estimator.estimate().orientation)) == pytest.approx(0.5)


def test_ardrone2_bottom_camera_is_0_1_s_late_and_plain_rgb():
    with World(seed=0) as world:
        uav = world.add_robot("ardrone2", pose=[0.0, 0.0, 2.0, 0.0])
        port = live_view(uav.world, uav.name).sensor("bottom_camera")
        ages = []
        for _ in range(60):
            world.step(1.0 / 30.0)
            reading = port.read()
            if reading is not None:
                ages.append(world.now - reading.stamp)
        assert min(ages) == pytest.approx(0.1, abs=1e-6)  # the freshest frame is 0.1 s old
        assert reading.data.depth is None and not uav.sensor("bottom_camera").measures_depth
        assert uav.sensor("bottom_camera").config.dropout == 0.02  # Wi-Fi video loses frames


def test_the_onboard_lidar_scan_carries_no_pose_and_no_body_ids():
    with World(seed=0) as world:
        mm = world.add_robot("mobile_manipulator")
        scan = live_view(mm.world, mm.name).sensor("lidar").read().data
        assert not hasattr(scan, "position") and not hasattr(scan, "hit_bodies")
        assert scan.ranges.shape == scan.angles.shape == (541,) and scan.max_range == 20.0


def test_one_seed_is_deterministic_and_two_seeds_differ():
    def flight(seed):
        with World(seed=seed) as world:
            uav = world.add_robot("bebop2", pose=[0.0, 0.0, 1.0, 0.0])
            ugv = world.add_robot("mobile_manipulator", pose=[3.0, 0.0, 0.0])
            uav.command_velocity(1.0, 0.5, 0.0, 0.2)
            ugv.drive(0.5, 0.1)
            world.step(3.0)
            return (
                uav.pose()[0],
                uav.estimator.estimate().position,
                ugv.estimator.estimate().position,
                ugv.arm_encoders(),
            )

    a, b, c = flight(7), flight(7), flight(8)
    for x, y in zip(a, b, strict=True):
        assert np.array_equal(x, y)
    assert not np.allclose(a[1], c[1], atol=1e-4) and not np.allclose(a[2], c[2], atol=1e-4)
