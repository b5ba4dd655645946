"""``insert_scout``: grasp a launching apparatus from its holster and slip its MAV through the aperture (§IV-F).

Arora & Papachristos, §IV-F: "The entire sequence of trajectories computed
by the motion plans is executed, starting by grasping the MAV, positioning
it at the 'initial' pose g, and moving it along Phases I-III". This skill
does the grasp and Phases I–II; ``launch_scout`` does Phase III, the launch
and the retreat. Stages, each a planned motion executed by the joint
controllers (:mod:`.motion`):

1. *to the holster*: RRT* (:func:`~.arm_motion.plan_arm_path`) from the arm's
   present angles to the tcp 0.12 m above the handle (the holster's frame is
   known from the URDF, "a priori known holster-like mounting"), clear of M,
   the robot and the stowed apparatuses;
2. *descend* straight onto the handle; *grip*: close the fingers and wait
   until their encoder reads the handle's width (the grasp) — FAILURE if it
   does not within ``grip_timeout``; *lift* straight up out of the holster;
3. *Phase I*: RRT* to the tcp pose that puts the MAV at ξ_MAV on the aperture
   plane, rotated by the profile analysis's θ (g, the handle d_l out along
   n̂), with the apparatus and MAV checked against M and the rim
   (:mod:`.insertion`);
4. *Phase II*: the straight slip along −n̂, as deep as is collision-free up to
   d_l (:func:`~.insertion.insertion_depth`, a named departure).

The launch plans are tried best first, each from every IK branch of the arm
at its approach pose (nearest the viewing pose first: the straight segments
then keep to that branch, and the nearest alone can put the wrist into the
wall during the slip); the first whose Phase I, II and III all plan is kept.
Joint speed limits: ``free_speed`` for free motions, ``slip_speed`` near the
holster and through the aperture ("gently slips").

What it senses: the launch plans of ``analyze_aperture``, the volumetric map
M of ``aperture_scan``, the arm encoders, the gripper's encoder, the base
estimate, and the robot's and apparatus's URDF geometry.

Blackboard: reads ``{robot}/launch_plans`` and ``{robot}/volumetric_map``;
writes ``{robot}/insertion`` (:class:`Insertion`, for ``launch_scout``).
Events: ``state_change`` phases ``insertion_plan`` (the plan kept, depth, how
many plans were tried), ``grasped``, ``phase1``, ``phase2`` (each as it
begins). SUCCESS at the end of Phase II with the MAV past the aperture;
FAILURE when no plan works, the grasp fails, or the inputs are missing.
Rim contacts are measured by the referee on truth (:mod:`marsupial.world.rim_contacts`), not here.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from enum import Enum

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.api.capabilities import HasArmModel, HasGripper, HasScoutLauncher
from marsupial.geometry import rotation_matrix, transform
from marsupial.trees.phases import Phased, Transition, go, phase_event
from marsupial.trees.skill import NodeParams, Skill

from ..common.ik_engine import ClosedFormIK
from ..common.trajectory import TrajectoryParams
from .analyze import LAUNCH_PLANS
from .arm_motion import ArmCollisionModel, ArmPlanParams, plan_arm_path
from .insertion import (
    HOLSTERS,
    MMS_URDF,
    T_HANDLE_TCP,
    LaunchPhases,
    cartesian_path,
    environment,
    insertion_goals,
    launch_phases,
    line_poses,
    rim_objects,
    rim_of,
    stowed_objects,
    tool_shapes,
    voxels_off_the_opening,
)
from .launch_pose import D_L_M, LaunchPlan
from .motion import ArmMotion
from .scan import VOLUMETRIC_MAP

INSERTION = "insertion"
"""Blackboard key (under the robot's name) of the executed :class:`Insertion`."""
HANDLE_WIDTH_M = 0.025  # the handle's width across the fingers (launching_apparatus.urdf)
MAV_HALF_LENGTH_M = 0.05  # the tello's half-length with its propeller guards (tello.urdf: 0.028 + 0.021 m)


@dataclass(frozen=True)
class Insertion:
    """What ``insert_scout`` did, for ``launch_scout``.

    Attributes:
        holster: the holster the apparatus came from.
        stowed: the holsters still holding an apparatus.
        plan: the launch plan used.
        phases: its tcp goals (M) and the joint paths of its straight segments (Phase I's entry, II, III).
        above_holster: joint angles (rad) of the tcp ``hover_height`` above the holster's handle frame.
        view_q: the arm's angles (rad) when ``insert_scout`` began (the approach's viewing pose).
        T_M_nav: the navigation frame in M when it was planned (the base stands still).
    """

    holster: str
    stowed: tuple[str, ...]
    plan: LaunchPlan
    phases: LaunchPhases
    above_holster: np.ndarray
    view_q: np.ndarray
    T_M_nav: np.ndarray


class ArmSkillParams(NodeParams):
    """Parameters the MMS's arm-motion skills share (joint limits of their timing, tolerances, planning)."""

    free_speed: float = Field(0.5, gt=0.0, le=0.8)
    """Joint speed limit (rad/s) of the free motions (the arm's is 0.8 rad/s)."""
    slip_speed: float = Field(0.15, gt=0.0, le=0.8)
    """Joint speed limit (rad/s) at the holster and through the aperture."""
    acceleration: float = Field(1.0, gt=0.0)
    """Joint acceleration limit (rad/s²) of every motion (chosen)."""
    tolerance: float = Field(0.01, gt=0.0)
    """Largest joint error (rad) at which a free motion has arrived."""
    fine_tolerance: float = Field(0.004, gt=0.0)
    """Largest joint error (rad) at which a motion at the aperture (Phase I's end, the entry, the slip, the turn
    and the retreat) has arrived within ``settle_time`` of its trajectory's end: 4 mm at the MAV 1 m from the
    shoulder, about 2.6 counts of the 12-bit encoders (1.5 mrad a count, 0.5 count noise) so that six readings
    meet it at rest. At ``tolerance`` (0.01 rad) the entry began up to a centimetre off the plan: the whole
    clearance of a tight aperture."""
    settle_time: float = Field(3.0, ge=0.0, le=60.0)
    """Seconds (sim) a fine motion waits past its trajectory's end for ``fine_tolerance``; then ``tolerance``
    suffices (the joint PIDs' integral removes a held payload's last centimetre-radian slowly)."""
    max_checks: int = Field(15000, ge=100, le=200000)
    """RRT* stops after this many collision checks (deterministic, §IV-F's "collision-free arm planning")."""
    check_resolution: float = Field(0.02, gt=0.001, le=0.1)
    """Joint-space spacing (rad) of the collision checks along a free motion: 0.02 rad moves the apparatus's far
    end, 1.2 m from the shoulder, by at most 2.4 cm between two checks (at 0.05 rad, 6 cm: enough to pass
    through a 10 cm wall between checks, measured as rim contacts on the way back to the holster)."""
    hover_height: float = Field(0.12, gt=0.02, le=0.3)
    """Height (m) of the tcp above the handle before the descent onto it and after the lift."""
    wall_depth: float = Field(0.1, gt=0.0, le=1.0)
    """Depth (m) of the structure behind the aperture plane (d_a of Definition 1; the sensor sees only its face)."""


class ArmSkill(Skill[ArmSkillParams]):
    """Shared machinery of ``insert_scout`` and ``launch_scout``: frames, models and the arm's motions."""

    robot_kinds = (HasArmModel, HasGripper, HasScoutLauncher)
    claims = ("arm", "gripper")

    def start(self) -> None:
        p_M, q_M = self.robot.arm_base_pose()
        self.T_M_nav = np.linalg.inv(transform(p_M, rotation_matrix(q_M)))
        self.ik = ClosedFormIK(self.robot.arm_kinematics)
        self.motion: ArmMotion | None = None
        self.motion_tolerance = self.params.tolerance

    def limits(self, slow: bool) -> TrajectoryParams:
        """The timing limits of a slow (holster, aperture) or free motion."""
        p = self.params
        return TrajectoryParams(v_max=p.slip_speed if slow else p.free_speed, a_max=p.acceleration)

    def holster_frame(self, holster: str) -> np.ndarray:
        """The holster's handle frame in M (4×4), from the URDF (fixed on the base)."""
        p_M, R_M = self.robot.link_offset(self.robot.arm_base_link)
        p_h, R_h = self.robot.link_offset(holster)
        return np.linalg.inv(transform(p_M, R_M)) @ transform(p_h, R_h)

    def above(self, holster: str) -> np.ndarray:
        """The tcp pose (4×4, M) ``hover_height`` above the holster's handle, gripper pointing down."""
        return self.holster_frame(holster) @ transform((0.0, 0.0, self.params.hover_height), np.eye(3)) @ T_HANDLE_TCP

    def model(self, with_tool: bool, with_mav: bool, stowed: list[str], plan: LaunchPlan | None = None
              ) -> ArmCollisionModel:
        """The arm's collision model: M's voxels (off the opening of ``plan``'s aperture, whose rim stands in for
        them), the stowed apparatuses of ``stowed`` holsters, and the held apparatus (and MAV) if ``with_tool``."""
        occupancy = self.read(f"{self.robot_name}/{VOLUMETRIC_MAP}")
        voxels = occupancy.occupied_boxes() if occupancy is not None else (np.zeros((0, 3)), np.zeros(0))
        extra = {"stowed apparatus": stowed_objects([self.holster_frame(h) for h in stowed])}
        if plan is not None and len(plan.rim) >= 3:
            rim = rim_of(plan)
            voxels = voxels_off_the_opening(voxels[0], voxels[1], rim, self.params.wall_depth)
            extra["rim"] = rim_objects(rim, self.T_M_nav, self.params.wall_depth)
        tool = tool_shapes(with_mav) if with_tool else []
        return environment(self.robot.arm_kinematics, MMS_URDF, self.T_M_nav, voxels, tool, extra)

    def free_path(self, model: ArmCollisionModel, q_from: np.ndarray, q_to: np.ndarray, key: str
                  ) -> np.ndarray | None:
        """RRT* from ``q_from`` to ``q_to`` (rad) in ``model``, seeded from the run's seed and ``key``."""
        seed = int(self.context.rng(f"{self.name}/{key}").integers(1 << 30))
        return plan_arm_path(model, q_from, q_to, seed,
                             ArmPlanParams(resolution=self.params.check_resolution, max_checks=self.params.max_checks))

    def run(self, path: np.ndarray, slow: bool, label: str, fine: bool = False) -> None:
        """Begin executing ``path`` (rad) at the slow or free speed limit, to end within ``fine_tolerance`` if
        ``fine`` (the motions at the aperture) or ``tolerance``."""
        self.motion = ArmMotion(path, self.limits(slow), self.now, label)
        self.motion_tolerance = self.params.fine_tolerance if fine else self.params.tolerance

    def moving(self) -> bool:
        """Advance the present motion; True while it is not over."""
        if self.motion is None:
            return False
        settling = self.now - self.motion.started - self.motion.trajectory.duration
        tolerance = self.motion_tolerance if settling < self.params.settle_time else self.params.tolerance
        if not self.motion.step(self.robot, self.now, tolerance):
            self.feedback_message = f"{self.motion.label}: {self.now - self.motion.started:.1f} s"
            return True
        self.motion = None
        return False


class InsertScout(Phased, ArmSkill):
    """Grasp a launching apparatus from its holster and insert its MAV through the aperture (grasp, Phases I–II)."""

    class Params(ArmSkillParams):
        holster: str = "holster_right"
        """The holster whose apparatus (and MAV) to take: ``holster_left`` or ``holster_right``."""
        stowed: tuple[str, ...] = ()
        """Other holsters still holding an apparatus (kept clear of); default: every other holster."""
        clear_back: float = Field(0.01, ge=0.0)
        """The MAV's tail must end this far (m) beyond ``wall_depth`` at the end of Phase II."""
        standoff: float = Field(0.1, gt=0.0, le=0.3)
        """Phase I's free motion ends with the MAV this far (m) in front of the plane; a straight line along −n̂
        then brings it onto the plane (a narrow goal RRT* would rarely sample)."""
        grip_timeout: float = Field(3.0, gt=0.0)
        """Seconds the fingers have to close on the handle."""

    class Phase(Enum):
        """What to do once the present motion has ended (module docstring, stages 1–4)."""

        PLAN_GRASP = "plan_grasp"
        """Plan the motion to above the holster and the descent onto the handle; move."""
        DESCEND = "descend"
        """Open the fingers, descend onto the handle."""
        GRIP = "grip"
        """Close the fingers until they hold the handle; lift the apparatus out of the holster."""
        PLAN_LAUNCH = "plan_launch"
        """Plan Phases I–III from the launch plans; Phase I's free motion."""
        ENTER = "enter"
        """Phase I's straight end, onto the aperture plane."""
        SLIP = "slip"
        """Phase II, the slip through the aperture."""
        DONE = "done"
        """The MAV is past the aperture: hand the insertion over to ``launch_scout``."""

    params: Params
    reads = (f"{{robot}}/{LAUNCH_PLANS}", f"{{robot}}/{VOLUMETRIC_MAP}")
    writes = (f"{{robot}}/{INSERTION}",)
    phase: Phase

    def start(self) -> None:
        super().start()
        if self.params.holster not in HOLSTERS:
            raise ValueError(f"holster must be one of {', '.join(HOLSTERS)}, got {self.params.holster!r}")
        self.stowed = list(self.params.stowed) or [h for h in HOLSTERS if h != self.params.holster]
        self.view_q = self.robot.joint_positions()  # the approach's viewing pose: faces the aperture
        self.enter(go(self.Phase.PLAN_GRASP, event=None))
        self.grip_since: float | None = None

    def step(self) -> Status:
        if self.moving():
            return Status.RUNNING
        return self.step_phase()

    def _fail(self, why: str) -> Status:
        self.feedback_message = why
        phase_event(self, "insertion_failed", reason=why)
        return Status.FAILURE

    def _step_plan_grasp(self) -> Status | Transition:
        q0 = self.robot.joint_positions()
        T_above = self.above(self.params.holster)
        solution = self.ik.solve(T_above[:3, 3][None], T_above[:3, :3][None], q0)
        if not solution.valid[0]:
            return self._fail(f"{self.params.holster} is out of the arm's reach")
        self.q_above = solution.q[0]
        model = self.model(False, False, list(HOLSTERS))
        path = self.free_path(model, q0, self.q_above, "to_holster")
        grasp = self.holster_frame(self.params.holster) @ T_HANDLE_TCP
        descent = cartesian_path(self.ik, line_poses(T_above, grasp), self.q_above)
        if path is None or descent is None:
            return self._fail(f"no collision-free path to {self.params.holster}")
        self.descent: np.ndarray = descent
        self.run(path, False, f"to {self.params.holster}")
        return go(self.Phase.DESCEND, event=None)

    def _step_descend(self) -> Status | Transition:
        self.robot.open_gripper()
        self.run(np.vstack((self.q_above, self.descent)), True, "onto the handle")
        return go(self.Phase.GRIP, event=None)

    def _step_grip(self) -> Status | Transition:
        self.robot.close_gripper()
        if self.grip_since is None:
            self.grip_since = self.now
        if abs(self.robot.gripper_opening() - HANDLE_WIDTH_M) <= 0.002:
            self.run(np.vstack((self.descent[::-1], self.q_above)), True, "lifting the apparatus")
            return go(self.Phase.PLAN_LAUNCH, event="grasped", holster=self.params.holster)
        if self.now - self.grip_since > self.params.grip_timeout:
            return self._fail(f"the gripper did not close on the handle (gap {self.robot.gripper_opening():.3f} m)")
        self.feedback_message = f"gripping: gap {self.robot.gripper_opening():.3f} m"
        return Status.RUNNING

    def _step_plan_launch(self) -> Status | Transition:
        plans = self.read(f"{self.robot_name}/{LAUNCH_PLANS}") or []
        if not plans:
            return self._fail("no launch plans (analyze_aperture)")
        p = self.params
        shallow = p.wall_depth + p.clear_back + MAV_HALF_LENGTH_M
        model = self.model(True, True, self.stowed, plans[0])  # the plans share their aperture's rim
        refused: Counter[str] = Counter()
        for tried, plan in enumerate(plans, start=1):
            T = insertion_goals(plan, self.T_M_nav, shallow, p.standoff).approach  # it does not depend on the depth
            branches = self.branches(T)
            if not branches:
                refused["approach out of reach"] += 1
                continue
            phases = self.launch_phases(model, plan, branches, shallow)
            if isinstance(phases, str):
                refused[phases] += 1
                continue
            path = self.phase1_path(model, phases.entry[0], f"phase1_{tried}")
            if path is None:
                refused["no phase I path"] += 1
                continue
            self.insertion = Insertion(p.holster, tuple(self.stowed), plan, phases, self.q_above, self.view_q,
                                       self.T_M_nav)
            phase_event(self, "insertion_plan", tried=tried, depth=round(phases.goals.depth, 3), plan=plan.summary())
            self.run(path, False, "phase I: to the approach pose", fine=True)  # the entry starts on the plan
            return go(self.Phase.ENTER, event="phase1")
        why = ", ".join(f"{reason} {n}" for reason, n in sorted(refused.items()))
        return self._fail(f"none of {len(plans)} launch plans has collision-free Phases I-III ({why})")

    def launch_phases(self, model: ArmCollisionModel, plan: LaunchPlan, branches: list[np.ndarray], shallow: float
                      ) -> LaunchPhases | str:
        """Phases I–III of ``plan`` (:func:`~.insertion.launch_phases`, Phase II at least ``shallow`` m deep) from
        the first of the arm's IK ``branches`` at the approach pose (nearest the viewing pose first) from which they
        plan; else why not: the last planned branch's refusal, or, every branch blocked, the first one's contacts."""
        why: str | None = None
        for q_approach in branches:
            if not model.free(q_approach):
                why = why or f"approach {' & '.join(model.contacts(q_approach)) or 'joint limits'}"
                continue
            phases = launch_phases(model, self.ik, plan, self.T_M_nav, q_approach, self.params.standoff, shallow,
                                   D_L_M)
            if isinstance(phases, LaunchPhases):
                return phases
            why = phases
        assert why is not None, "at least one branch"
        return why

    def phase1_path(self, model: ArmCollisionModel, q_approach: np.ndarray, key: str) -> np.ndarray | None:
        """Phase I's free motion (rad) from above the holster to ``q_approach``: RRT* straight there, else through
        the viewing pose (the arm came from it; RRT* often finds the two shorter legs where it misses the whole)."""
        path = self.free_path(model, self.q_above, q_approach, key)
        if path is not None or not model.free(self.view_q):
            return path
        first = self.free_path(model, self.q_above, self.view_q, f"{key}_to_view")
        second = None if first is None else self.free_path(model, self.view_q, q_approach, f"{key}_from_view")
        return None if first is None or second is None else np.vstack((first, second[1:]))

    def branches(self, T: np.ndarray) -> list[np.ndarray]:
        """The arm's valid IK solutions (rad) for the tcp pose ``T`` (4×4, M), nearest the viewing pose first."""
        q, ok = self.ik.candidates(T[:3, 3][None], T[:3, :3][None], self.view_q)
        valid = q[0][ok[0]]
        return list(valid[np.argsort(np.sum((valid - self.view_q) ** 2, axis=1))])

    def _step_enter(self) -> Status | Transition:
        self.run(self.insertion.phases.entry, True, "phase I: onto the aperture plane", fine=True)
        return go(self.Phase.SLIP, event=None)

    def _step_slip(self) -> Status | Transition:
        self.run(self.insertion.phases.slip, True, "phase II: slipping through", fine=True)
        return go(self.Phase.DONE, event="phase2", depth=round(self.insertion.phases.goals.depth, 3))

    def _step_done(self) -> Status:
        self.write(f"{self.robot_name}/{INSERTION}", self.insertion)
        self.feedback_message = f"the MAV is {self.insertion.phases.goals.depth:.2f} m past the aperture plane"
        return Status.SUCCESS
