"""Built-in conditions: battery, operator command, obstacle, explored area, difficult area, timer.

Each is a :class:`~marsupial.trees.skill.Condition` registered under the
``marsupial.conditions`` entry-point group. In the compact guard form the
value of the condition key is its ``primary`` parameter:
``{battery_below: 0.2, robot: uav}``, ``{operator: dock}``,
``{obstacle_ahead: 1.5, robot: carrier}``, ``{area_explored: 0.8}``,
``{difficult_area: 1.0, robot: carrier}``, ``{timer: 120}``.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
import pybullet
from pydantic import Field

from marsupial.world.robots.base import yaw_of

from .skill import Condition, NodeParams


class BatteryBelow(Condition):
    """Holds while the robot's battery state of charge is below a fraction."""

    class Params(NodeParams):
        threshold: float = Field(0.2, ge=0.0, le=1.0)
        """State of charge (fraction 0..1) below which the condition holds."""

    primary: ClassVar[str] = "threshold"
    robot_kinds: ClassVar[tuple[str, ...]] = ("Quadrotor",)  # the robots with a battery model (world/energy.py)

    def check(self) -> bool:
        return self.robot.robot.battery.soc < self.params.threshold


class OperatorSaid(Condition):
    """Holds while the operator's command is pending (said and not yet handled).

    Inside ``priorities`` the command is handled when the guarded branch
    finishes; elsewhere as soon as this condition reports that it holds
    (see :mod:`marsupial.trees.operator`).
    """

    class Params(NodeParams):
        command: str
        """Name of the operator command (``dock``, ``deploy``, …)."""

    primary: ClassVar[str] = "command"
    uses_robot: ClassVar[bool] = False

    #: set by the compiler for guards of ``priorities`` (the branch handles the command)
    handled_by_branch: bool = False

    def check(self) -> bool:
        channel = self.context.operator
        if channel is None or channel.latched(self.params.command) is None:
            return False
        if not self.handled_by_branch:
            channel.handle(self.params.command)
        return True

    def describe(self) -> str:
        channel = self.context.operator
        said = channel.latched(self.params.command) if channel is not None else None
        why = f": {said.why}" if said is not None and said.why else ""
        return f"operator({self.params.command}){why}"


class ObstacleAhead(Condition):
    """Holds when something lies in front of a ground robot within a distance.

    A fan of horizontal rays is cast along the robot's heading at a given
    height, across the robot's width, starting at the front of its bounding
    box; the distance is measured from there (m).
    """

    class Params(NodeParams):
        distance: float = Field(1.0, gt=0.0)
        """Look-ahead distance from the robot's front (m)."""
        width: float = Field(0.6, gt=0.0)
        """Width of the swept corridor (m), centred on the robot."""
        height: float = Field(0.25, gt=0.0)
        """Height of the rays above the robot's base origin (m)."""
        rays: int = Field(7, ge=1)
        """Number of rays across the width."""

    primary: ClassVar[str] = "distance"

    def check(self) -> bool:
        robot = self.robot.robot
        cid = self.world.client_id
        p, q = robot.pose()
        yaw = yaw_of(q)
        forward = np.array([math.cos(yaw), math.sin(yaw), 0.0])
        left = np.array([-math.sin(yaw), math.cos(yaw), 0.0])
        lo, hi = pybullet.getAABB(robot.body_id, physicsClientId=cid)
        corners = np.array([[x, y, 0.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])])
        front = float(np.max((corners - [p[0], p[1], 0.0]) @ forward))
        offsets = np.linspace(-self.params.width / 2, self.params.width / 2, self.params.rays)
        origin = p + np.array([0.0, 0.0, self.params.height]) + forward * (front + 1e-3)
        starts = [origin + left * o for o in offsets]
        ends = [s + forward * self.params.distance for s in starts]
        hits = pybullet.rayTestBatch(
            [list(s) for s in starts], [list(e) for e in ends], physicsClientId=cid
        )
        return any(h[0] >= 0 and h[0] != robot.body_id for h in hits)


class AreaExplored(Condition):
    """Holds when the explored fraction on the blackboard reaches a threshold."""

    class Params(NodeParams):
        fraction: float = Field(0.8, ge=0.0, le=1.0)
        """Coverage fraction (0..1) at which the area counts as explored."""
        key: str = "coverage"
        """Blackboard key holding the explored fraction (written by an exploring skill)."""

    primary: ClassVar[str] = "fraction"
    uses_robot: ClassVar[bool] = False
    reads = ("{key}",)

    def check(self) -> bool:
        return float(self.read(self.params.key, 0.0)) >= self.params.fraction


class DifficultArea(Condition):
    """Holds when the robot is within a distance of a scene zone or object tagged as difficult.

    Zones (``scene.zones``) count by their box, objects by their collision
    shape; the default tags are corridors and door frames.
    """

    class Params(NodeParams):
        distance: float = Field(1.0, ge=0.0)
        """Distance (m) from the tagged zone or object at which the condition holds."""
        tags: tuple[str, ...] = ("corridor", "door_frame")
        """Scene tags that mark difficult areas."""

    primary: ClassVar[str] = "distance"

    def check(self) -> bool:
        robot = self.robot.robot
        scene = self.world.scene
        p, _ = robot.pose()
        for tag in self.params.tags:
            if scene.zones_at(p[:2], margin=self.params.distance, tag=tag):
                return True
            for obj in scene.tagged(tag):
                if pybullet.getClosestPoints(
                    robot.body_id, obj.body_id, self.params.distance, physicsClientId=self.world.client_id
                ):
                    return True
        return False


class Timer(Condition):
    """Holds once the simulated time reaches a given number of seconds since the run started."""

    class Params(NodeParams):
        seconds: float = Field(ge=0.0)
        """Simulated time (s) from which the condition holds."""

    primary: ClassVar[str] = "seconds"
    uses_robot: ClassVar[bool] = False

    def check(self) -> bool:
        return self.world.now + 1e-9 >= self.params.seconds
