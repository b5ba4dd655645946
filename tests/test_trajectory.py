"""Joint trajectories timed by toppra within the arm's 15 rpm limit (Narváez et al., §V-B).

Sampled densely, no joint ever exceeds 15 rpm or the chosen acceleration
limit, every trajectory starts at its start and ends at rest on its goal,
a single-joint move takes the analytic bang-coast-bang time, and a moving
set-point keeps its speed along the new line.
"""

import math

import numpy as np
import pytest

from marsupial.skills.common.trajectory import JointTrajectory, TrajectoryParams, plan_joint_trajectory
from marsupial.world.robots.arm import RPM
from marsupial.world.robots.mobile_manipulator import JOINT_SPEED_LIMIT

PARAMS = TrajectoryParams()
LOWER = np.array([-2.967, -2.0, -2.6, -2.967, -2.1, -2.967])
UPPER = -LOWER


def _samples(trajectory: JointTrajectory, n: int = 800):
    t = np.linspace(0.0, trajectory.duration, n)
    q, qd = zip(*(trajectory.sample(ti) for ti in t), strict=True)
    return t, np.array(q), np.array(qd)


def test_the_limit_is_15_rpm():
    assert PARAMS.v_max == pytest.approx(15.0 * RPM) == pytest.approx(JOINT_SPEED_LIMIT)
    assert PARAMS.v_max == pytest.approx(1.5708, abs=1e-4)


def test_random_moves_stay_within_15_rpm_and_reach_the_goal():
    rng = np.random.default_rng(0)
    for _ in range(12):
        q_start = rng.uniform(LOWER, UPPER)
        q_goal = np.clip(q_start + rng.uniform(-1.0, 1.0, 6), LOWER, UPPER)
        trajectory = plan_joint_trajectory(q_start, q_goal)
        t, q, qd = _samples(trajectory)
        assert np.abs(qd).max() <= JOINT_SPEED_LIMIT  # 15 rpm, every joint, every sample
        np.testing.assert_allclose(q[0], q_start, atol=1e-9)
        np.testing.assert_allclose(q[-1], q_goal, atol=1e-9)
        np.testing.assert_allclose(qd[-1], 0.0, atol=1e-6)  # at rest on the goal
        accel = np.diff(qd, axis=0) / np.diff(t)[:, None]
        assert np.abs(accel).max() <= PARAMS.a_max * 1.01
        # a straight line in joint space: every sample lies on the segment
        s = (q - q_start) @ (q_goal - q_start) / np.dot(q_goal - q_start, q_goal - q_start)
        np.testing.assert_allclose(q, q_start + s[:, None] * (q_goal - q_start), atol=1e-9)
        assert trajectory.duration >= np.abs(q_goal - q_start).max() / JOINT_SPEED_LIMIT
        q_after, qd_after = trajectory.sample(trajectory.duration + 1.0)  # held at the goal
        np.testing.assert_allclose(q_after, q_goal)
        np.testing.assert_allclose(qd_after, 0.0)


def test_single_joint_move_takes_the_bang_coast_bang_time():
    distance = 1.2  # rad on joint 1
    trajectory = plan_joint_trajectory(np.zeros(6), np.array([distance, 0, 0, 0, 0, 0]))
    v, a = PARAMS.margin * PARAMS.v_max, PARAMS.margin * PARAMS.a_max
    expected = distance / v + v / a  # accelerate to v, coast, decelerate
    assert trajectory.duration == pytest.approx(expected, rel=0.02)
    _, _, qd = _samples(trajectory)
    assert qd[:, 0].max() == pytest.approx(v, rel=0.01)  # it does reach the 15 rpm cruise


def test_a_moving_set_point_keeps_its_speed_along_the_new_line():
    q_start, q_goal = np.zeros(6), np.array([0.5, -0.3, 0.2, 0.0, 0.1, 0.0])
    direction = (q_goal - q_start) / np.abs(q_goal - q_start).max()
    qd_start = 0.8 * direction + np.array([0.0, 0.0, 0.0, 0.3, 0.0, 0.0])  # plus a sideways part that is dropped
    moving = plan_joint_trajectory(q_start, q_goal, qd_start)
    _, q, qd = _samples(moving)
    np.testing.assert_allclose(qd[0], 0.8 * direction, atol=1e-6)
    assert np.abs(qd).max() <= JOINT_SPEED_LIMIT
    np.testing.assert_allclose(q[-1], q_goal, atol=1e-9)
    assert moving.duration < plan_joint_trajectory(q_start, q_goal).duration  # no stop-and-go
    # too fast to stop on a short line: the trajectory starts from rest instead of failing
    short = plan_joint_trajectory(q_start, 0.01 * q_goal / np.abs(q_goal).max(), np.full(6, 1.5))
    _, _, qd_short = _samples(short)
    assert np.abs(qd_short).max() <= JOINT_SPEED_LIMIT and short.sample(short.duration)[0][0] == pytest.approx(0.01)


def test_no_motion_and_bad_input():
    still = plan_joint_trajectory(np.ones(6), np.ones(6))
    assert still.duration == 0.0
    q, qd = still.sample(0.3)
    np.testing.assert_allclose(q, 1.0)
    np.testing.assert_allclose(qd, 0.0)
    with pytest.raises(ValueError, match="joint vectors"):
        plan_joint_trajectory(np.zeros(6), np.zeros(5))
    with pytest.raises(ValueError, match="a_max"):
        TrajectoryParams(a_max=0.0)
    assert math.isfinite(plan_joint_trajectory(np.zeros(6), np.full(6, 0.2)).duration)
