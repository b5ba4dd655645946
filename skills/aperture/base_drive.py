"""The MMS base driven to a pose on its own estimate: pure pursuit to the point, then a turn to the heading.

The MMS has no LiDAR, so ``navigate``'s obstacle avoidance cannot run: the skills that move its base
(``approach_aperture``, ``explore_volume``) check the drive against the volumetric map M before they
command it and then follow it on the base estimate (nav frame, m, rad) with this one step.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..navigation import pure_pursuit


def turn_step(robot: Any, yaw: float, tolerance: float) -> float | None:
    """One tick of a turn in place to ``yaw`` (rad): the heading error (rad) while turning, ``None`` once within
    ``tolerance`` (the base is then stopped)."""
    error = math.remainder(yaw - robot.estimate().yaw, math.tau)
    if abs(error) <= tolerance:
        robot.stop()
        return None
    robot.drive(0.0, float(np.clip(2.0 * error, -0.5, 0.5)))
    return error


def pursuit_step(robot: Any, goal: np.ndarray, max_speed: float, tolerance: float) -> float | None:
    """One tick of pure pursuit toward the point ``goal`` ``(x, y, ...)`` (nav, m), slowing to a stop: the distance
    (m) left while driving, ``None`` once within ``tolerance`` (the base is not stopped: a turn may follow)."""
    estimate = robot.estimate()
    offset = np.asarray(goal[:2], dtype=float) - estimate.position[:2]
    distance = float(np.hypot(*offset))
    if distance <= tolerance:
        return None
    c, s = math.cos(estimate.yaw), math.sin(estimate.yaw)
    goal_R = np.array([c * offset[0] + s * offset[1], -s * offset[0] + c * offset[1]])
    limit = min(max_speed, robot.limits.max_speed, math.sqrt(distance))  # slowing to a stop
    robot.drive(*pure_pursuit(goal_R, limit, robot.limits.max_omega))
    return distance
