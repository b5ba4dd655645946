"""``approach_aperture``: the MMS drives to a base placement from which its eye-in-hand camera sees the aperture.

Arora & Papachristos, §IV-D: from the most consistent aperture m_A and its
plane normal, base poses are sampled in the ρ = 2 m cone in front of it,
checked against the volumetric map M and for an arm configuration keeping
the aperture in the camera's view (:func:`~.placement.plan_placements`);
"once a feasible solution is found ... the MMS base is commanded to navigate
towards the goal such that the mounted arm workspace reaches the aperture,
while the latter is also maintained within the eye-in-hand sensor field of
view".

The level scanning poses of ``aperture_scan`` see the wall, not the ground in
front of it (the camera, 0.8 m up with a 29° half field of view, meets the
floor only beyond the wall), so M holds the ground where the base would
stand as unknown, which the placement refuses. The skill therefore first
looks at the ground: the arm takes each of ``look_poses`` (the camera just
beyond the base's front edge, pitched 55° and 70° down) panned by each of
``look_pan``, and one depth frame from each is inserted into M
(:mod:`.volumetric`).

What it senses: the ranked apertures and M that ``aperture_scan`` wrote (in
the navigation frame of the base estimate), the base estimate, the arm
encoders, the arm's model and the camera's mount and intrinsics. The MMS has
no LiDAR, so ``navigate``'s obstacle avoidance cannot run; the base goes to
the placement on its estimate (turn toward it, pure pursuit —
:func:`~marsupial.skills.navigation.pure_pursuit` — then turn to the
placement's heading), over ground M showed free at the placement only: the
straight drive there is not checked against M. Then the arm moves to the
placement's joint angles, the camera looking at m_A from ``standoff``, and
(``relocalize``) one depth frame from there is registered against the
surface M kept, correcting the base estimate for the odometry's drift on
the drive (:mod:`.registration`; the paper's MMS has SLAM for that). With
``reaim`` the arm's angles are then solved again from the (corrected) estimate
so that the camera stands at the placement's camera goal: the base stops up to
``position_tolerance`` and ``yaw_tolerance`` off the placement and the
relocalisation moves the estimate by up to 8 cm more, and the camera, 0.4 m
from the wall, saw a 30 cm U cut by the image border. The camera is centred
across n̂ on the aperture's contour (its bounding box), m_A in view
(:func:`~.placement.plan_placements`' ``view_point``). When the frame does not
register at the odometry's pose, it is registered from poses along the heading
(:func:`~.registration.register_searched`: a wheel slipping on an obstacle lets
the odometry run on), and a placement then more than ``redrive_distance`` ahead
is driven to again.

Blackboard: reads ``{robot}/apertures`` (``aperture_scan``'s ranking) and
``{robot}/volumetric_map`` (M); writes ``{robot}/placement``, the
:class:`~.placement.Placement` chosen. Events: a ``state_change`` with phase
``placement`` (the aperture, the placement, how many were feasible, why the others were refused) and
``ground_look`` (each look pose), ``reached`` (the estimated pose reached, its error from the placement, the
arm angles), ``relocalized`` (the correction applied: dx, dy, dyaw, pairs, rms;
none when the frame did not register), ``redrive`` (the distance to drive again), ``reaimed`` (how far the
camera stood off its goal, m; the new angles, none when out of reach). RUNNING while nothing is ranked yet;
FAILURE when the ranking is empty or no placement is feasible; SUCCESS once base and arm are there. The
base stops and the arm holds when the skill ends.
"""

from __future__ import annotations

import math
from collections import Counter
from enum import Enum

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.api.capabilities import HasArmModel, HasBase
from marsupial.geometry import rotation_matrix
from marsupial.trees.milestones import milestone
from marsupial.trees.phases import Phased, Transition, go, phase_event
from marsupial.trees.skill import NodeParams, Skill

from .base_drive import pursuit_step, turn_step
from .insertion import level_insertion_tcp
from .placement import RHO_M, CameraModel, Placement, PlacementParams, aim_camera, camera_goal, plan_placements
from .registration import relocalize_base
from .scan import APERTURES, VOLUMETRIC_MAP, fresh_frame
from .volumetric import sensor_cloud

LOOK_POSES = ((0.0, -0.061, 1.616, 0.0, 0.976, 0.0), (0.0, 0.009, 1.54, 0.0, 1.244, 0.0))
"""MMS arm angles (rad) with the camera 0.35 m ahead of and 0.50 m above ``arm_base_link`` (0.10 m beyond the base's
front edge, 0.89 m up), pitched 55° and 70° down (closed-form IK): together they see the ground from the base's
front edge to ≈1.8 m ahead of the camera."""

REDRIVE_CONE = math.radians(30.0)
"""The placement is driven to again only within this angle (rad) of the heading (pure pursuit turns on the spot
beyond 60°)."""

PLACEMENT = "placement"
"""Blackboard key (under the robot's name) of the chosen :class:`~.placement.Placement`."""


class ApproachAperture(Phased, Skill["ApproachAperture.Params"]):
    """Drive the MMS to a collision-free base placement from which its arm camera sees and reaches a ranked aperture."""

    class Params(NodeParams):
        rank: int = Field(0, ge=0)
        """Which ranked aperture to approach (0: the most consistent, §IV-D)."""
        rho: float = Field(RHO_M, gt=0.0)
        """ρ (m), radius of the sampling cone in front of the aperture (§IV-D: 2 m)."""
        half_angle: float = Field(math.radians(45.0), gt=0.0, lt=math.pi / 2)
        """Half-angle (rad) of the cone about the plane normal's ground projection (chosen)."""
        samples: int = Field(300, ge=1)
        """Candidate base poses drawn in the cone."""
        standoff: float = Field(0.5, gt=0.0)
        """Distance (m) of the camera from m_A along the plane normal."""
        margin: float = Field(0.05, ge=0.0)
        """Inflation (m) of the base rectangle in the collision check against M."""
        max_speed: float = Field(0.3, gt=0.0)
        """Base speed limit (m/s) on the approach (chosen: slow near the structure)."""
        position_tolerance: float = Field(0.05, gt=0.0)
        """Distance (m) of the estimate from the placement at which the base has arrived."""
        yaw_tolerance: float = Field(0.05, gt=0.0)
        """Heading error (rad) at which the base has turned to the placement's heading."""
        joint_tolerance: float = Field(0.01, gt=0.0)
        """Largest joint error (rad) at which the arm has reached the placement's angles."""
        look_poses: tuple[tuple[float, float, float, float, float, float], ...] = LOOK_POSES
        """Arm angles (rad) of the central ground-looking poses (none: M is used as the scan left it)."""
        look_pan: tuple[float, ...] = (-0.6, 0.0, 0.6)
        """Offsets (rad) of the first arm joint from each of ``look_poses``, one ground view each (chosen)."""
        stride_px: int = Field(2, ge=1)
        """Every how many depth pixels a ray of a ground view is inserted into M."""
        max_range: float = Field(4.0, gt=0.0)
        """Rays of the ground views are truncated at this range (m)."""
        reach_depth: float | None = Field(0.17, ge=0.0, le=0.5)
        """The placement must also let the arm hold the MAV level this far (m) past the aperture plane and
        ``standoff`` in front of it (the insertion's reach, §IV-D: "the mounted arm workspace reaches the
        aperture"); none: viewing only."""
        relocalize: bool = True
        """At the placement, register a depth frame against M and correct the base estimate by it (the paper's
        SLAM keeps the map and the pose consistent; the wheel odometry alone drifts centimetres on the drive,
        :mod:`.registration`); false: keep the odometry."""
        redrive_distance: float = Field(0.15, gt=0.0)
        """After the relocalisation, the base drives to the placement again when it lies more than this (m) ahead
        (and within 30° of the heading): a wheel slipping on an obstacle the MMS does not sense left it short."""
        max_redrives: int = Field(2, ge=0)
        """At most this many drives again to the placement."""
        reaim: bool = True
        """At the placement (after ``relocalize``), solve the arm's angles again from the base estimate so that the
        camera stands at the placement's camera goal; false: keep the placement's angles."""
        centre_view: bool = True
        """Centre the camera's view across n̂ on the aperture's contour (its bounding box) instead of on m_A."""
        camera: str = "camera"
        """The eye-in-hand RGB-D camera."""

    class Phase(Enum):
        """The approach's phases, in their order (a drive again goes back to ``drive``)."""

        LOOK = "look"
        """The arm through the ground-looking poses, a depth frame from each into M."""
        PLAN = "plan"
        """Placements for the ranked aperture; the best is the goal."""
        DRIVE = "drive"
        """The base drives to the placement (pure pursuit on its estimate)."""
        TURN = "turn"
        """The base turns to the placement's heading."""
        ARM = "arm"
        """The arm to the viewing angles; once there, relocalise and re-aim (once)."""

    robot_kinds = (HasBase, HasArmModel)
    sensors = ("{camera}",)
    claims = ("base", "arm")
    reads = (f"{{robot}}/{APERTURES}", f"{{robot}}/{VOLUMETRIC_MAP}")
    writes = (f"{{robot}}/{PLACEMENT}",)
    phase: Phase

    def start(self) -> None:
        self.placement: Placement | None = None
        self.enter(go(self.Phase.LOOK, event=None))
        self.looks = [np.array(pose) + np.r_[pan, np.zeros(5)] for pose in self.params.look_poses
                      for pan in self.params.look_pan]
        self.arrived_at: float | None = None  # at the present ground-looking pose since
        self.placed_at: float | None = None  # at the placement, arm at its angles, since
        self.view_q: np.ndarray | None = None  # the arm's viewing angles: the placement's, then re-aimed
        self.camera_R: np.ndarray | None = None  # R_nav_optical of the placement's camera goal
        self.settled = False  # relocalised (and re-aimed) at the placement
        self.redrives = 0

    def step(self) -> Status:
        return self.step_phase()

    def _step_drive(self) -> Status | Transition:
        """Drive to the placement's position; there, turn at once."""
        assert self.placement is not None
        p, goal = self.params, self.placement.pose
        left = pursuit_step(self.robot, goal, p.max_speed, p.position_tolerance)
        if left is not None:
            self.feedback_message = f"driving to the placement: {left:.2f} m"
            return Status.RUNNING
        return go(self.Phase.TURN, event=None, at_once=True)

    def _step_turn(self) -> Status | Transition:
        """Turn to the placement's heading; then the arm, at once."""
        assert self.placement is not None
        turning = turn_step(self.robot, float(self.placement.pose[2]), self.params.yaw_tolerance)
        if turning is not None:
            self.feedback_message = f"turning to the placement's heading: {turning:+.2f} rad"
            return Status.RUNNING
        return go(self.Phase.ARM, event=None, at_once=True)

    def _step_arm(self) -> Status | Transition:
        """The base stands at the placement: the arm to the viewing angles, then relocalise and re-aim once."""
        assert self.placement is not None
        goal = self.placement.pose
        estimate = self.robot.estimate()
        distance = float(np.hypot(*(goal[:2] - estimate.position[:2])))
        yaw_error = math.remainder(goal[2] - estimate.yaw, math.tau)
        p = self.params
        view_q = self.placement.q if self.view_q is None else self.view_q
        self.robot.set_joint_targets(view_q)
        joint_error = float(np.max(np.abs(self.robot.joint_positions() - view_q)))
        if joint_error > p.joint_tolerance:
            self.feedback_message = f"arm to the viewing pose: {joint_error:.3f} rad"
            return Status.RUNNING
        if self.placed_at is None:
            estimate = self.robot.estimate()
            phase_event(self, "reached", pose=[round(float(x), 3) for x in (*estimate.position[:2], estimate.yaw)],
                        error_m=round(distance, 3), yaw_error=round(yaw_error, 3),
                        q=[round(float(x), 3) for x in self.robot.joint_positions()])
            milestone(self, "reached the placement", detail=f"{distance:.2f} m off (estimate)")
            self.placed_at = self.now
            if p.relocalize:
                self.feedback_message = "at the placement: relocalising against M"
                return Status.RUNNING
        if not self.settled:
            if p.relocalize and not self._relocalize():
                return Status.RUNNING
            self.settled = True
            redrive = self._redrive()
            if redrive is not None:
                return redrive
            if p.reaim and self._reaim():
                self.feedback_message = "re-aiming the camera at the placement's goal"
                return Status.RUNNING
        self.feedback_message = f"at the placement ({distance:.2f} m, {yaw_error:+.2f} rad off), aperture in view"
        return Status.SUCCESS

    def _relocalize(self) -> bool:
        """Register one fresh depth frame from the viewing pose against M's surface and correct the base estimate
        by the result (:mod:`.registration`); False while the frame is awaited."""
        assert self.placed_at is not None
        taken = fresh_frame(self.robot, self.params.camera, self.placed_at)
        if taken is None:
            return False
        occupancy = self.read(f"{self.robot_name}/{VOLUMETRIC_MAP}")
        found = relocalize_base(self.robot, sensor_cloud(taken[0], self.params.stride_px, self.params.max_range),
                                occupancy, searched=True)
        phase_event(self, "relocalized", correction=found.summary() if found is not None else None)
        return True

    def _redrive(self) -> Transition | None:
        """Back to ``drive`` when the placement lies more than ``redrive_distance`` ahead of the corrected
        estimate, within 30° of its heading (never behind: pure pursuit would turn the base about with the arm out
        at the wall), at most ``max_redrives`` times; else ``None``."""
        assert self.placement is not None
        p = self.params
        estimate = self.robot.estimate()
        offset = self.placement.pose[:2] - estimate.position[:2]
        c, s = math.cos(estimate.yaw), math.sin(estimate.yaw)
        ahead, aside = c * offset[0] + s * offset[1], -s * offset[0] + c * offset[1]
        if self.redrives >= p.max_redrives or ahead <= p.redrive_distance:
            return None
        if abs(math.atan2(aside, ahead)) > REDRIVE_CONE:
            return None
        self.redrives += 1
        self.placed_at, self.settled = None, False
        self.feedback_message = f"driving to the placement again: {float(np.hypot(*offset)):.2f} m"
        return go(self.Phase.DRIVE, event="redrive", distance=round(float(np.hypot(*offset)), 3))

    def _reaim(self) -> bool:
        """Solve the camera's goal again from the base estimate (:func:`~.placement.aim_camera`); True when the arm
        has to move to the new angles."""
        assert self.placement is not None and self.camera_R is not None
        estimate = self.robot.estimate()
        pose = (*estimate.position[:2], estimate.yaw)
        camera = CameraModel.of_port(self.robot.sensor(self.params.camera))
        p_opt = self.placement.camera_position
        q_now = self.robot.joint_positions()
        q = aim_camera(self.robot.arm_kinematics, camera, self.robot.arm_mount(), pose, float(estimate.position[2]),
                       p_opt, self.camera_R, q_now)
        p_M, q_M = self.robot.arm_base_pose()  # where the camera stands now, as the corrected estimate has it
        p_link, R_link = self.robot.arm_kinematics.forward(q_now, camera.link)
        off = float(np.linalg.norm(p_M + rotation_matrix(q_M) @ (p_link + R_link @ camera.offset) - p_opt))
        phase_event(self, "reaimed", camera_off_m=round(off, 4),
                    q=None if q is None else [round(float(x), 3) for x in q])
        if q is None or float(np.max(np.abs(q - q_now))) <= self.params.joint_tolerance:
            return False
        self.view_q = q
        return True

    def _step_look(self) -> Status | Transition:
        """Move through the ground-looking poses; one new depth frame from each goes into M; then plan at once."""
        occupancy = self.read(f"{self.robot_name}/{VOLUMETRIC_MAP}")
        if occupancy is None:
            self.robot.stop()
            self.feedback_message = "waiting for ranked apertures and the map (aperture_scan)"
            return Status.RUNNING
        if not self.looks:
            return go(self.Phase.PLAN, event=None, at_once=True)
        target = self.looks[0]
        self.robot.set_joint_targets(target)
        if float(np.max(np.abs(self.robot.joint_positions() - target))) > self.params.joint_tolerance:
            self.feedback_message = f"looking at the ground: {len(self.looks)} views to go"
            return Status.RUNNING
        if self.arrived_at is None:
            self.arrived_at = self.now
        taken = fresh_frame(self.robot, self.params.camera, self.arrived_at)
        if taken is not None:
            occupancy.insert(sensor_cloud(taken[0], self.params.stride_px, self.params.max_range))
            phase_event(self, "ground_look", q=[round(float(x), 3) for x in target])
            self.looks.pop(0)
            self.arrived_at = None
        self.feedback_message = f"looking at the ground: {len(self.looks)} views to go"
        return Status.RUNNING

    def _tool_goals(self, target: np.ndarray, normal: np.ndarray) -> list[np.ndarray]:
        """The insertion's tcp poses the placement must reach (none without ``reach_depth``)."""
        depth = self.params.reach_depth
        if depth is None:
            return []
        return [level_insertion_tcp(target, normal, offset) for offset in (self.params.standoff, -depth)]

    def _step_plan(self) -> Status | Transition:
        """Placements for the chosen aperture from the scan's M; the best is the goal."""
        p = self.params
        ranked = self.read(f"{self.robot_name}/{APERTURES}")
        occupancy = self.read(f"{self.robot_name}/{VOLUMETRIC_MAP}")
        if ranked is None or occupancy is None:
            self.robot.stop()
            self.feedback_message = "waiting for ranked apertures and the map (aperture_scan)"
            return Status.RUNNING
        if len(ranked) <= p.rank:
            self.feedback_message = f"{len(ranked)} apertures ranked: no aperture of rank {p.rank}"
            return Status.FAILURE
        aperture = ranked[p.rank]
        estimate = self.robot.estimate()
        refused: Counter[str] = Counter()
        params = PlacementParams(rho=p.rho, half_angle=p.half_angle, samples=p.samples, standoff=p.standoff,
                                 margin=p.margin)
        placements = plan_placements(
            aperture.m_A, aperture.normal_nav, occupancy, self.robot.arm_kinematics,
            CameraModel.of_port(self.robot.sensor(p.camera)), self.robot.arm_mount(),
            (*estimate.position[:2], estimate.yaw), self.robot.joint_positions(), float(estimate.position[2]),
            self.context.rng(f"{self.name}/placement"), params, self._tool_goals(aperture.m_A, aperture.normal_nav),
            refused, aperture.candidate.box_centre_nav if p.centre_view else None,
        )
        phase_event(self, "placement", aperture=[round(float(x), 3) for x in aperture.m_A], feasible=len(placements),
                    placement=placements[0].summary() if placements else None, refused=dict(refused))
        if not placements:
            why = ", ".join(f"{reason} {n}" for reason, n in refused.most_common())
            self.feedback_message = f"no feasible base placement among {p.samples} samples in the cone ({why})"
            return Status.FAILURE
        self.placement = placements[0]
        self.camera_R = camera_goal(aperture.m_A, aperture.normal_nav, p.standoff)[1]
        self.write(f"{self.robot_name}/{PLACEMENT}", self.placement)
        self.robot.stop()
        self.feedback_message = f"placement chosen among {len(placements)} feasible"
        return go(self.Phase.DRIVE, event=None)
