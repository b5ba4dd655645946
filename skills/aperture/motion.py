"""Executing planned arm motions of the MMS: a toppra-timed joint path streamed to the joint controllers.

A skill plans a joint path (:mod:`.insertion`, :func:`~.arm_motion.plan_arm_path`), times it with
:func:`~..uav_docking.trajectory.time_joint_path` and hands it to an :class:`ArmMotion`, which on every tick
sets the joint targets to q(t) (simulated time since it began) and reports the motion done once the time is up
and the encoders are within a tolerance of the goal. The joint PIDs in the physics do the tracking.

Units: rad, rad/s, seconds.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..uav_docking.trajectory import JointTrajectory, TrajectoryParams, time_joint_path
from .arm_motion import densify

RESOLUTION = 0.05  # rad: joint-space spacing of the timed paths (the planner's collision-check resolution)


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
        self.trajectory: JointTrajectory = time_joint_path(densify(self.path, RESOLUTION), limits)
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
