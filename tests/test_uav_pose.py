"""UAV pose in the manipulator frame from rendered eye-in-hand frames (Narváez et al., eq. 1).

The Bebop 2 hovers 0.5–1.5 m in front of the PS Eye at the end effector
(640×480); the AprilTag bundle under it is detected, one solvePnP over all
visible tags gives P_Q^{C_A}, and eq. (1) composes it with F(q) (pinocchio)
and O_C. The UAV position in M must match pybullet's ground truth within
0.5 % of the camera–UAV distance on average (1.5 % for any single frame),
also with the camera tilted (where adding the three terms of eq. (1) as
vectors, as printed, is far off).
"""

import numpy as np
import pybullet
import pytest

from marsupial.skills.uav_docking.pose import UavPoseMeasurement, invert, transform
from marsupial.world import World

ARM_CONFIGURATIONS = {
    "docking_ready": np.array([0.0, -0.87, 1.98, 0.0, -1.11, 0.0]),  # camera straight up
    "tilted": np.array([0.7, -0.6, 1.7, 0.5, -0.7, 0.4]),  # camera tilted and turned
}
DISTANCES = (0.5, 1.0, 1.5)  # m along the optical axis


def _T(position, quaternion):
    return transform(np.array(pybullet.getMatrixFromQuaternion(quaternion)).reshape(3, 3), np.asarray(position))


@pytest.fixture(scope="module")
def scene():
    with World(seed=0) as world:
        carrier = world.add_robot("mobile_manipulator", pose=[0.0, 0.0, 0.3])
        uav = world.add_robot("bebop2", pose=[0.0, 0.0, 3.0, 0.0], motors_on=False)
        yield world, carrier, uav


@pytest.mark.parametrize("arm", ARM_CONFIGURATIONS)
def test_uav_position_in_M_matches_ground_truth(scene, arm):
    world, carrier, uav = scene
    carrier.reset_arm(ARM_CONFIGURATIONS[arm])
    camera = carrier.eye_in_hand
    measurement = UavPoseMeasurement(carrier.arm_kinematics, camera.K)
    rng = np.random.default_rng(11)
    errors = []
    for distance in DISTANCES:
        p_cam, R_world_optical = camera.optical_pose()
        lateral = rng.uniform(-0.15, 0.15, 2) * distance  # off the image centre
        p_uav = p_cam + R_world_optical @ np.array([lateral[0], lateral[1], distance])
        q_uav = pybullet.getQuaternionFromEuler([*rng.normal(0.0, 0.05, 2), rng.uniform(-np.pi, np.pi)])
        pybullet.resetBasePositionAndOrientation(uav.body_id, p_uav.tolist(), q_uav, physicsClientId=world.client_id)
        frame = camera.measure()
        q = carrier.joint_positions()
        measured = measurement.measure(frame.rgb, q)
        assert measured is not None, f"bundle not found at {distance} m ({arm})"
        T_M_Q = invert(_T(*carrier.arm_base_pose())) @ _T(*uav.pose())  # ground truth P_Q^M
        range_m = np.linalg.norm(measured.T_C_Q[:3, 3])
        error = np.linalg.norm(measured.p_uav_M - T_M_Q[:3, 3])
        errors.append(error / range_m)
        assert error <= 0.015 * range_m, f"{arm}, {distance} m: {error * 1000:.1f} mm off"
        # the UAV's attitude in M is measured as well
        R_error = measured.T_M_Q[:3, :3].T @ T_M_Q[:3, :3]
        assert np.arccos(np.clip((np.trace(R_error) - 1.0) / 2.0, -1.0, 1.0)) < np.radians(7.0)  # with pixel noise
        if arm == "tilted":  # eq. (1) read literally, as a sum of the three translations, misses by far
            T_M_F = carrier.arm_kinematics.transform(q, measurement.flange_link)
            p_sum = T_M_F[:3, 3] + measured.T_C_Q[:3, 3] + measurement.T_F_C[:3, 3]
            assert np.linalg.norm(p_sum - T_M_Q[:3, 3]) > 0.3 * distance
    assert np.mean(errors) < 0.005


def test_no_bundle_in_view_gives_no_measurement(scene):
    world, carrier, uav = scene
    carrier.reset_arm(ARM_CONFIGURATIONS["docking_ready"])
    p_cam, R_world_optical = carrier.eye_in_hand.optical_pose()
    behind = p_cam - 1.0 * R_world_optical[:, 2]
    cid = world.client_id
    pybullet.resetBasePositionAndOrientation(uav.body_id, behind.tolist(), [0, 0, 0, 1], physicsClientId=cid)
    measurement = UavPoseMeasurement(carrier.arm_kinematics, carrier.eye_in_hand.K)
    assert measurement.measure(carrier.eye_in_hand.measure().rgb, carrier.joint_positions()) is None
