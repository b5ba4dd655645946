"""Generic skills to build missions and tests on: wait, goto (UAV), hover (UAV), drive_to (ground).

Each skill declares its typed parameters, the robot kinds it drives and its
life cycle (start / step / finish); ``finish`` is the base class's: the
robot is left safe (hovering, wheels stopped) through the arbiter.

The skills steer on the robot's own state estimate (``self.robot.estimate()``):
targets are points of its navigation frame (``odom`` for a quadrotor or
wheel odometry, ``map`` for a localised carrier), which coincides with the
world frame at the start the mission declares; as the estimate drifts, so
does where the robot really arrives. Speeds m/s, times simulated s
(``self.now``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, ClassVar, Literal

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.api.capabilities import HasBase, Rotorcraft
from marsupial.trees.milestones import milestone
from marsupial.trees.skill import NodeParams, Skill

#: capabilities of the robots the skills below accept
AERIAL: tuple[type, ...] = (Rotorcraft,)
GROUND: tuple[type, ...] = (HasBase,)


class Wait(Skill["Wait.Params"]):
    """Do nothing for a number of simulated seconds, then succeed."""

    class Params(NodeParams):
        seconds: float = Field(1.0, ge=0.0)
        """How long to wait (simulated s)."""

    uses_robot: ClassVar[bool] = False

    def start(self) -> None:
        self._until = self.now + self.params.seconds

    def step(self) -> Status:
        left = self._until - self.now
        self.feedback_message = f"{max(left, 0.0):.1f} s left"
        return Status.SUCCESS if left <= 1e-9 else Status.RUNNING


class Goto(Skill["Goto.Params", Rotorcraft]):
    """Fly a UAV to a point of its navigation frame (proportional velocity command on its estimate, speed-limited)."""

    class Params(NodeParams):
        target: tuple[float, float, float]
        """Point to reach (m), in the UAV's navigation frame (the world frame at the start)."""
        tolerance: float = Field(0.15, gt=0.0)
        """Distance (m) at which the point counts as reached."""
        speed: float = Field(1.0, gt=0.0)
        """Speed limit (m/s)."""
        gain: float = Field(1.0, gt=0.0)
        """Proportional gain from position error to velocity (1/s)."""
        then: Literal["hover", "motors_off"] = "hover"
        """What the UAV does on arrival: hover there, or switch the motors off (to land near the floor)."""

    robot_kinds = AERIAL
    claims = ("rotors",)

    def start(self) -> None:
        self.robot.set_motors(True)

    def step(self) -> Status:
        error = np.asarray(self.params.target) - self.robot.estimate().position
        distance = float(np.linalg.norm(error))
        self.feedback_message = f"{distance:.2f} m to go"
        if distance <= self.params.tolerance:
            motors = ", motors off" if self.params.then == "motors_off" else ""
            milestone(self, f"reached {_point(self.params.target)}", detail=_named(self) + motors)
            return Status.SUCCESS
        v = self.params.gain * error
        speed = float(np.linalg.norm(v))
        if speed > self.params.speed:
            v *= self.params.speed / speed
        self.robot.command_velocity(v[0], v[1], v[2], 0.0, frame="world")
        return Status.RUNNING

    def finish(self, status: Status) -> None:
        if status == Status.SUCCESS and self.params.then == "motors_off":
            self.robot.set_motors(False)
        else:
            self.leave_safe()


class Hover(Skill["Hover.Params", Rotorcraft]):
    """Hold a UAV in place for a number of simulated seconds, then succeed."""

    class Params(NodeParams):
        seconds: float = Field(1.0, ge=0.0)
        """How long to hover (simulated s)."""

    robot_kinds = AERIAL
    claims = ("rotors",)

    def start(self) -> None:
        self._until = self.now + self.params.seconds

    def step(self) -> Status:
        self.robot.hover()
        left = self._until - self.now
        self.feedback_message = f"hovering, {max(left, 0.0):.1f} s left"
        return Status.SUCCESS if left <= 1e-9 else Status.RUNNING


class DriveTo(Skill["DriveTo.Params", HasBase]):
    """Drive a ground robot to a point of the floor (turn towards it, then drive; unicycle law on its estimate)."""

    class Params(NodeParams):
        target: tuple[float, float]
        """Point to reach (x, y in m), in the robot's navigation frame (the world frame at the start)."""
        tolerance: float = Field(0.2, gt=0.0)
        """Distance (m) at which the point counts as reached."""
        speed: float = Field(0.5, gt=0.0)
        """Forward speed limit (m/s)."""
        turn_rate: float = Field(1.0, gt=0.0)
        """Turn-rate limit (rad/s)."""
        heading_gain: float = Field(2.0, gt=0.0)
        """Proportional gain from heading error to turn rate (1/s)."""

    robot_kinds = GROUND
    claims = ("base",)

    def step(self) -> Status:
        estimate = self.robot.estimate()
        p = self.params
        distance = math.dist(p.target, estimate.position[:2])
        self.feedback_message = f"{distance:.2f} m to go"
        if distance <= p.tolerance:
            milestone(self, f"reached {_point(p.target)}", detail=_named(self))
            return Status.SUCCESS
        self.robot.drive(*unicycle_command(estimate.position[:2], estimate.yaw, p.target, p.speed, p.turn_rate,
                                           p.heading_gain))
        return Status.RUNNING


def _point(xyz: Sequence[float]) -> str:
    """``"(2.0, 0.0, 1.5) m"``: a target point for a milestone."""
    return "(" + ", ".join(f"{v:.1f}" for v in xyz) + ") m"


def _named(skill: Skill[Any]) -> str:
    """The node's name when the mission gave it one (a milestone's detail), else ``""``."""
    return skill.name if skill.name != skill.kind else ""


def unicycle_command(position: Sequence[float] | np.ndarray, yaw: float, target: Sequence[float] | np.ndarray,
                     speed: float, turn_rate: float, heading_gain: float) -> tuple[float, float]:
    """``(v, omega)`` (m/s, rad/s) driving a ground robot at ``position`` (m), heading ``yaw`` (rad), to ``target``.

    Turns towards the target at ``heading_gain`` × the heading error (limited to ``turn_rate``) and drives at
    ``min(speed, distance)`` scaled by the error's cosine (nothing while facing away). Same frame for both points.
    """
    dx, dy = target[0] - position[0], target[1] - position[1]
    heading_error = math.remainder(math.atan2(dy, dx) - yaw, math.tau)
    omega = max(-turn_rate, min(turn_rate, heading_gain * heading_error))
    return min(speed, math.hypot(dx, dy)) * max(0.0, math.cos(heading_error)), omega
