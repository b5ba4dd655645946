"""``explore_volume`` and ``exploration_stuck``: the MMS explores the bounded volume V until no view offers gain.

Arora & Papachristos, §IV-A and Fig. 3: the aperture search "is autonomously triggered once the robot
exploration mission is 'stuck'" — "no feasible exploration routes offer any further exploration gain [29]".
The skill runs receding-horizon next-best-view exploration ([29]; one step: :mod:`.exploration`) with the
MMS's only depth sensor, the eye-in-hand camera:

1. **Look around**: the arm takes the level pose panned by each of ``view_pan`` and the ground-looking poses
   of ``approach_aperture`` panned by each of ``look_pan``; one new depth frame from each goes into M
   (:mod:`.volumetric`), posed by the base estimate and the encoders.
2. **Plan**: the reachable viewpoints of V (:func:`~.exploration.plan_viewpoints`), best gain · exp(−λ c)
   first; none with gain ≥ ``stuck_gain``: stuck.
3. **Go**: the arm folds back to the angles it had when the skill started, the base turns toward the
   viewpoint, drives there on its estimate (pure pursuit) and turns to its heading; then 1. again.

Stuck, the arm folds back, the base drives back to the first view's pose (``end_at_start``, if that drive is
clear in M) and turns to ``end_yaw`` (if given): the skill succeeds. With ``relocalize``, a level frame once
back at the start is registered against the surface M kept and corrects the base estimate
(:mod:`.registration`; event ``relocalized``). Past
``max_views`` look-arounds without being stuck it fails.

What it senses: the eye-in-hand depth frames, the base estimate, the arm encoders and the camera's
intrinsics. Blackboard: writes ``{robot}/volumetric_map`` (M; one already there is extended, and
``aperture_scan`` extends this one) and ``{robot}/exploration``, the :class:`ExplorationRecord` that
``exploration_stuck`` plans with. Events: ``state_change`` with phase ``explore_view`` (each look-around:
the base estimate, the unknown volume left in V), ``explore_goal`` (the viewpoint chosen, how many
were feasible), ``exploration_stuck`` (the views made, the unknown volume left) and ``explore_return``
(``end_at_start``'s drive back).

The condition ``exploration_stuck`` holds when, from where the robot's estimate stands now, the plan over M
finds no viewpoint with gain ≥ ``stuck_gain`` (the settings of the exploration that ran; it does not hold
before one has run). It plans again only when M or the estimate changed.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from enum import Enum
from typing import Any, ClassVar

import numpy as np
from py_trees.common import Status
from pydantic import Field, field_validator, model_validator

from marsupial.api.capabilities import HasArmModel, HasBase
from marsupial.trees.phases import Phased, Transition, go, phase_event
from marsupial.trees.skill import Condition, NodeParams, Skill

from ..navigation import Footprint
from .approach import LOOK_POSES
from .base_drive import pursuit_step, turn_step
from .detection import DepthFrame
from .exploration import ExplorationParams, GainGrid, Viewpoint, drive_clear, outside_body, plan_viewpoints
from .registration import relocalize_base
from .scan import LEVEL_POSE, VOLUMETRIC_MAP, fresh_frame
from .volumetric import VolumetricMap, sensor_cloud

EXPLORATION = "exploration"
"""Blackboard key (under the robot's name) of the :class:`ExplorationRecord`."""

Pose6 = tuple[float, float, float, float, float, float]
MAX_VOXELS = 2e7
"""Largest V, in voxels of M (its states are held densely while planning: 20 MB; the mission's V has 0.66 M)."""


@dataclass
class ExplorationRecord:
    """What ``explore_volume`` explored with: its settings, the camera's position in the base frame (m) at the
    look-around's central pose, the base poses ``(x, y, yaw)`` (nav, m, rad) it viewed from, whether it got stuck."""

    params: ExplorationParams
    camera_offset: np.ndarray
    visited: list[np.ndarray] = field(default_factory=list)
    stuck: bool = False


def base_pose(robot: Any) -> tuple[np.ndarray, float]:
    """The base estimate as ``(x, y, yaw)`` (nav, m, rad) and its height (m)."""
    estimate = robot.estimate()
    return np.array([*estimate.position[:2], estimate.yaw]), float(estimate.position[2])


class ExploreVolume(Phased, Skill["ExploreVolume.Params"]):
    """Explore the bounded volume V with the eye-in-hand camera, next best view after view, until stuck."""

    class Params(NodeParams):
        bounds: tuple[tuple[float, float, float], tuple[float, float, float]]
        """V: corners ``[[x, y, z], [x, y, z]]`` (nav frame of the base estimate, m), low then high."""
        stuck_gain: float = Field(1.5, gt=0.0)
        """A view must see this much unknown volume (m³) in V; no reachable one does: stuck (chosen: about a
        tenth of the approach area's volume)."""
        clearance: float = Field(1.2, ge=0.0)
        """Least distance (m) of a viewpoint's base centre from anything occupied (the camera, 1.06 m ahead of
        the base at the level pose, keeps 0.14 m to the surface it looks at, beyond its 0.1 m near clip)."""
        spacing: float = Field(0.3, ge=0.05)
        """Distance (m) between viewpoint positions."""
        headings: int = Field(8, ge=1, le=64)
        """Yaws per viewpoint position."""
        view_range: float = Field(3.0, gt=0.0, le=10.0)
        """Unknown cells count toward a view's gain up to this far (m) from the camera."""
        lam: float = Field(0.5, ge=0.0)
        """λ (1/m) of the score gain · exp(−λ c) ([29])."""
        max_views: int = Field(6, ge=1, le=100)
        """Look-arounds at most; still not stuck after them: FAILURE."""
        end_at_start: bool = False
        """Once stuck, drive back to where the exploration began (if the drive is clear in M): ``aperture_scan``'s
        poses are made for a camera about 1.3 m from the structure, the standoff the MMS arrived at."""
        end_yaw: float | None = None
        """Heading (rad, nav) the base turns to once stuck, after ``end_at_start`` (none: it stays as it is)."""
        level_pose: Pose6 = LEVEL_POSE
        """Arm angles (rad) of the central level view."""
        view_pan: tuple[float, ...] = Field((-0.6, 0.0, 0.6), min_length=1)
        """Offsets (rad) of the first arm joint from ``level_pose``, one level view each."""
        look_poses: tuple[Pose6, ...] = LOOK_POSES
        """Arm angles (rad) of the central ground-looking views (the ground the base would drive on)."""
        look_pan: tuple[float, ...] = (-0.6, 0.0, 0.6)
        """Offsets (rad) of the first arm joint from each of ``look_poses``."""
        max_speed: float = Field(0.3, gt=0.0)
        """Base speed limit (m/s)."""
        position_tolerance: float = Field(0.05, gt=0.0)
        """Distance (m) of the estimate from a viewpoint at which the base has arrived."""
        yaw_tolerance: float = Field(0.05, gt=0.0)
        """Heading error (rad) at which a turn has ended."""
        joint_tolerance: float = Field(0.01, gt=0.0)
        """Largest joint error (rad) at which the arm has reached a pose."""
        footprint: tuple[float, float, float] = (0.495, 0.495, 0.335)
        """Front, rear, half-width (m) of the base rectangle about ``base_footprint`` (mms.urdf's 0.99 × 0.67 m)."""
        body_margin: float = Field(0.05, ge=0.0)
        """Returns within the rectangle inflated by this (m) ..."""
        body_height: float = Field(1.0, gt=0.0)
        """... and lower than this (m) above the ground are the robot itself: not inserted into M."""
        resolution: float = Field(0.03, gt=0.0)
        """Voxel edge of M (m) when no M is on the blackboard."""
        stride_px: int = Field(2, ge=1)
        """Every how many depth pixels a ray is inserted into M."""
        max_range: float = Field(4.0, gt=0.0)
        """Rays are truncated at this range (m)."""
        relocalize: bool = True
        """Back at the start (``end_at_start``), register a level frame against the surface M kept, the first
        look-around's included, and correct the base estimate by it (:mod:`.registration`; the paper's MMS has SLAM,
        ours wheel odometry); false: keep the odometry. Views of unknown space have little of M to register
        against, so the frames between are not registered."""
        horizon: float | None = Field(1.0, gt=0.0)
        """Receding horizon (m): views farther than this from the base are not planned (none: all of V; chosen:
        short drives keep the odometry's drift small, it drifted up to 14 cm over 5–6 m)."""
        camera: str = "camera"
        """The eye-in-hand RGB-D camera."""

        @field_validator("bounds", "look_poses", mode="before")
        @classmethod
        def _nested_lists(cls, value: Any) -> Any:
            return tuple(tuple(v) if isinstance(v, list) else v for v in value) if isinstance(value, list | tuple) \
                else value

        @model_validator(mode="after")
        def _low_below_high(self) -> ExploreVolume.Params:
            if any(lo >= hi for lo, hi in zip(*self.bounds, strict=True)):
                raise ValueError(f"bounds: each low corner coordinate must be below the high one, got {self.bounds}")
            voxels = math.prod((hi - lo) / self.resolution for lo, hi in zip(*self.bounds, strict=True))
            if voxels > MAX_VOXELS:
                raise ValueError(f"bounds: V holds {voxels:.3g} voxels of {self.resolution} m, at most "
                                 f"{MAX_VOXELS:.0e} (a smaller V or a coarser resolution)")
            return self

    class Phase(Enum):
        """look → plan → fold → face → drive → turn → look …; stuck: [fold → face → drive → turn →] end [→ final]."""

        LOOK = "look"
        """The arm through the look-around's poses, a depth frame from each into M."""
        PLAN = "plan"
        """The next best view, or stuck."""
        FOLD = "fold"
        """The arm back to its travelling angles."""
        FACE = "face"
        """The base turns toward the viewpoint."""
        DRIVE = "drive"
        """The base drives to it."""
        TURN = "turn"
        """The base turns to its heading."""
        END = "end"
        """Stuck: the arm folded, the base turns to ``end_yaw``."""
        FINAL = "final"
        """Stuck, back at the start: one level frame registered against M."""

    robot_kinds = (HasBase, HasArmModel)
    sensors = ("{camera}",)
    claims = ("base", "arm")
    writes = (f"{{robot}}/{VOLUMETRIC_MAP}", f"{{robot}}/{EXPLORATION}")
    phase: Phase

    def start(self) -> None:
        p = self.params
        known = self.read(f"{self.robot_name}/{VOLUMETRIC_MAP}")
        self.occupancy: VolumetricMap = known if known is not None else VolumetricMap(p.resolution)
        self.write(f"{self.robot_name}/{VOLUMETRIC_MAP}", self.occupancy)
        self.fold = self.robot.joint_positions().copy()  # the arm's travelling angles
        self.record: ExplorationRecord | None = None
        self.goal: Viewpoint | None = None
        self.returning = False  # stuck, on the way back to the first view
        self.enter(go(self.Phase.LOOK, event=None))
        self._new_look()

    def _new_look(self) -> None:
        p = self.params
        level = [np.array(p.level_pose) + np.r_[pan, np.zeros(5)] for pan in p.view_pan]
        ground = [np.array(pose) + np.r_[pan, np.zeros(5)] for pose in p.look_poses for pan in p.look_pan]
        self.looks = level + ground
        self.central = int(np.argmin(np.abs(p.view_pan)))  # the level view nearest ahead gives the camera offset
        self.look_index = 0
        self.arrived_at: float | None = None

    def step(self) -> Status:
        return self.step_phase()

    def _step_look(self) -> Status | Transition:
        """The arm through the look-around's poses; one new depth frame from each into M."""
        left = len(self.looks) - self.look_index
        self.feedback_message = f"looking around: {left} views to go"
        frame = self._frame_at(self.looks[self.look_index])
        if frame is None:
            return Status.RUNNING
        pose, z = base_pose(self.robot)
        footprint = Footprint(*(d + self.params.body_margin for d in self.params.footprint))
        cloud = sensor_cloud(frame, self.params.stride_px, self.params.max_range)
        self.occupancy.insert(outside_body(cloud, pose, z, footprint, self.params.body_height))
        if self.look_index == self.central and self.record is None:
            self.record = ExplorationRecord(self._settings(), self._camera_offset(frame.position))
            self.write(f"{self.robot_name}/{EXPLORATION}", self.record)
        self.look_index += 1
        self.arrived_at = None
        if self.look_index == len(self.looks):
            return go(self.Phase.PLAN, event=None)
        return Status.RUNNING

    def _frame_at(self, target: np.ndarray) -> DepthFrame | None:
        """Hold the arm at ``target`` (rad); once there, the first depth frame taken since (posed), else ``None``."""
        self.robot.set_joint_targets(target)
        if float(np.max(np.abs(self.robot.joint_positions() - target))) > self.params.joint_tolerance:
            return None
        if self.arrived_at is None:
            self.arrived_at = self.now
        taken = fresh_frame(self.robot, self.params.camera, self.arrived_at)
        return taken[0] if taken is not None else None

    def _relocalize(self, frame: DepthFrame) -> None:
        """Register ``frame`` against M's surface and correct the base estimate (:mod:`.registration`)."""
        found = relocalize_base(self.robot, sensor_cloud(frame, self.params.stride_px, self.params.max_range),
                                self.occupancy)
        phase_event(self, "relocalized", correction=found.summary() if found is not None else None)

    def _camera_offset(self, camera: np.ndarray) -> np.ndarray:
        """The camera's position (m) in ``base_footprint``'s frame, from the base estimate."""
        pose, z = base_pose(self.robot)
        c, s = math.cos(pose[2]), math.sin(pose[2])
        d = np.asarray(camera, dtype=float) - np.r_[pose[:2], z]
        return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1], d[2]])

    def _settings(self) -> ExplorationParams:
        """The planning settings: the node's, with the view's half-angles from the camera's intrinsics."""
        p = self.params
        intrinsics = self.robot.sensor(p.camera).intrinsics
        K = np.asarray(intrinsics.K, dtype=float)
        half_h = max((abs(x) for x in p.view_pan), default=0.0) + math.atan2(0.5 * intrinsics.width, K[0, 0])
        half_v = math.atan2(0.5 * intrinsics.height, K[1, 1])
        return ExplorationParams(bounds=p.bounds, spacing=p.spacing, headings=p.headings, clearance=p.clearance,
                                 view_range=p.view_range, half_fov=(half_h, half_v), lam=p.lam,
                                 stuck_gain=p.stuck_gain, footprint=p.footprint, horizon=p.horizon)

    def _step_plan(self) -> Status | Transition:
        """The next best view, or stuck."""
        assert self.record is not None, "the look-around's level view gives the camera offset"
        pose, z = base_pose(self.robot)
        self.record.visited.append(pose)
        grid = GainGrid(self.occupancy, self.params.bounds, self.record.params.cell_voxels)
        unknown = grid.unknown_volume
        phase_event(self, "explore_view", view=len(self.record.visited), pose=[round(float(x), 3) for x in pose],
                    unknown_m3=round(unknown, 3))
        views = plan_viewpoints(self.occupancy, pose, self.record.camera_offset, self.record.params,
                                self.record.visited, z, grid)
        if not views:
            self.record.stuck = True
            phase_event(self, "exploration_stuck", views=len(self.record.visited), unknown_m3=round(unknown, 3))
            return self._end(pose, z)
        if len(self.record.visited) >= self.params.max_views:
            self.feedback_message = (f"not stuck after {len(self.record.visited)} views: {len(views)} still offer "
                                     f"up to {views[0].gain:.2f} m³ ({unknown:.2f} m³ unknown in V)")
            return Status.FAILURE
        self.goal = views[0]
        return go(self.Phase.FOLD, event="explore_goal", goal=self.goal.summary(), feasible=len(views))

    def _end(self, pose: np.ndarray, z: float) -> Transition:
        """Stuck: back to the first view's pose (``end_at_start``, if the drive is clear in M), else end here."""
        assert self.record is not None
        first = self.record.visited[0]
        far = np.hypot(*(first[:2] - pose[:2])) > self.params.position_tolerance
        if self.params.end_at_start and far and drive_clear(self.occupancy, pose, first, self.record.params, z):
            self.goal, self.returning = Viewpoint(first, 0.0, 0.0, 0.0), True
            return go(self.Phase.FOLD, event="explore_return", goal=self.goal.summary())
        return go(self.Phase.END, event=None)

    def _folded(self) -> bool:
        """Stop the base, hold the arm at its travelling angles; whether it is there."""
        self.robot.stop()
        self.robot.set_joint_targets(self.fold)
        error = float(np.max(np.abs(self.robot.joint_positions() - self.fold)))
        if error > self.params.joint_tolerance:
            self.feedback_message = f"folding the arm: {error:.3f} rad"
            return False
        return True

    def _step_fold(self) -> Status | Transition:
        """The arm back to its travelling angles; then on to the viewpoint."""
        if not self._folded():
            return Status.RUNNING
        return go(self.Phase.FACE, event=None)

    def _step_end(self) -> Status | Transition:
        """Stuck, the arm folded: the final turn, then (back at the start, ``relocalize``) the final frame."""
        if not self._folded():
            return Status.RUNNING
        end_yaw = self.params.end_yaw
        if end_yaw is not None and turn_step(self.robot, end_yaw, self.params.yaw_tolerance) is not None:
            self.feedback_message = "stuck: turning to the final heading"
            return Status.RUNNING
        if self.returning and self.params.relocalize:
            self.arrived_at = None
            return go(self.Phase.FINAL, event=None)
        return self._stuck()

    def _stuck(self) -> Status:
        assert self.record is not None
        self.feedback_message = f"stuck after {len(self.record.visited)} views: no reachable view offers gain"
        return Status.SUCCESS

    def _step_final(self) -> Status:
        """Back at the start: the arm at the level pose, one frame registered against M (the drive back drifted)."""
        self.feedback_message = "stuck, back at the start: relocalising against M"
        frame = self._frame_at(np.asarray(self.params.level_pose, dtype=float))
        if frame is None:
            return Status.RUNNING
        self._relocalize(frame)
        return self._stuck()

    def _step_face(self) -> Status | Transition:
        """Turn toward the viewpoint; then drive there at once."""
        assert self.goal is not None
        p, goal = self.params, self.goal.pose
        pose, _ = base_pose(self.robot)
        offset = goal[:2] - pose[:2]
        heading = math.atan2(offset[1], offset[0]) if np.hypot(*offset) > p.position_tolerance else pose[2]
        if turn_step(self.robot, heading, p.yaw_tolerance) is not None:
            self.feedback_message = "turning toward the next view"
            return Status.RUNNING
        return go(self.Phase.DRIVE, event=None, at_once=True)

    def _step_drive(self) -> Status | Transition:
        """Drive to the viewpoint (pure pursuit on the estimate); then turn to its heading at once."""
        assert self.goal is not None
        p, goal = self.params, self.goal.pose
        left = pursuit_step(self.robot, goal, p.max_speed, p.position_tolerance)
        if left is not None:
            self.feedback_message = f"driving to the next view: {left:.2f} m"
            return Status.RUNNING
        return go(self.Phase.TURN, event=None, at_once=True)

    def _step_turn(self) -> Status | Transition:
        """Turn to the viewpoint's heading; then look around (or, back at the start, end)."""
        assert self.goal is not None
        if turn_step(self.robot, float(self.goal.pose[2]), self.params.yaw_tolerance) is not None:
            self.feedback_message = "turning to the next view's heading"
            return Status.RUNNING
        if self.returning:
            return go(self.Phase.END, event=None)
        self._new_look()
        return go(self.Phase.LOOK, event=None)


class ExplorationStuck(Condition["ExplorationStuck.Params"]):
    """Holds when no reachable viewpoint of V offers gain, planned over M from the robot's estimate now."""

    class Params(NodeParams):
        stuck_gain: float | None = Field(None, gt=0.0)
        """Gain (m³) a view must offer (none: the exploration's ``stuck_gain``)."""

    primary: ClassVar[str] = "stuck_gain"
    robot_kinds = (HasBase, HasArmModel)
    reads = (f"{{robot}}/{EXPLORATION}", f"{{robot}}/{VOLUMETRIC_MAP}")
    _key: tuple[Any, ...] | None = None  # (M, its revision, the estimate) the last plan was made for
    _stuck = False

    def check(self) -> bool:
        record = self.read(f"{self.robot_name}/{EXPLORATION}")
        occupancy = self.read(f"{self.robot_name}/{VOLUMETRIC_MAP}")
        if record is None or occupancy is None:
            return False
        pose, z = base_pose(self.robot)
        key = (id(occupancy), occupancy.revision, tuple(np.round(pose, 2)))
        if self._key != key:
            params = record.params
            if self.params.stuck_gain is not None:
                params = dataclasses.replace(params, stuck_gain=self.params.stuck_gain)
            self._key = key
            self._stuck = not plan_viewpoints(occupancy, pose, record.camera_offset, params, record.visited, z)
        return self._stuck
