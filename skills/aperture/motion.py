"""Executing planned arm motions of the MMS: a toppra-timed joint path streamed to the joint controllers.

A skill plans a joint path (:mod:`.insertion`, :func:`~.arm_motion.plan_arm_path`), times it with
:func:`~..common.trajectory.time_joint_path` and hands it to an :class:`ArmMotion`, which on every tick
sets the joint targets to q(t) (simulated time since it began) and reports the motion done once the time is up
and the encoders are within a tolerance of the goal. The joint PIDs in the physics do the tracking.

Units: rad, rad/s, seconds.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..common.trajectory import JointTrajectory, TrajectoryParams, time_joint_path
from .arm_motion import densify

RESOLUTION = 0.05  # rad: joint-space spacing of the timed paths (the planner's collision-check resolution)
MIN_STEP_RAD = 1e-4
"""Waypoints closer than this (rad, joint-space norm) to the one kept before are dropped: toppra finds no
parameterisation through two waypoints 1e-8 to 1e-5 rad apart (measured: a level launch plan's Phase III)."""


def distinct_waypoints(path: np.ndarray) -> np.ndarray:
    """``path`` ``(n, dof)`` (rad) without the waypoints within :data:`MIN_STEP_RAD` of the one kept before
    (the last is kept in their place, so the path still ends at its goal)."""
    kept = [path[0]]
    for q in path[1:]:
        if float(np.linalg.norm(q - kept[-1])) > MIN_STEP_RAD:
            kept.append(q)
    if len(kept) > 1:
        kept[-1] = path[-1]
    return np.array(kept)


class ArmMotion:
    """One timed joint motion being executed (set-points q(t) from ``started``, s of simulated time).

    Args:
        path: ``(n, 6)`` joint path (rad), checked collision-free by its planner.
        limits: joint speed and acceleration limits of its timing.
        started: when it begins (s).
        label: what it is, for feedback and events (e.g. ``"phase II"``).
    """

    def __init__(self, path: np.ndarray, limits: TrajectoryParams, started: float, label: str):
        self.path = np.asarray(path, dtype=float)
        waypoints = distinct_waypoints(densify(self.path, RESOLUTION))
        if len(waypoints) < 2:  # no motion: hold the goal
            waypoints = np.vstack((self.path[-1], self.path[-1]))
        self.trajectory: JointTrajectory = time_joint_path(waypoints, limits)
        self.started = started
        self.label = label

    @property
    def goal(self) -> np.ndarray:
        """The joint angles (rad) it ends at."""
        return self.trajectory.q_goal

    def step(self, robot: Any, now: float, tolerance: float) -> bool:
        """Send the set-point of ``now`` (s) to ``robot``'s arm; whether the motion is over and the arm there."""
        q, _ = self.trajectory.sample(now - self.started)
        robot.set_joint_targets(q)
        if now - self.started < self.trajectory.duration:
            return False
        return float(np.max(np.abs(robot.joint_positions() - self.goal))) <= tolerance
