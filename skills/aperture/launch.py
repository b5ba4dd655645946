"""``launch_scout``: Phase III, the launch command, and the arm's retreat with the empty apparatus (§IV-F).

Arora & Papachristos, §IV-F: after Phase II "the MAV should have egressed
from the back side of the aperture and held by the elongated apparatus";
Phase III turns it to the launch pose ξ_MAV^ref (|φ|, |θ| ≤ α_launch), "where
the MAV is ready to takeoff based on an appropriately timed command". Stages:

1. *Phase III*: the turn ``insert_scout`` planned (about the MAV's body x);
2. *launch*: once the arm has settled for ``settle`` s, the apparatus lets the
   MAV go (:meth:`~marsupial.api.views.ManipulatorView.release_scout`);
   the MAV's own skill takes off (it senses that it is no longer held);
3. *clear*: the MMS holds the arm still until the MAV's estimate, as the team
   link carries it, is ``clear_height`` above the cradle's seat as the MMS
   knows it (:func:`~.insertion.held_mav_pose`, where ``scout_takeoff``
   restarts the MAV's estimate at the release) (FAILURE after
   ``clear_timeout``: the MAV did not leave);
4. *retreat*: back along Phases III, II and the entry in reverse (the same
   checked paths, now without the MAV), RRT* to above the holster the
   apparatus came from, the descent, the fingers open (the apparatus latches
   into its holster), the lift, and RRT* back to the viewing pose the arm
   had before ``insert_scout``.

What it senses: the arm encoders, the base estimate, the scout's estimate
telemetry on the team link, the map M and the insertion ``insert_scout``
wrote. Blackboard: reads ``{robot}/insertion`` and ``{robot}/volumetric_map``.
Events: ``state_change`` phases ``phase3``, ``launched`` (the MAV's estimated
position), ``cleared``, ``stowed``. RUNNING while no insertion is on the
blackboard; SUCCESS with the apparatus back in its holster and the arm at
the viewing pose.
"""

from __future__ import annotations

from enum import Enum

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.trees.milestones import milestone
from marsupial.trees.phases import Phased, Transition, go

from .insert import INSERTION, ArmSkill, ArmSkillParams, Insertion
from .insertion import HOLSTERS, T_HANDLE_TCP, cartesian_path, held_mav_pose, line_poses
from .scan import VOLUMETRIC_MAP


class LaunchScout(Phased, ArmSkill):
    """Turn the inserted MAV to its launch attitude, let it go, and bring the empty apparatus back to its holster."""

    class Params(ArmSkillParams):
        scout: str
        """The MAV being launched (its estimate telemetry tells when it has left the apparatus)."""
        settle: float = Field(0.5, ge=0.0)
        """Seconds the arm holds still at the launch pose before the release."""
        clear_height: float = Field(0.15, gt=0.0)
        """The MAV has left once its estimate is this far (m) above its seat in the cradle at the release."""
        clear_timeout: float = Field(15.0, gt=0.0)
        """Seconds the MAV has to leave before the skill fails."""

    class Phase(Enum):
        """What to do once the present motion has ended (module docstring, stages 1–4)."""

        TURN = "turn"
        """Phase III, the turn to the launch attitude."""
        LAUNCH = "launch"
        """Hold still ``settle`` s, then let the MAV go."""
        CLEAR = "clear"
        """Wait for the MAV to climb ``clear_height`` off; then back through the aperture."""
        TO_HOLSTER = "to_holster"
        """The free motion to above the holster."""
        DESCEND = "descend"
        """Down onto the holster with the apparatus."""
        LET_GO = "let_go"
        """Open the fingers (the apparatus latches into its holster); lift off."""
        TO_VIEW = "to_view"
        """The free motion back to the viewing pose."""
        DONE = "done"
        """The apparatus is stowed, the arm at the viewing pose."""

    params: Params
    reads = (f"{{robot}}/{INSERTION}", f"{{robot}}/{VOLUMETRIC_MAP}")
    phase: Phase

    def start(self) -> None:
        super().start()
        self.insertion: Insertion | None = self.read(f"{self.robot_name}/{INSERTION}")
        self.enter(go(self.Phase.TURN, event=None))
        self.since = self.now
        self.released_at: np.ndarray | None = None

    def step(self) -> Status:
        if self.insertion is None:
            self.insertion = self.read(f"{self.robot_name}/{INSERTION}")
            self.feedback_message = "waiting for an inserted MAV (insert_scout)"
            return Status.RUNNING
        if self.moving():
            return Status.RUNNING
        return self.step_phase()

    @property
    def inserted(self) -> Insertion:
        """The insertion being launched (present once :meth:`step` has read it)."""
        assert self.insertion is not None
        return self.insertion

    def _scout_position(self) -> np.ndarray | None:
        message = self.link.latest(self.params.scout)
        return None if message is None else np.asarray(message.payload.position, dtype=float)

    def _step_turn(self) -> Status | Transition:
        self.run(self.inserted.phases.turn, True, "phase III: to the launch attitude", fine=True)
        self.since = -1.0
        return go(self.Phase.LAUNCH, event="phase3", roll=round(self.inserted.plan.roll, 4),
                  pitch=round(self.inserted.plan.pitch, 4))

    def _step_launch(self) -> Status | Transition:
        if self.since < 0.0:
            self.since = self.now
        self.robot.hold_arm()
        if self.now - self.since < self.params.settle:
            self.feedback_message = "settling at the launch pose"
            return Status.RUNNING
        if self._scout_position() is None:
            self.feedback_message = f"waiting for {self.params.scout}'s telemetry"
            return Status.RUNNING
        self.robot.release_scout()
        position, _ = held_mav_pose(self.robot)
        self.released_at = position
        self.since = self.now
        milestone(self, "launched", robot=self.params.scout, detail=f"through the aperture by {self.robot_name}")
        return go(self.Phase.CLEAR, event="launched", scout=self.params.scout,
                  position=[round(float(x), 3) for x in position])

    def _step_clear(self) -> Status | Transition:
        position = self._scout_position()
        assert self.released_at is not None
        climbed = -np.inf if position is None else float(position[2] - self.released_at[2])
        if climbed >= self.params.clear_height:
            phases = self.inserted.phases
            back = np.vstack((phases.turn[::-1], phases.slip[::-1], phases.entry[::-1]))
            self.run(back, True, "retreating through the aperture", fine=True)
            return go(self.Phase.TO_HOLSTER, event="cleared", scout=self.params.scout, climbed=round(climbed, 3))
        if self.now - self.since > self.params.clear_timeout:
            self.feedback_message = f"{self.params.scout} has not left in {self.params.clear_timeout:.0f} s"
            return Status.FAILURE
        self.feedback_message = f"waiting for {self.params.scout} to climb off ({climbed:+.2f} m)"
        return Status.RUNNING

    def _step_to_holster(self) -> Status | Transition:
        holster = self.inserted.holster
        model = self.model(True, False, list(self.inserted.stowed), self.inserted.plan)
        q_above = self.inserted.above_holster
        path = self.free_path(model, self.robot.joint_positions(), q_above, "to_holster")
        grasp = self.holster_frame(holster) @ T_HANDLE_TCP
        descent = cartesian_path(self.ik, line_poses(self.above(holster), grasp), q_above)
        if path is None or descent is None:
            self.feedback_message = f"no collision-free path back to {holster}"
            return Status.FAILURE
        self.descent: np.ndarray = descent
        self.run(path, False, f"back to {holster}")
        return go(self.Phase.DESCEND, event=None)

    def _step_descend(self) -> Status | Transition:
        self.run(np.vstack((self.inserted.above_holster, self.descent)), True, "putting the apparatus back")
        return go(self.Phase.LET_GO, event=None)

    def _step_let_go(self) -> Status | Transition:
        self.robot.open_gripper()
        if self.robot.gripper_opening() < 0.06:
            self.feedback_message = f"opening the gripper: {self.robot.gripper_opening():.3f} m"
            return Status.RUNNING
        self.run(np.vstack((self.descent[::-1], self.inserted.above_holster)), True, "lifting off the holster")
        return go(self.Phase.TO_VIEW, event="stowed", holster=self.inserted.holster)

    def _step_to_view(self) -> Status | Transition:
        model = self.model(False, False, list(HOLSTERS))
        path = self.free_path(model, self.robot.joint_positions(), self.inserted.view_q, "to_view")
        if path is None:
            self.feedback_message = "no collision-free path back to the viewing pose"
            return Status.FAILURE
        self.run(path, False, "back to the viewing pose")
        return go(self.Phase.DONE, event=None)

    def _step_done(self) -> Status:
        self.feedback_message = f"{self.params.scout} launched, the apparatus back in {self.inserted.holster}"
        return Status.SUCCESS
