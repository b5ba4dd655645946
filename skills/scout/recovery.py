"""Ending a scout's flight early: ``scout_land`` (land where it is) and ``scout_return`` (fly its path back).

A micro-scout past the aperture cannot be retrieved by the carrier until it
is back at the aperture; a mission preempts ``scout`` with these (on low
battery, on the operator's recall; ``missions/subtrees/scout_object.yaml``):

- ``scout_land``: descend at ``descent_speed`` until the downward
  time-of-flight range reads ``touchdown_range`` or less, then stop the
  motors (the Tello SDK's ``land``: the vision positioning system's range
  finder sees the floor). Battery preemption: the scout is safe on the floor
  where it was, at the cost of leaving it there.
- ``scout_return``: fly back along the breadcrumbs ``scout`` recorded
  (``{robot}/scout_path``, newest first), facing the way it flies, to the
  first one (where the run started, past the aperture), then hover. Without a
  recorded path it flies to ``home`` if given, else fails.

Both decide from the MAV's own estimate (navigation frame, m) and its range
finder; speeds m/s, yaw rates rad/s.
"""

from __future__ import annotations

import math

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.api.capabilities import Rotorcraft
from marsupial.trees.skill import NodeParams, Skill

from .skills import SCOUT_PATH


class ScoutLand(Skill["ScoutLand.Params"]):
    """Land a micro-scout where it is: descend on its range finder, then stop the motors."""

    class Params(NodeParams):
        descent_speed: float = Field(0.3, gt=0.0)
        """Descent speed (m/s)."""
        touchdown_range: float = Field(0.12, gt=0.0)
        """Range finder reading (m) at which the motors stop (the Tello's ToF reads ≥ 0.1 m, its minimum)."""

    robot_kinds = (Rotorcraft,)
    sensors = ("sonar",)
    claims = ("rotors",)

    def step(self) -> Status:
        if not self.robot.motors_on:
            self.feedback_message = "landed, motors off"
            return Status.SUCCESS
        reading = self.robot.sensor("sonar").read()
        height = reading.data.range if reading is not None else math.inf
        if height <= self.params.touchdown_range:
            self.robot.set_motors(False)
            self.feedback_message = f"touchdown at {height:.2f} m range, motors off"
            return Status.SUCCESS
        self.robot.command_velocity(0.0, 0.0, -self.params.descent_speed, 0.0, frame="body")
        self.feedback_message = f"descending, range {height:.2f} m"
        return Status.RUNNING


class ScoutReturn(Skill["ScoutReturn.Params"]):
    """Fly a micro-scout back along the path its ``scout`` run recorded, to where the run started; then hover."""

    class Params(NodeParams):
        speed: float = Field(0.4, gt=0.0)
        """Flight speed along the path (m/s)."""
        tolerance: float = Field(0.2, gt=0.0)
        """Distance (m) at which a breadcrumb counts as reached."""
        yaw_gain: float = Field(1.5, gt=0.0)
        """Proportional gain from heading error to yaw rate (1/s): the camera looks the way it flies."""
        home: tuple[float, float, float] | None = None
        """Point to fly to when no path is recorded (m, navigation frame); ``None``: fail without a path."""

    robot_kinds = (Rotorcraft,)
    claims = ("rotors",)
    reads = (f"{{robot}}/{SCOUT_PATH}",)

    def start(self) -> None:
        path = self.read(f"{self.robot_name}/{SCOUT_PATH}") or []
        home = self.params.home
        self.waypoints = [np.asarray(p, dtype=float) for p in reversed(path)] if path else (
            [np.asarray(home, dtype=float)] if home is not None else [])

    def step(self) -> Status:
        if not self.waypoints:
            self.feedback_message = "no recorded path and no home to return to"
            return Status.FAILURE
        estimate = self.robot.estimate()
        tolerance = self.params.tolerance
        while len(self.waypoints) > 1 and np.linalg.norm(self.waypoints[0] - estimate.position) <= tolerance:
            self.waypoints.pop(0)
        error = self.waypoints[0] - estimate.position
        distance = float(np.linalg.norm(error))
        if len(self.waypoints) == 1 and distance <= self.params.tolerance:
            self.robot.hover()
            self.feedback_message = "back where the scout run started"
            return Status.SUCCESS
        heading_error = math.remainder(math.atan2(error[1], error[0]) - estimate.yaw, math.tau)
        yaw_rate = self.params.yaw_gain * heading_error
        v = error * min(1.0, self.params.speed / max(distance, 1e-9))
        self.robot.command_velocity(float(v[0]), float(v[1]), float(v[2]), yaw_rate, frame="world")
        self.feedback_message = f"returning, {len(self.waypoints)} breadcrumbs and {distance:.2f} m to the next"
        return Status.RUNNING
