"""Collision-free arm motion of the MMS (Arora & Papachristos §IV-F): fcl checks, OMPL RRT* and toppra timing."""

from __future__ import annotations

import fcl
import numpy as np
import pytest

from marsupial.api.assets import asset_path
from marsupial.api.kinematics import ArmKinematics
from marsupial.skills.aperture.arm_motion import ArmCollisionModel, ArmPlanParams, plan_arm_path
from marsupial.skills.common.trajectory import TrajectoryParams, time_joint_path

URDF = asset_path("mms.urdf")
ARM_LINKS = [f"arm_link_{i}" for i in range(1, 7)] + ["gripper_base", "finger_left", "finger_right"]
FIXED_LINKS = ["base_link", "holster_left", "holster_right", "arm_base_link"]
Q_LEFT = np.array([-1.0, 0.6, 0.8, 0.0, 0.5, 0.0])  # rad: the tool out in front, to the right / left of the axis
Q_RIGHT = np.array([1.0, 0.6, 0.8, 0.0, 0.5, 0.0])
VOXEL = 0.05  # m


@pytest.fixture(scope="module")
def kinematics():
    return ArmKinematics.from_urdf("mms.urdf", "arm_base_link", "tcp")


def _block(kinematics, half: float = 0.1):
    """Voxels (centres, edges) of a cube 2·``half`` wide around the tool at the middle of the Q_LEFT–Q_RIGHT swing."""
    p, _ = kinematics.forward(np.array([0.0, 0.6, 0.8, 0.0, 0.5, 0.0]))
    steps = np.arange(-half, half + 1e-9, VOXEL)
    centres = np.array([p + (dx, dy, dz) for dx in steps for dy in steps for dz in steps])
    return centres, np.full(len(centres), VOXEL)


def test_the_arm_touches_the_robot_when_folded_onto_its_base(kinematics):
    model = ArmCollisionModel(kinematics, URDF, ARM_LINKS, FIXED_LINKS)
    assert model.free(np.zeros(6)) and model.free(Q_LEFT)  # upright, and out in front
    folded = np.array([0.0, -1.9, 0.0, 0.0, 0.0, 0.0])  # leant back over the base
    assert not model.free(folded)
    assert any(c.endswith(": robot") for c in model.contacts(folded))
    assert not model.free(kinematics.upper + 0.1)  # out of the joint limits


def test_a_carried_shape_collides_with_the_map(kinematics):
    centres, edges = _block(kinematics)
    shifted = centres + (0.0, 0.0, 0.30)  # the block 30 cm above the tool's path
    bare = ArmCollisionModel(kinematics, URDF, ARM_LINKS, FIXED_LINKS, obstacles=(shifted, edges))
    tall = ArmCollisionModel(kinematics, URDF, ARM_LINKS, FIXED_LINKS, obstacles=(shifted, edges),
                             tool=[(fcl.Box(0.6, 0.05, 0.05), np.eye(4), "boom")])  # 0.6 m along the tcp x (up here)
    q = np.array([0.0, 0.6, 0.8, 0.0, 0.5, 0.0])
    assert bare.free(q) and not tall.free(q)
    assert "boom: map" in tall.contacts(q)


def test_rrt_star_goes_round_a_block_in_the_way_and_toppra_times_the_path(kinematics):
    model = ArmCollisionModel(kinematics, URDF, ARM_LINKS, FIXED_LINKS, obstacles=_block(kinematics))
    params = ArmPlanParams()
    assert not all(model.free(q) for q in np.linspace(Q_LEFT, Q_RIGHT, 50))  # the straight swing hits it
    path = plan_arm_path(model, Q_LEFT, Q_RIGHT, seed=1, params=params)
    assert path is not None
    assert np.allclose(path[0], Q_LEFT) and np.linalg.norm(path[-1] - Q_RIGHT) <= params.resolution
    assert np.max(np.linalg.norm(np.diff(path, axis=0), axis=1)) <= params.resolution + 1e-9
    assert all(model.free(q) for q in path)
    again = plan_arm_path(model, Q_LEFT, Q_RIGHT, seed=1, params=params)
    assert again is not None and again.shape == path.shape and np.allclose(again, path)  # seeded: the same plan
    limits = TrajectoryParams(v_max=1.0, a_max=2.0)
    timed = time_joint_path(path, limits)
    t = np.linspace(0.0, timed.duration, 300)
    q = np.array([timed.sample(s)[0] for s in t])
    assert np.allclose(q[0], path[0]) and np.allclose(q[-1], path[-1])
    assert np.max(np.abs(np.diff(q, axis=0)) / np.diff(t)[:, None]) <= limits.v_max * 1.01
    assert all(model.free(s) for s in q)  # the timed spline stays clear too


def test_no_path_into_the_map(kinematics):
    model = ArmCollisionModel(kinematics, URDF, ARM_LINKS, FIXED_LINKS, obstacles=_block(kinematics))
    inside = np.array([0.0, 0.6, 0.8, 0.0, 0.5, 0.0])
    assert plan_arm_path(model, Q_LEFT, inside, seed=0) is None
