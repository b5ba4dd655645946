"""The mother's task states of the coordinated docking (Zhao et al., §3.3, Figs. 4-6): linking, aligning, directing.

The mother has no view of the child: it knows only the features the child
sends over the team link (:data:`~.vision.FEATURES_TOPIC`, with the link's
latency and losses) and its own platform's load switch and lift encoder.
Its transitions (C1 and C3 judged on the received features) are written in
the mission's tree (``missions/subtrees/ugv_dock.yaml``):

- ``mother_link`` — rotate on the spot, slower than the child, until the
  child's features arrive (C1 as the child reports it), then succeed;
- ``mother_align`` — rotate by Remark 1 on the received k_h
  (:func:`~.steering.align_rate`) so the entrance turns towards the child;
  holds still while no fresh features arrive; runs until the tree moves on (C3), or
  succeeds when its load switch is pressed (the child drove in on a match whose frames the link lost);
- ``mother_direct`` — hold still while the child drives in, reporting the
  platform (:class:`~.vision.PlatformReport`) over the link; succeed once the
  load switch has stayed pressed for ``settle`` seconds (the child stopped on it).

Turn rates rad/s (counter-clockwise positive), times simulated s.
"""

from __future__ import annotations

from typing import Annotated

from py_trees.common import Status
from pydantic import Field

from marsupial.api.capabilities import HasBase, HasLift
from marsupial.trees.skill import NodeParams, P, Skill, TeamMember

from .steering import align_rate
from .vision import received_features, report_platform

#: a parameter naming the child a mother's skill works with
ChildMember = Annotated[str, TeamMember(HasBase)]


class _MotherSkill(Skill[P]):
    """Base of the mother's skills: its base."""

    robot_kinds = (HasBase, HasLift)
    claims = ("base",)



class MotherLink(_MotherSkill["MotherLink.Params"]):
    """Linking: rotate on the spot, slower than the child, until the child reports the benchmark captured (C1)."""

    class Params(NodeParams):
        child: ChildMember = "child"
        """The child docking (its features arrive over the team link)."""
        turn_rate: float = Field(0.15, ge=-0.5, le=0.5)
        """Turn rate (rad/s, counter-clockwise positive; slower than the child's, §3.3)."""
        max_age: float = Field(0.5, gt=0.0)
        """Features sent less than this long ago (s) count as the benchmark captured."""

    def step(self) -> Status:
        p = self.params
        if received_features(self, p.child, p.max_age) is not None:
            self.robot.stop()
            self.feedback_message = f"{p.child} captured the benchmark (C1)"
            return Status.SUCCESS
        self.robot.drive(0.0, p.turn_rate)
        self.feedback_message = f"rotating, waiting for {p.child}'s features"
        return Status.RUNNING


class MotherAlign(_MotherSkill["MotherAlign.Params"]):
    """Aligning: rotate by Remark 1 on the child's transmitted k_h so the entrance faces the child (until C3).

    Succeeds, stopped, if the platform's load switch is pressed first: the child matched and drove in, but
    every frame showing the match was lost on the team link.
    """

    class Params(NodeParams):
        child: ChildMember = "child"
        """The child docking (its features arrive over the team link)."""
        gain: float = Field(0.5, gt=0.0)
        """Turn rate per unit of k_h (rad/s)."""
        max_rate: float = Field(0.15, gt=0.0, le=0.5)
        """Turn-rate limit (rad/s): slow enough for the child to keep I_h centred."""
        max_age: float = Field(0.5, gt=0.0)
        """Hold still while the newest features are older than this (s)."""

    def step(self) -> Status:
        p = self.params
        if self.robot.platform_occupied:
            # the child drove in on a match (C3) whose frames all missed the link: the load switch tells
            self.robot.stop()
            self.feedback_message = "child on the platform before its match arrived: aligned"
            return Status.SUCCESS
        features = received_features(self, p.child, p.max_age)
        if features is None:
            self.robot.stop()
            self.feedback_message = f"no fresh features from {p.child}: holding"
            return Status.RUNNING
        omega = align_rate(features.k_h, p.gain, p.max_rate)
        self.robot.drive(0.0, omega)
        self.feedback_message = f"k_h {features.k_h:+.3f}: turning at {omega:+.3f} rad/s"
        return Status.RUNNING


class MotherDirect(_MotherSkill["MotherDirect.Params"]):
    """Directing: hold still while the child drives in; succeed once it has stood on the platform ``settle`` s."""

    class Params(NodeParams):
        settle: float = Field(2.0, ge=0.0)
        """How long (s) the platform's switch must stay pressed: the child drives on and stops inside."""
        timeout: float = Field(30.0, gt=0.0)
        """Fail if the switch has not settled pressed by then (s)."""

    def start(self) -> None:
        self.deadline = self.now + self.params.timeout
        self.pressed_since: float | None = None

    def step(self) -> Status:
        self.robot.stop()
        if not report_platform(self):
            self.pressed_since = None
        elif self.pressed_since is None:
            self.pressed_since = self.now
        if self.pressed_since is not None and self.now - self.pressed_since >= self.params.settle - 1e-9:
            self.feedback_message = "child on the platform"
            return Status.SUCCESS
        if self.now >= self.deadline:
            self.feedback_message = f"no child settled on the platform in {self.params.timeout:.0f} s"
            return Status.FAILURE
        self.feedback_message = "holding still, platform " + ("pressed" if self.pressed_since is not None else "free")
        return Status.RUNNING
