"""``analyze_aperture``: from the approach's vantage point, the aperture's profile analysis and launch plans.

Arora & Papachristos, §IV-E: once the MMS stands at its placement with the
aperture in the eye-in-hand camera's view (``approach_aperture``), the
aperture is detected again in a window of N fresh depth frames (§IV-B,
:func:`~.detection.detect_apertures`); the detection nearest the aperture
the ranking put first is kept, its region in the fronto-parallel image I and
the MAV's contour C_m at the plane's depth go through Algorithm 1
(:func:`~.profile.profile_analysis`), and each valid configuration becomes a
pre-launch pose and the Phase I–III set-points (:func:`~.launch_pose.plan_launches`),
kept when the launch attitude is within α_launch.

What it senses: the camera's depth frames posed by the arm encoders, the arm
model and the base estimate (:func:`~.scan.fresh_frame`), and the ranking
``aperture_scan`` wrote. It holds the arm where the approach left it. Its
frames also go into the volumetric map M: M was built before the base drove
to the placement, and the odometry's drift on the way (centimetres) would
otherwise leave the arm's collision checks against a wall that is not quite
where the camera now sees it.

Blackboard: reads ``{robot}/apertures`` and ``{robot}/volumetric_map`` (updated in place);
writes ``{robot}/launch_plans``, the
feasible :class:`~.launch_pose.LaunchPlan` list, best first. Events: a
``state_change`` with phase ``profile`` (the detection's centre, how many
configurations (their angles θ, degrees) and feasible plans, the best plan). SUCCESS with at least
one plan; FAILURE when the ranking is empty, the aperture is not detected
again near where it was ranked, or the MAV fits nowhere in it. Metres, radians, the navigation frame.
"""

from __future__ import annotations

import math

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.api.capabilities import HasArmModel
from marsupial.api.silhouette import mav_contour
from marsupial.trees.phases import phase_event
from marsupial.trees.skill import NodeParams, Skill

from .detection import DepthFrame, DetectionParams, detect_apertures
from .launch_pose import LaunchParams, plan_launches
from .profile import ProfileParams, profile_analysis
from .scan import APERTURES, VOLUMETRIC_MAP, fresh_frame
from .volumetric import sensor_cloud

LAUNCH_PLANS = "launch_plans"
"""Blackboard key (under the robot's name) of the feasible launch plans, best first."""


class AnalyzeAperture(Skill["AnalyzeAperture.Params"]):
    """Detect the ranked aperture again, run its profile analysis (Algorithm 1) and plan the launches."""

    class Params(NodeParams):
        n_frames: int = Field(3, ge=1)
        """N, fresh depth frames of the detection window (§IV-B)."""
        same_aperture: float = Field(0.15, gt=0.0)
        """The detection must lie this close (m) to the ranked aperture's centre."""
        clearance_px: float = Field(ProfileParams().clearance_px, ge=0.0)
        """Pixels C_m must keep from C_a in the profile analysis."""
        centre_radius_px: float = Field(ProfileParams().centre_radius_px, ge=0.0, le=200.0)
        """Step iv of the profile analysis (a departure, :mod:`.profile`): how far (px) a configuration may be moved
        to keep the MAV off the rim; 0: Algorithm 1's configurations as found."""
        stride_px: int = Field(2, ge=1)
        """Every how many depth pixels of each frame a ray is inserted into M."""
        max_range: float = Field(4.0, gt=0.0)
        """Rays inserted into M are truncated at this range (m)."""
        camera: str = "camera"
        """The eye-in-hand RGB-D camera."""

    robot_kinds = (HasArmModel,)
    sensors = ("{camera}",)
    claims = ("arm",)  # held still at the approach's viewing pose while the frames are taken
    reads = (f"{{robot}}/{APERTURES}", f"{{robot}}/{VOLUMETRIC_MAP}")
    writes = (f"{{robot}}/{LAUNCH_PLANS}",)

    def start(self) -> None:
        self.robot.hold_arm()
        self.frames: list[DepthFrame] = []
        self.last_stamp = self.now  # frames taken from now on: the arm stands at the approach's pose

    def step(self) -> Status:
        ranked = self.read(f"{self.robot_name}/{APERTURES}")
        if ranked is None:
            self.feedback_message = "waiting for aperture_scan's ranking"
            return Status.RUNNING
        if not ranked:
            self.feedback_message = "no ranked aperture to analyse"
            return Status.FAILURE
        taken = fresh_frame(self.robot, self.params.camera, self.last_stamp)
        if taken is not None:
            frame, self.last_stamp = taken
            self.frames.append(frame)
            occupancy = self.read(f"{self.robot_name}/{VOLUMETRIC_MAP}")
            if occupancy is not None:  # the structure as seen from here: M was built before the base drove
                occupancy.insert(sensor_cloud(frame, self.params.stride_px, self.params.max_range))
        if len(self.frames) < self.params.n_frames:
            self.feedback_message = f"collecting depth frames: {len(self.frames)}/{self.params.n_frames}"
            return Status.RUNNING
        return self._analyse(np.asarray(ranked[0].centre_nav))

    def _analyse(self, centre: np.ndarray) -> Status:
        p = self.params
        candidates = detect_apertures(self.frames, DetectionParams(n_frames=p.n_frames))
        near = [c for c in candidates if float(np.linalg.norm(c.centre_nav - centre)) <= p.same_aperture]
        if not near:
            self.feedback_message = (f"the aperture at ({', '.join(f'{x:.2f}' for x in centre)}) is not detected "
                                     f"again ({len(candidates)} candidates elsewhere)")
            phase_event(self, "profile", detected=False, candidates=len(candidates))
            return Status.FAILURE
        found = min(near, key=lambda c: float(np.linalg.norm(c.centre_nav - centre)))
        c_m = mav_contour(found.view.plane_depth, found.view.K)
        profile = ProfileParams(clearance_px=p.clearance_px, centre_radius_px=p.centre_radius_px)
        configs = profile_analysis(found.mask(), c_m, profile)
        plans = plan_launches(found, configs, LaunchParams())
        self.write(f"{self.robot_name}/{LAUNCH_PLANS}", plans)
        phase_event(self, "profile", detected=True, centre=[round(float(x), 3) for x in found.centre_nav],
                    configurations=len(configs), feasible=len(plans),
                    angles_deg=[round(math.degrees(c.angle), 1) for c in configs],
                    best=plans[0].summary() if plans else None)
        if not plans:
            self.feedback_message = f"the MAV fits nowhere in the aperture ({len(configs)} configurations, none level)"
            return Status.FAILURE
        self.feedback_message = f"{len(plans)} launch plans of {len(configs)} configurations"
        return Status.SUCCESS
