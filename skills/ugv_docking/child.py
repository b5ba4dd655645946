"""The child's task states of the coordinated docking (Zhao et al., §3.3, Figs. 4-6): linking, approaching,
matching, directed.

Each skill drives the child's base from its own camera's features
(:func:`~.vision.child_view`, which also sends them to the mother) and its
wheel odometry; the transitions between them are the conditions C1–C4 of
:mod:`.conditions`, written in the mission's tree (``missions/subtrees/ugv_dock.yaml``):

- ``child_link`` — rotate on the spot until the benchmark is captured (C1), then succeed;
- ``child_approach`` — drive towards the benchmark keeping I_h on the image's
  vertical bisector ("with the guide of image feature u_h"; a child docking
  alone may already steer towards the entry line by k_h, ``lateral_gain``);
  runs until the tree moves on (C2) or falls back to linking (C4);
- ``child_match`` — advance and rotate alternately (:func:`~.steering.match_command`)
  until eq. (7) holds (C3, the tree ends it);
- ``child_direct`` — drive straight in, holding the heading on odometry (its features still sent),
  until the mother reports its platform's load switch pressed over the team
  link, then on a little to stand inside the capsule; succeed stopped.

Speeds m/s, turn rates rad/s (counter-clockwise positive), pixels as in :mod:`.features`.
"""

from __future__ import annotations

import math
from typing import Annotated

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.api.capabilities import HasBase, HasLift
from marsupial.trees.milestones import milestone
from marsupial.trees.skill import NodeParams, P, Skill, TeamMember

from .conditions import LOST_FRAMES
from .criterion import load_criterion_list, robot_tolerances
from .steering import MatchGains, centring_rate, match_command, target_column
from .vision import FEATURE_METRICS, PLATFORM_TOPIC, VIEW_KEY, BenchmarkView, PlatformReport, child_view


class _ChildSkill(Skill[P]):
    """Base of the child's skills: its base and camera, its benchmark view on the blackboard."""

    robot_kinds = (HasBase,)
    sensors = ("camera",)
    claims = ("base",)
    reads = (f"{{robot}}/{VIEW_KEY}",)
    writes = (f"{{robot}}/{VIEW_KEY}",)
    metrics = FEATURE_METRICS

    def view(self) -> BenchmarkView:
        """The child's benchmark view, updated to the newest camera frame."""
        return child_view(self)


class ChildLink(_ChildSkill["ChildLink.Params"]):
    """Linking: rotate on the spot until the benchmark is captured (C1)."""

    class Params(NodeParams):
        turn_rate: float = Field(0.6, ge=-1.5, le=1.5)
        """Turn rate while searching (rad/s, counter-clockwise positive; faster than the mother's, §3.3)."""

    def step(self) -> Status:
        if self.view().current is not None:
            self.robot.stop()
            self.feedback_message = "benchmark captured (C1)"
            return Status.SUCCESS
        self.robot.drive(0.0, self.params.turn_rate)
        self.feedback_message = "searching for the benchmark"
        return Status.RUNNING


class ChildApproach(_ChildSkill["ChildApproach.Params"]):
    """Approaching: drive towards the benchmark keeping I_h on the image's vertical bisector (until C2, by the tree)."""

    class Params(NodeParams):
        speed: float = Field(0.12, gt=0.0, le=0.3)
        """Forward speed (m/s; the child_ugv's limit is 0.3)."""
        turn_gain: float = Field(0.8, gt=0.0)
        """Turn rate per half image width of I_h off the centre (rad/s)."""
        max_rate: float = Field(0.5, gt=0.0)
        """Turn-rate limit (rad/s)."""
        turn_band: float = Field(60.0, gt=0.0)
        """I_h farther than this off its column (px) makes the child stop and rotate first."""
        lateral_gain: float = Field(0.0, ge=0.0)
        """Steer towards the entry line by k_h already while approaching (as ``child_match``'s; 0: I_h centred)."""
        max_offset: float = Field(0.3, gt=0.0, lt=1.0)
        """Largest offset of I_h from the centre while steering towards the entry line (fraction of W/2)."""
        delta_k: float = Field(0.02, gt=0.0)  # Δk = 0.02, Table 1
        """Within this |k_h| (Table 1's Δk) the child keeps I_h centred."""
        frames: int = Field(LOST_FRAMES, ge=1)
        """Keep steering on the newest features while fewer than this many successive frames missed them."""

    def step(self) -> Status:
        p = self.params
        features = self.view().held(p.frames)
        if features is None:
            self.robot.stop()
            self.feedback_message = "benchmark lost"
            return Status.RUNNING
        column = target_column(features, p.lateral_gain, p.max_offset, p.delta_k)
        omega = centring_rate(features, column, p.turn_gain, p.max_rate)
        v = p.speed if abs(features.u_h - column) <= p.turn_band else 0.0
        self.robot.drive(v, omega)
        self.feedback_message = f"u_h {features.u_h:.0f} px, s_u {features.s_u} px"
        return Status.RUNNING


class ChildMatch(_ChildSkill["ChildMatch.Params"]):
    """Matching: advance and rotate alternately until eq. (7) holds (C3, by the tree)."""

    class Params(NodeParams):
        delta_k: float = Field(0.02, gt=0.0)  # Δk = 0.02, Table 1
        """Δk of eq. (7) (Table 1: 0.02): within it the child centres I_h."""
        s_u_e: int | None = Field(None, ge=1)
        """s_u^e of eq. (7) (px): the child advances while s_u is below it. Unset: the value measured for the
        robot model and recorded with its f_list (``child_ugv``: 184 px); the paper's 203 px is never reached
        by this world's child camera."""
        speed: float = Field(0.04, gt=0.0, le=0.3)
        """Forward speed while advancing (m/s); backing off at half of it."""
        turn_gain: float = Field(0.6, gt=0.0)
        """Turn rate per half image width of I_h off its column (rad/s)."""
        max_rate: float = Field(0.3, gt=0.0)
        """Turn-rate limit (rad/s)."""
        turn_band: float = Field(12.0, gt=0.0)
        """I_h farther than this off its column (px) makes the child stop and rotate."""
        lateral_gain: float = Field(0.0, ge=0.0)
        """Steer onto the entry line by k_h (half image widths of offset per unit k_h, Remark 1). 0: keep I_h
        centred and let the mother turn the entrance (coordinated docking); > 0: the child alone (independent)."""
        max_offset: float = Field(0.3, gt=0.0, lt=1.0)
        """Largest offset of I_h from the centre while steering onto the entry line (fraction of W/2)."""
        retreat: float = Field(0.8, gt=0.0, lt=1.0)
        """Steering onto the entry line: once close but not aligned, back off until s_u < retreat · s_u^e."""
        frames: int = Field(LOST_FRAMES, ge=1)
        """Keep steering on the newest features while fewer than this many successive frames missed them."""

    def start(self) -> None:
        p = self.params
        self.tolerances = robot_tolerances(load_criterion_list(self.robot.kind), delta_k=p.delta_k, s_u_e=p.s_u_e)
        self.gains = MatchGains(
            p.speed, p.turn_gain, p.max_rate, p.turn_band, p.lateral_gain, p.max_offset, p.retreat
        )
        self.retreating = False

    def step(self) -> Status:
        features = self.view().held(self.params.frames)
        if features is None:
            self.robot.stop()
            self.feedback_message = "benchmark lost"
            return Status.RUNNING
        v, omega, what = match_command(features, self.tolerances, self.gains, self.retreating)
        self.retreating = what == "backing off"
        self.robot.drive(v, omega)
        self.feedback_message = f"{what}: u_h {features.u_h:.0f} px, k_h {features.k_h:+.3f}, s_u {features.s_u} px"
        return Status.RUNNING


class ChildDirect(_ChildSkill["ChildDirect.Params"]):
    """Directed: drive straight in until the mother reports the child on its platform, then on into the capsule.

    The child keeps processing its camera's frames while it drives in, until the benchmark has left the
    image (for ``LOST_FRAMES`` frames, 2–3 cm on), so its features keep going to the mother (§2): the mother
    leaves aligning on the first of them that meets eq. (7) (C3), which a single frame lost on the link would
    otherwise withhold from it. The frames after that would show nothing and are not rendered.
    """

    class Params(NodeParams):
        mother: Annotated[str, TeamMember(HasLift)] = "mother"
        """The mother whose platform the child boards (a team member with a lifting station)."""
        speed: float = Field(0.05, gt=0.0, le=0.3)
        """Forward speed (m/s)."""
        heading_gain: float = Field(2.0, ge=0.0)
        """Turn rate per radian of heading off the start heading (odometry), to drive straight (1/s)."""
        past_switch: float = Field(0.06, ge=0.0)
        """Distance (m, odometry) driven on after the platform's switch is reported pressed, to stand inside."""
        max_distance: float = Field(0.8, gt=0.0)
        """Fail when driven this far (m, odometry) without the mother reporting the child on the platform."""

    def start(self) -> None:
        estimate = self.robot.estimate()
        self.p0, self.yaw0 = np.array(estimate.position[:2]), float(estimate.yaw)
        self.started = self.now
        self.boarded_at: np.ndarray | None = None
        self.sending = True

    def step(self) -> Status:
        p = self.params
        if self.sending:  # the features still go to the mother, until the benchmark leaves the image
            self.sending = self.view().lost_frames < LOST_FRAMES
        estimate = self.robot.estimate()
        position = np.array(estimate.position[:2])
        if self.boarded_at is None and self.platform_occupied():
            self.boarded_at = position
        if self.boarded_at is not None and float(np.linalg.norm(position - self.boarded_at)) >= p.past_switch:
            self.robot.stop()
            self.feedback_message = f"on {p.mother}'s platform"
            milestone(self, "docked", detail=f"on {p.mother}'s platform")
            return Status.SUCCESS
        driven = float(np.linalg.norm(position - self.p0))
        if driven > p.max_distance:
            self.feedback_message = f"drove {driven:.2f} m without {p.mother} reporting the child on its platform"
            return Status.FAILURE
        omega = -p.heading_gain * math.remainder(float(estimate.yaw) - self.yaw0, math.tau)
        self.robot.drive(p.speed, omega)
        on = ", on the platform" if self.boarded_at is not None else ""
        self.feedback_message = f"driving in: {driven:.2f} m{on}"
        return Status.RUNNING

    def platform_occupied(self) -> bool:
        """Whether the mother's newest platform report, sent since this skill started, has its switch pressed."""
        message = self.link.latest(self.params.mother, PLATFORM_TOPIC)
        if message is None or message.sent < self.started:
            return False
        report: PlatformReport = message.payload
        return report.occupied
