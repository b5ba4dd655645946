"""Kidnapping a robot: the world moves its body, the robot is not told (Zhao et al. §4.2, Experiment II).

:class:`~marsupial.world.disturbances.DisturbanceSchedule` applies the
``kidnap`` entries of a mission's ``world.disturbances`` with :func:`teleport`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pybullet

from marsupial.api.errors import WorldError

from .robots.wheeled import WheeledRobot

if TYPE_CHECKING:
    from .robots.base import Robot


@dataclass(frozen=True)
class Kidnap:
    """A robot moved by hand at one instant (Zhao et al. §4.2, Experiment II: the child "moved manually").

    ``pose`` is ``(x, y, yaw)`` (world frame, m, rad) of the robot's base,
    or ``(x, y, z, yaw)``; a wheeled robot stays on the floor whatever ``z``
    says. ``step`` is the physics step after which it is applied.
    """

    robot: Robot
    step: int
    pose: tuple[float, ...]


def spread_pose(pose: Sequence[float], spread: Sequence[float], rng: np.random.Generator) -> tuple[float, ...]:
    """``pose`` (``[x, y, yaw]`` or ``[x, y, z, yaw]``, m, rad) plus a uniform offset within ±``spread``
    ``[dx, dy, dyaw]`` (m, m, rad) on x, y and yaw, drawn from ``rng`` (a kidnap's spread, a start pose's)."""
    target = [float(v) for v in pose]
    if any(spread):
        dx, dy, dyaw = (rng.uniform(-h, h) for h in spread)
        target[0] += dx
        target[1] += dy
        target[-1] += dyaw
    return tuple(target)


def teleport(robot: Robot, pose: Sequence[float]) -> None:
    """Put ``robot``'s base at ``pose`` (``[x, y, yaw]`` or ``[x, y, z, yaw]``, world frame) at rest.

    World side only: the body and its velocity change, the robot's onboard
    estimate is not told (a wheeled robot's odometry integrates its wheels,
    which did not turn). A wheeled base is placed through its drive, which
    keeps it on the floor. A child carried by its mother (welded to the lift)
    raises :class:`WorldError`.
    """
    carrier = getattr(robot, "carrier", None)
    if carrier is not None:
        raise WorldError(f"kidnap {robot.name}: it is carried by {carrier.name}; only a robot on its own can be moved")
    x, y, yaw = pose[0], pose[1], pose[-1]
    if isinstance(robot, WheeledRobot):
        robot.diff_drive.teleport(np.array([x, y]), yaw)
        return
    z = pose[2] if len(pose) == 4 else float(robot.pose()[0][2])
    quaternion = (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))
    pybullet.resetBasePositionAndOrientation(robot.body_id, (x, y, z), quaternion, physicsClientId=robot.cid)
    pybullet.resetBaseVelocity(robot.body_id, (0, 0, 0), (0, 0, 0), physicsClientId=robot.cid)
