"""IK engine of Narváez et al. (Algorithm 3) on the pinocchio model of the carrier's arm.

Every pose the engine declares valid has joint angles within the URDF ranges
and its forward kinematics reaches the requested pose; poses out of reach
are rejected; the closed-form solver agrees with the paper's Jacobian (DLS)
solver, and splitting a batch over M worker processes changes nothing.
"""

import numpy as np
import pytest

from marsupial.api.errors import UnknownNameError
from marsupial.api.kinematics import ArmKinematics
from marsupial.skills.common.ik_engine import ArmGeometry, ClosedFormIK, DlsIK, IKEngine
from marsupial.skills.uav_docking.cord import Cord, CordParams
from marsupial.skills.uav_docking.vicinity import build_vicinity

Q_READY = np.array([0.0, -0.87, 1.98, 0.0, -1.11, 0.0])  # the carrier's "docking_ready" arm pose


@pytest.fixture(scope="module")
def kinematics():
    return ArmKinematics.from_urdf("mobile_manipulator.urdf", "arm_base", "part_a")


def _fk(kinematics, q):
    return np.array([kinematics.transform(qi) for qi in q])


def _assert_valid_vertices(kinematics, solution, targets, tolerance=1e-6):
    """Every valid vertex: joints within range, FK on the target (position m, rotation)."""
    q = solution.q[solution.valid]
    assert np.all(q >= kinematics.lower) and np.all(q <= kinematics.upper)
    reached = _fk(kinematics, q)
    np.testing.assert_allclose(reached[:, :3, 3], targets[solution.valid][:, :3, 3], atol=tolerance)
    np.testing.assert_allclose(reached[:, :3, :3], targets[solution.valid][:, :3, :3], atol=tolerance)


def test_the_arm_has_a_spherical_wrist_read_from_the_urdf(kinematics):
    g = ArmGeometry.from_kinematics(kinematics)
    np.testing.assert_allclose(g.shoulder, [0.0, 0.0, 0.18], atol=1e-12)  # joint 1 at 0.10 m + joint 2 at 0.08 m
    assert (g.upper_arm, g.forearm, g.flange) == pytest.approx((0.40, 0.41, 0.06))
    np.testing.assert_allclose(g.T_6_ik[:3, 3], [0.0, 0.0, 0.03], atol=1e-12)  # Part A's face


def test_random_configurations_are_recovered_exactly(kinematics):
    rng = np.random.default_rng(0)
    q_true = rng.uniform(kinematics.lower, kinematics.upper, (500, 6))
    targets = _fk(kinematics, q_true)
    solution = ClosedFormIK(kinematics).solve(targets[:, :3, 3], targets[:, :3, :3], q_ref=Q_READY)
    assert solution.valid.all()  # each was reached by an in-range configuration
    _assert_valid_vertices(kinematics, solution, targets, tolerance=1e-9)
    # from the true configuration as reference, the engine returns it (away from singularities)
    one = ClosedFormIK(kinematics).solve(targets[:50, :3, 3], targets[:50, :3, :3], q_ref=q_true[:50])
    regular = np.abs(np.sin(q_true[:50, 4])) > 1e-3
    np.testing.assert_allclose(one.q[regular], q_true[:50][regular], atol=1e-7)


def test_every_branch_reaches_the_pose(kinematics):
    rng = np.random.default_rng(1)
    targets = _fk(kinematics, rng.uniform(kinematics.lower, kinematics.upper, (100, 6)))
    q, ok = ClosedFormIK(kinematics).candidates(targets[:, :3, 3], targets[:, :3, :3], Q_READY)
    assert q.shape == (100, 8, 6)
    for k in range(8):
        reached = _fk(kinematics, q[ok[:, k], k])
        np.testing.assert_allclose(reached, targets[ok[:, k]], atol=1e-9)


def test_vicinity_vertices_respect_joint_ranges_and_reach_their_pose(kinematics):
    """Algorithm 3 on Algorithm 2's random poses: Part A pointing up inside a vicinity, some beyond reach."""
    rng = np.random.default_rng(2)
    L_S = CordParams().L_S
    items = np.array([0.55, 0.0, 0.75]) + L_S * np.arange(5)[:, None] * np.array([1.0, 0.3, 0.0])
    vicinity = build_vicinity(Cord(items, 1, 0, np.zeros(2), False, np.array([1.0, 0.3]) / np.hypot(1, 0.3)), L_S)
    positions, _ = vicinity.sample(120, rng)
    tilt = rng.normal(0.0, 0.2, (positions.shape[0], 3))  # the orientation varies around "Part A up"
    rotations = np.array([_rotation(w) for w in tilt])
    targets = np.zeros((positions.shape[0], 4, 4))
    targets[:, :3, :3], targets[:, :3, 3], targets[:, 3, 3] = rotations, positions, 1.0
    with IKEngine(kinematics) as engine:
        solution = engine.solve(positions, rotations, q_ref=Q_READY)
        index, q = engine.valid_poses(positions, rotations, q_ref=Q_READY)
    np.testing.assert_array_equal(index, np.flatnonzero(solution.valid))
    assert 0.2 < solution.valid.mean() < 1.0  # the far end of this cord leaves the workspace
    _assert_valid_vertices(kinematics, solution, targets)
    reach = ArmGeometry.from_kinematics(kinematics).reach
    beyond = np.linalg.norm(positions - ArmGeometry.from_kinematics(kinematics).shoulder, axis=1) > reach
    assert not solution.valid[beyond].any()
    np.testing.assert_allclose(solution.q[~solution.valid], Q_READY[None].repeat((~solution.valid).sum(), 0))


def _rotation(w):
    """Rotation matrix of the rotation vector ``w`` (rad)."""
    angle = np.linalg.norm(w)
    k = w / angle
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def test_joint_ranges_reject_configurations_outside_the_limits(kinematics):
    # the wrist pitch beyond its ±2.1 rad range: the pose is only reachable with |q5| > 2.1 on every branch
    q = np.array([0.3, 0.2, 0.9, 0.0, 2.5, 0.0])
    target = kinematics.transform(q)
    q_all, ok = ClosedFormIK(kinematics).candidates(target[None, :3, 3], target[None, :3, :3], Q_READY)
    reached = np.abs(_fk(kinematics, q_all[0]) - target).max(axis=(1, 2)) < 1e-9
    in_range = np.all((q_all[0] >= kinematics.lower) & (q_all[0] <= kinematics.upper), axis=1)
    np.testing.assert_array_equal(ok[0], reached & in_range)


def test_dls_solver_agrees_and_is_the_paper_per_pose_solver(kinematics):
    rng = np.random.default_rng(3)
    q_true = Q_READY + rng.uniform(-0.4, 0.4, (20, 6))
    targets = _fk(kinematics, q_true)
    dls = DlsIK(kinematics).solve(targets[:, :3, 3], targets[:, :3, :3], q_ref=Q_READY)
    assert dls.valid.mean() >= 0.9
    _assert_valid_vertices(kinematics, dls, targets, tolerance=1e-5)


def test_parallel_workers_give_the_same_vertices(kinematics):
    rng = np.random.default_rng(4)
    targets = _fk(kinematics, rng.uniform(kinematics.lower, kinematics.upper, (300, 6)))
    with IKEngine(kinematics) as one, IKEngine(kinematics, workers=2) as two:
        a = one.solve(targets[:, :3, 3], targets[:, :3, :3], Q_READY)
        b = two.solve(targets[:, :3, 3], targets[:, :3, :3], Q_READY)
    np.testing.assert_array_equal(a.valid, b.valid)
    np.testing.assert_allclose(a.q, b.q)


def test_other_frames_and_bad_input(kinematics):
    q = np.array([0.4, -0.5, 1.5, 0.3, -0.8, 0.2])
    T = kinematics.transform(q, "eye_in_hand")
    camera = ClosedFormIK(kinematics, frame="eye_in_hand").solve(T[None, :3, 3], T[:3, :3], q_ref=q)
    np.testing.assert_allclose(camera.q[0], q, atol=1e-9)
    with pytest.raises(UnknownNameError, match="flange"):
        ClosedFormIK(kinematics, frame="flange")
    with pytest.raises(ValueError, match="closed_form"):
        IKEngine(kinematics, solver="newton")
    with pytest.raises(ValueError, match="rotations"):
        IKEngine(kinematics).solve(np.zeros((3, 3)), np.zeros((2, 3, 3)))
