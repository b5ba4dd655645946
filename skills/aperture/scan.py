"""``aperture_scan``: the MMS sweeps its eye-in-hand camera over the structure ahead and ranks the apertures it sees.

Arora & Papachristos, §IV-B/C: "the eye-in-hand sensor S mounted on the
manipulator arm performs environment scanning motions"; the detections feed
the log-odds aperture belief over the volumetric map M, and "the most
consistent" candidate is ranked first. The arm stops at each scanning pose
(the first joint panned about a level, forward-looking pose); once it is
there, ``n_frames`` new depth frames make a detection window (§IV-B), posed
by the base estimate and the encoders (:func:`~.detection.eye_in_hand_frame`);
the newest frame is inserted into M and, with the window's detections as
hits, into the belief (eq. 1). After the last pose the tracked candidates,
ranked by belief (:func:`~.ranking.rank_apertures`), go to the blackboard.

Blackboard: writes ``{robot}/apertures``, the list of
:class:`~.ranking.RankedAperture` (highest score first), and
``{robot}/volumetric_map``, the map M it built (for base placement,
:mod:`.approach`); an M already there (``explore_volume``'s) is extended,
not replaced (the belief then takes that M's voxel edge, not ``resolution``). Events: a
``state_change`` with phase ``scan_pose`` at each pose (its index and the
candidates the window found) and ``ranked`` at the end (each candidate's
score, map point m_A and centre, nav frame, m). SUCCESS with at least one
ranked candidate, FAILURE when the sweep found none. The arm holds where it
is when the skill ends.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.api.capabilities import HasArmModel
from marsupial.trees.milestones import milestone
from marsupial.trees.phases import phase_event
from marsupial.trees.skill import NodeParams, Skill

from .belief import ApertureBelief, BeliefParams, aperture_region
from .detection import DepthFrame, DetectionParams, detect_apertures, eye_in_hand_frame
from .ranking import ApertureTrack, associate, rank_apertures
from .volumetric import VolumetricMap, sensor_cloud

APERTURES = "apertures"
"""Blackboard key (under the robot's name) of the ranked candidates."""
VOLUMETRIC_MAP = "volumetric_map"
"""Blackboard key (under the robot's name) of the volumetric map M (:class:`~.volumetric.VolumetricMap`)."""

LEVEL_POSE = (0.0, 1.15, 0.2, 0.0, 0.221, 0.0)
"""MMS arm angles (rad) with the camera level, 0.81 m ahead of and 0.40 m above ``arm_base_link``, facing forward."""


def fresh_frame(robot: Any, camera: str, after: float) -> tuple[DepthFrame, float] | None:
    """The camera's newest depth frame, posed (:func:`~.detection.eye_in_hand_frame`), if stamped after ``after`` (s).

    ``robot``: the MMS's onboard interface; returns the frame and its stamp (s), else ``None``.
    """
    reading = robot.sensor(camera).read()
    if reading is None or reading.stamp <= after:
        return None
    image = reading.data
    return eye_in_hand_frame(robot, image.depth, image.K, robot.joint_positions(), camera), reading.stamp


class ApertureScan(Skill["ApertureScan.Params"]):
    """Sweep the eye-in-hand camera through scanning poses, build M and the aperture belief, rank the candidates."""

    class Params(NodeParams):
        level_pose: tuple[float, float, float, float, float, float] = LEVEL_POSE
        """Arm angles (rad) of the central scanning pose (camera level, looking ahead)."""
        pan: tuple[float, ...] = (-0.3, -0.15, 0.0, 0.15, 0.3)
        """Offsets (rad) of the first arm joint from ``level_pose``, one scanning pose each, in order (chosen)."""
        n_frames: int = Field(2, ge=1)
        """N, depth frames of each pose's detection window (§IV-B)."""
        tolerance: float = Field(0.01, gt=0.0)
        """Largest joint error (rad) at which the arm has reached a pose."""
        resolution: float = Field(0.03, gt=0.0)
        """Voxel edge of M and of the belief (m) when no M is on the blackboard; see :mod:`.volumetric` for the
        measured cost."""
        stride_px: int = Field(2, ge=1)
        """Every how many depth pixels a ray is inserted into M."""
        max_range: float = Field(4.0, gt=0.0)
        """Rays are truncated at this range (m)."""
        p_hit: float = Field(0.7, gt=0.5, lt=1.0)
        """p_a of a voxel in a detected aperture (eq. 1)."""
        p_miss: float = Field(0.4, gt=0.0, lt=0.5)
        """p_a of a voxel seen without a detection (eq. 1)."""
        d_a: float = Field(0.1, gt=0.0)
        """d_a (m): depth behind the plane face that a detection's region reaches (Definition 1)."""
        same_aperture_m: float = Field(0.1, gt=0.0)
        """Detections whose centres lie this close (m) are one aperture."""
        camera: str = "camera"
        """The eye-in-hand RGB-D camera."""

    robot_kinds = (HasArmModel,)
    sensors = ("{camera}",)
    claims = ("arm",)
    writes = (f"{{robot}}/{APERTURES}", f"{{robot}}/{VOLUMETRIC_MAP}")

    def start(self) -> None:
        p = self.params
        self.poses = [np.array(p.level_pose) + np.r_[offset, np.zeros(5)] for offset in p.pan]
        self.index = 0
        self.arrived_at: float | None = None
        self.frames: list[DepthFrame] = []
        self.last_stamp = -np.inf
        known = self.read(f"{self.robot_name}/{VOLUMETRIC_MAP}")  # M as exploration left it, extended here
        self.occupancy = known if known is not None else VolumetricMap(p.resolution)
        self.belief = ApertureBelief(self.occupancy.resolution, BeliefParams(p.p_hit, p.p_miss, d_a=p.d_a))
        self.tracks: list[ApertureTrack] = []

    def step(self) -> Status:
        if self.index == len(self.poses):
            return self._rank()
        target = self.poses[self.index]
        self.robot.set_joint_targets(target)
        if float(np.max(np.abs(self.robot.joint_positions() - target))) > self.params.tolerance:
            self.feedback_message = f"moving to scanning pose {self.index + 1}/{len(self.poses)}"
            return Status.RUNNING
        if self.arrived_at is None:
            self.arrived_at = self.now
        self._take_frame()
        if len(self.frames) == self.params.n_frames:
            self._integrate()
            self.index, self.arrived_at, self.frames = self.index + 1, None, []
        self.feedback_message = f"scanning at pose {self.index}/{len(self.poses)}: {len(self.tracks)} candidates"
        return Status.RUNNING

    def _take_frame(self) -> None:
        """Keep the camera's newest frame if it was taken since the arm reached the pose."""
        if self.arrived_at is None:
            return
        taken = fresh_frame(self.robot, self.params.camera, max(self.arrived_at, self.last_stamp))
        if taken is not None:
            frame, self.last_stamp = taken
            self.frames.append(frame)

    def _integrate(self) -> None:
        """Detect in the pose's window; the newest frame into M, then into the belief with the detections' hits."""
        p = self.params
        candidates = detect_apertures(self.frames, DetectionParams(n_frames=p.n_frames))
        cloud = sensor_cloud(self.frames[-1], p.stride_px, p.max_range)
        self.occupancy.insert(cloud)
        regions = [aperture_region(c, self.occupancy.resolution, p.d_a) for c in candidates]
        self.belief.update(cloud, regions, self.occupancy)
        for candidate, region in zip(candidates, regions, strict=True):
            associate(self.tracks, candidate, region, p.same_aperture_m)
        centres = [[round(float(x), 3) for x in c.centre_nav] for c in candidates]
        phase_event(self, "scan_pose", pose=self.index, candidates=centres)

    def _rank(self) -> Status:
        ranked = rank_apertures(self.tracks, self.belief, self.occupancy)
        self.write(f"{self.robot_name}/{APERTURES}", ranked)
        self.write(f"{self.robot_name}/{VOLUMETRIC_MAP}", self.occupancy)
        phase_event(self, "ranked", apertures=[r.summary() for r in ranked])
        if not ranked:
            self.feedback_message = f"no aperture found in {len(self.poses)} scanning poses"
            return Status.FAILURE
        best = ranked[0]
        self.feedback_message = (f"{len(ranked)} apertures ranked; best L_a {best.score:.2f} at "
                                 f"({', '.join(f'{x:.2f}' for x in best.m_A)})")
        milestone(self, f"found {len(ranked)} aperture{'s' if len(ranked) > 1 else ''}",
                  detail=f"best belief L_a {best.score:.2f}")
        return Status.SUCCESS

