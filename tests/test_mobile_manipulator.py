"""Mobile manipulator of Narváez et al.: base limits, arm PID at 15 rpm, payload, pinocchio model, poses."""

import math

import numpy as np
import pybullet
import pytest

from marsupial.api.errors import UnknownNameError
from marsupial.api.kinematics import ArmKinematics
from marsupial.world import World
from marsupial.world.robots.mobile_manipulator import (
    ARM_JOINTS,
    ARM_POSES,
    JOINT_SPEED_LIMIT,
    MobileManipulator,
)


def _rotation(q):
    return np.array(pybullet.getMatrixFromQuaternion(q)).reshape(3, 3)


def _relative(robot, frame, link):
    """Pose of ``link`` in ``frame`` as pybullet computes it (link frames, not COM frames)."""
    p_f, q_f = robot.link_pose(frame)
    p_l, q_l = robot.link_pose(link)
    R_f = _rotation(q_f)
    return R_f.T @ (p_l - p_f), R_f.T @ _rotation(q_l)


@pytest.fixture
def world():
    with World(seed=1) as w:
        yield w


def test_base_drives_at_commanded_speed_and_is_clamped_at_2_m_s(world):
    mm = world.add_robot("mobile_manipulator", pose=[0, 0, 0])
    mm.drive(0.8, 0.0)
    world.step(2.0)
    assert mm.speed() == pytest.approx(0.8, abs=1e-3)
    mm.drive(5.0, 0.0)  # §V-B: UGV longitudinal speed limited to 2 m/s
    world.step(2.0)
    assert mm.speed() == pytest.approx(2.0, abs=1e-3)
    mm.safe_stop()
    world.step(2.5)
    assert abs(mm.speed()) < 1e-3
    assert mm.link_pose("base_footprint")[0][2] == pytest.approx(0.0, abs=1e-3)


def test_every_arm_joint_reaches_its_target_without_exceeding_15_rpm(world):
    mm = world.add_robot("mobile_manipulator", arm_pose="docking_ready")
    target = mm.arm_pose("docking_ready") + np.array([0.9, 0.4, -0.5, 1.2, 0.6, -1.0])
    mm.set_joint_targets(target)
    peak = np.zeros(6)
    for _ in range(world.clock.steps_for(2.5)):
        world.step()
        peak = np.maximum(peak, np.abs(mm.joint_velocities()))
    assert np.all(peak <= JOINT_SPEED_LIMIT + 1e-3)  # 15 rpm, §V-B
    assert peak.min() > 0.5 * JOINT_SPEED_LIMIT  # every joint actually slewed
    assert np.abs(mm.joint_positions() - target).max() < 5e-3
    assert mm.arm_at_target(5e-3)


def test_arm_holds_half_a_kilogram_at_the_tip_within_a_few_millimetres(world):
    mm = world.add_robot("mobile_manipulator", arm_pose=[0.0, 1.2, 0.37, 0.0, 0.0, 0.0])  # reaching forward
    cid = world.client_id
    ball = pybullet.createCollisionShape(pybullet.GEOM_SPHERE, radius=0.03, physicsClientId=cid)
    p_tip, q_tip = mm.link_pose("part_a")
    p_load = p_tip + 0.035 * _rotation(q_tip)[:, 2]  # on Part A's face, like a docked UAV's adapter
    load = pybullet.createMultiBody(0.5, ball, -1, p_load.tolist(), physicsClientId=cid)
    for link in mm.links.values():
        pybullet.setCollisionFilterPair(mm.body_id, load, link, -1, 0, physicsClientId=cid)
    com = pybullet.getLinkState(mm.body_id, mm.link_index("part_a"), physicsClientId=cid)
    p_rel, q_rel = pybullet.multiplyTransforms(*pybullet.invertTransform(com[0], com[1]), p_load.tolist(), [0, 0, 0, 1])
    pybullet.createConstraint(
        mm.body_id, mm.link_index("part_a"), load, -1, pybullet.JOINT_FIXED, [0, 0, 0], p_rel, [0, 0, 0], q_rel,
        physicsClientId=cid,
    )
    world.step(2.0)
    p_now, _ = mm.link_pose("part_a")
    assert np.linalg.norm(p_now - p_tip) < 0.004
    torques = [s[3] for s in pybullet.getJointStates(mm.body_id, mm.joint_indices, physicsClientId=cid)]
    assert abs(torques[1]) > 8.0  # the shoulder really carries arm + load (N·m)
    assert np.all(np.abs(torques) <= mm.max_torque + 1e-6)


def test_pinocchio_forward_kinematics_matches_pybullet(world):
    mm = world.add_robot("mobile_manipulator")
    kin = mm.arm_kinematics
    assert kin.joint_names == ARM_JOINTS
    rng = np.random.default_rng(0)
    for _ in range(12):
        q = rng.uniform(kin.lower, kin.upper)
        mm.reset_arm(q)
        for link in ("part_a", "eye_in_hand", "end_effector"):
            p_bullet, R_bullet = _relative(mm, "arm_base", link)
            p_pin, R_pin = kin.forward(q, link)
            assert np.abs(p_pin - p_bullet).max() < 1e-6
            assert np.abs(R_pin - R_bullet).max() < 1e-6


def test_frame_jacobian_matches_finite_differences_and_limits_come_from_the_urdf(world):
    mm = world.add_robot("mobile_manipulator")
    kin = mm.arm_kinematics
    q = mm.arm_pose("docking_ready") + 0.1
    J = kin.jacobian(q)
    eps = 1e-6
    for i in range(kin.dof):
        dq = np.zeros(kin.dof)
        dq[i] = eps
        (p1, R1), (p0, R0) = kin.forward(q + dq), kin.forward(q - dq)
        assert np.allclose((p1 - p0) / (2 * eps), J[:3, i], atol=1e-6)
        W = (R1 - R0) / (2 * eps) @ kin.forward(q)[1].T  # skew(omega)
        assert np.allclose([W[2, 1], W[0, 2], W[1, 0]], J[3:, i], atol=1e-6)
    lower, upper = mm.joint_limits
    assert np.allclose(kin.lower, lower) and np.allclose(kin.upper, upper)
    assert np.allclose(kin.velocity_limit, JOINT_SPEED_LIMIT, atol=1e-3)
    assert kin.within_limits(q) and not kin.within_limits(upper + 0.1)


def test_kinematics_errors_name_what_was_expected():
    with pytest.raises(UnknownNameError, match="part_a"):
        ArmKinematics.from_urdf("mobile_manipulator.urdf", "arm_base", "part_aa")
    with pytest.raises(ValueError, match="not fixed to the chain"):
        ArmKinematics.from_urdf("mobile_manipulator.urdf", "end_effector", "arm_link_2")
    from_lidar = ArmKinematics.from_urdf("mobile_manipulator.urdf", "lidar", "part_a")  # fixed to the root: fine
    assert from_lidar.forward(np.zeros(6))[0] == pytest.approx([-0.23, 0.0, 1.08 + 0.24 - 0.356])
    kin = ArmKinematics.from_urdf("mobile_manipulator.urdf", "arm_base", "part_a")
    with pytest.raises(ValueError, match="expected 6 joint values"):
        kin.forward([0.0, 0.0])
    with pytest.raises(UnknownNameError, match="eye_in_hand"):
        kin.forward(np.zeros(6), "eye_in_hnd")


def test_eye_in_hand_sits_at_O_C_and_looks_along_part_a(world):
    mm = world.add_robot("mobile_manipulator", arm_pose="docking_ready")
    p_cam_E, R_E_cam = _relative(mm, "end_effector", "eye_in_hand")
    assert np.allclose(p_cam_E, [0.045, 0.01, 0.03], atol=1e-9)  # O_C, eq. (1), §V-B
    _, R_world_a = mm.link_pose("part_a")
    _, R_world_optical = mm.eye_in_hand.optical_pose()
    z_a = _rotation(R_world_a)[:, 2]
    assert z_a @ [0, 0, 1] > 0.999  # docking_ready: Part A points up
    assert R_world_optical[:, 2] @ z_a > 0.999  # the camera looks along Part A's approach axis
    intr = mm.eye_in_hand.intrinsics
    assert (intr.width, intr.height, intr.fov_v_deg) == (640, 480, 60.0)
    assert mm.eye_in_hand.config.rate_hz == 60.0


def test_named_poses_are_within_limits_and_point_part_a_up(world):
    mm = world.add_robot("mobile_manipulator")
    kin = mm.arm_kinematics
    for name in ARM_POSES:
        assert kin.within_limits(mm.arm_pose(name)), name
    p_floor = mm.link_pose("base_footprint")[0]
    for name in ("stowed", "docking_ready", "storage"):
        mm.reset_arm(name)
        p_a, q_a = mm.link_pose("part_a")
        assert _rotation(q_a)[2, 2] > 0.999, name
        assert p_a[2] - p_floor[2] > 0.6, name
    with pytest.raises(UnknownNameError, match="docking_ready"):
        mm.set_joint_targets("docking_redy")


def test_sensors_follow_the_paper_and_accept_overrides(world):
    mm = world.add_robot(
        "mobile_manipulator", sensors={"front_rgbd": {"width": 160, "height": 120}, "lidar": {"noise_std": 0.0}}
    )
    assert mm.sensor("lidar") is mm.lidar and mm.lidar.spec.fov_deg == 270.0
    assert mm.front_rgbd.read() is None  # the first frame arrives after the camera's 50 ms latency
    world.step(0.05)
    frame = mm.front_rgbd.read().data
    assert frame.rgb.shape == (120, 160, 3) and frame.depth.shape == (120, 160)
    assert mm.front_rgbd.measures_depth and not mm.eye_in_hand.measures_depth  # RealSense D435 vs PS Eye
    assert mm.lidar.config.noise_std == 0.0
    with pytest.raises(UnknownNameError, match="front_rgbd"):
        world.add_robot("mobile_manipulator", name="other", sensors={"front_rgb": {}})
    with pytest.raises(ValueError, match="unknown setting"):
        world.add_robot("mobile_manipulator", name="third", sensors={"lidar": {"width": 3}})
    with pytest.raises(ValueError, match="capture_distance"):
        world.add_robot("mobile_manipulator", name="fourth", docking={"capture_distanc": 0.02})
    wide = world.add_robot("mobile_manipulator", name="fifth", docking={"capture_distance": 0.02})
    assert wide.docking.capture_distance == 0.02


def test_safe_stop_stops_the_base_and_holds_the_arm(world):
    mm = world.add_robot("mobile_manipulator")
    mm.drive(1.0, 0.3)
    mm.set_joint_targets("docking_ready")
    world.step(0.3)
    mm.safe_stop()
    q_held = mm.joint_positions()
    world.step(1.5)
    assert abs(mm.speed()) < 1e-3
    assert np.abs(mm.joint_positions() - q_held).max() < 0.02
    state = mm.state()
    assert len(state["joints"]) == 6 and state["docking"] == {"state": "open", "docked": None, "locking": False}


def test_arm_and_carried_uav_fit_the_pioneer_payload():
    with World() as world:
        mm = world.add_robot("mobile_manipulator")
        cid = world.client_id
        base_links = ("base_link", "base_footprint", "lidar", "front_rgbd")
        arm_links = [mm.link_index(n) for n in mm.links if n not in base_links]
        arm_mass = sum(pybullet.getDynamicsInfo(mm.body_id, i, physicsClientId=cid)[0] for i in arm_links)
        assert 3.0 < arm_mass < 6.0
        assert arm_mass + 0.5 < MobileManipulator.payload_kg  # 10 kg payload, §V-B
        assert math.isclose(mm.limits.max_speed, 2.0)
