"""The mother's lifting docking station after the docking (Zhao et al., §2, Fig. 4(d)): lift, carry, release.

- ``lift`` — raise the platform with the child on it to its storing capsule
  ("this platform shall elevate the child robot to its expected storing
  capsule"); succeed when the lift encoder reads the capsule's height;
- ``carry`` — drive the mother with the child stored (``drive_to``'s law on
  the mother's estimate), refusing to start unless the platform is up and its
  load switch pressed;
- ``release`` — lower the platform to the floor, then drive the child out
  backwards a given distance on its odometry (the station's entrance is its only opening).

Each reports the platform over the team link (:class:`~.vision.PlatformReport`).
``lift`` writes the child it lifted (its ``child`` parameter: the load switch does not tell which) to ``{robot}/lifted``
(``carry`` reads them for its milestone, ``release`` clears them).
Heights and distances in m, speeds m/s.
"""

from __future__ import annotations

from typing import cast

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.api.capabilities import HasBase, HasLift
from marsupial.trees.milestones import milestone
from marsupial.trees.skill import NodeParams, Skill

from ..generic import DriveTo
from .mother import ChildMember
from .vision import report_platform

LIFT_TOLERANCE = 0.005  # m: the lift encoder this close to its target counts as arrived
LIFTED = "{robot}/lifted"  # blackboard: the children the platform lifted (team member names)


class Lift(Skill["Lift.Params"]):
    """Raise the platform with the child on it to the storing capsule; it decides on the platform's load switch."""

    class Params(NodeParams):
        child: ChildMember = "child"
        """The child the mission docks (the load switch tells that a child is on the plate, not which)."""
        tolerance: float = Field(LIFT_TOLERANCE, gt=0.0)
        """Lift-encoder error (m) at which the platform is at the capsule."""

    robot_kinds = (HasLift,)
    claims = ("lift",)
    writes = (LIFTED,)

    def start(self) -> None:
        self.loaded = bool(self.robot.platform_occupied)  # the load switch: a child stands wholly on the plate
        if self.loaded:
            self.robot.raise_platform()

    def step(self) -> Status:
        report_platform(self)
        if not self.loaded:
            self.feedback_message = "nothing on the platform to lift (load switch open)"
            return Status.FAILURE
        height, travel = float(self.robot.platform_height()), float(self.robot.lift_travel)
        self.feedback_message = f"lifting {self.params.child}: {height:.3f} of {travel:.2f} m"
        if height < travel - self.params.tolerance:
            return Status.RUNNING
        self.write(LIFTED.format(robot=self.robot_name), [self.params.child])
        milestone(self, "lifted", robot=self.params.child, detail=f"into {self.robot_name}'s capsule")
        return Status.SUCCESS


class Carry(DriveTo):
    """Drive the mother to a point with the child stored in its capsule (``drive_to`` on the mother's estimate)."""

    robot_kinds = (HasBase, HasLift)
    reads = (LIFTED,)

    def start(self) -> None:
        lift = cast(HasLift, self.robot)  # drive_to's robot is a HasBase; this one has the lift too (robot_kinds)
        travel = float(lift.lift_travel)
        self.stored = bool(lift.platform_occupied) and lift.platform_height() >= travel - LIFT_TOLERANCE

    def step(self) -> Status:
        if not self.stored:
            self.feedback_message = "no child stored: the platform is not up with a child on it"
            return Status.FAILURE
        status = super().step()
        if status == Status.SUCCESS:
            where = f"to ({self.params.target[0]:.2f}, {self.params.target[1]:.2f}) m"
            for child in self.read(LIFTED.format(robot=self.robot_name), ()):
                milestone(self, "carried", robot=child, detail=f"by {self.robot_name} {where}")
        return status


class Release(Skill["Release.Params"]):
    """Lower the platform to the floor, then drive the child out backwards."""

    class Params(NodeParams):
        child: ChildMember = "child"
        """The child on the platform (it drives out)."""
        distance: float = Field(0.6, gt=0.0)
        """How far the child backs out (m, its odometry): clear of the entrance."""
        speed: float = Field(0.1, gt=0.0, le=0.3)
        """The child's reversing speed (m/s)."""
        tolerance: float = Field(LIFT_TOLERANCE, gt=0.0)
        """Lift-encoder height (m) under which the platform is down."""

    robot_kinds = (HasLift,)
    claims = ("lift", "{child}/base")
    writes = (LIFTED,)

    def start(self) -> None:
        self.robot.lower_platform()
        self.child = self.member(self.params.child)
        self.p0: np.ndarray | None = None

    def step(self) -> Status:
        report_platform(self)
        p = self.params
        height = float(self.robot.platform_height())
        if self.p0 is None:
            if height > p.tolerance:
                self.feedback_message = f"lowering: {height:.3f} m"
                return Status.RUNNING
            self.p0 = np.array(self.child.estimate().position[:2])
        backed = float(np.linalg.norm(np.array(self.child.estimate().position[:2]) - self.p0))
        if backed >= p.distance:
            self.child.stop()
            self.feedback_message = f"{p.child} out, {backed:.2f} m back"
            self.write(LIFTED.format(robot=self.robot_name), [])
            milestone(self, "released", robot=p.child, detail=f"backed out of {self.robot_name}'s station")
            return Status.SUCCESS
        self.child.drive(-p.speed, 0.0)
        self.feedback_message = f"{p.child} backing out: {backed:.2f} m"
        return Status.RUNNING

    def finish(self, status: Status) -> None:
        self.child.stop()
        self.leave_safe()
