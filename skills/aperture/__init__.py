"""Micro-scout deployment through constricted apertures (Arora & Papachristos): the perception algorithms.

Plain functions with numpy in and out, fed with what the MMS's onboard
interface delivers (eye-in-hand depth frames, the base estimate, the arm
encoders and the arm's URDF model):

- :mod:`.detection` — aperture detection (§IV-B): N-frame point-cloud window
  in the inertially aligned frame F_I, RANSAC model plane, fronto-parallel
  depth image I, binary → dilation → Canny → contours, hollow and wide
  enough candidates;
- :mod:`.silhouette` — the MAV's fronto-parallel contour C_m at a plane depth;
- :mod:`.profile` — aperture profile analysis (§IV-E, Algorithm 1): launch
  configurations {p, θ} at which C_m fits inside the aperture contour C_a;
- :mod:`.volumetric` — the volumetric map M (OctoMap octree of occupied, free
  and unknown voxels) from the posed depth frames;
- :mod:`.belief` — the log-odds aperture belief L_a over M's voxels (§IV-C, eq. 1);
- :mod:`.ranking` — candidates tracked across windows, ranked by L_a;
- :mod:`.placement` — base placement (§IV-D): cone samples checked against M and by the arm's IK;
- :mod:`.launch_pose` — pre-launch pose ξ_MAV, the Phase I goal g, the insertion line, the launch attitude
  check (§IV-E output, §IV-F);
- :mod:`.arm_motion` — collision-free arm motion (§IV-F): python-fcl checks of the arm (and what it
  carries) against M and the robot, OMPL RRT* in joint space, seeded;
- :mod:`.exploration` — receding-horizon next-best-view over M in the bounded volume V (§III Problem 1): viewpoints,
  gain, stuck;
- :mod:`.explore` — the ``explore_volume`` skill and the ``exploration_stuck`` condition;
- :mod:`.base_drive` — the base driven to a pose on its estimate (pure pursuit, then the heading);
- :mod:`.scan` — the ``aperture_scan`` skill: arm scanning poses → M, L_a, ranked candidates;
- :mod:`.approach` — the ``approach_aperture`` skill: a placement for a ranked aperture, driven to;
- :mod:`.analyze` — the ``analyze_aperture`` skill: the aperture detected again from there, its profile
  analysis and launch plans.
"""

from marsupial.api.silhouette import mav_contour, mav_silhouette

from .arm_motion import ArmCollisionModel, ArmPlanParams, plan_arm_path
from .belief import ApertureBelief, BeliefParams, aperture_region
from .detection import ApertureCandidate, DepthFrame, DetectionParams, detect_apertures, eye_in_hand_frame
from .launch_pose import LaunchParams, LaunchPlan, attitude_ok, plan_launch, plan_launches, pre_launch_pose
from .placement import CameraModel, Placement, PlacementParams, plan_placements
from .profile import LaunchConfiguration, ProfileParams, profile_analysis
from .ranking import RankedAperture, rank_apertures
from .volumetric import VolumetricMap, sensor_cloud

__all__ = [
    "ApertureBelief", "ApertureCandidate", "ArmCollisionModel", "ArmPlanParams", "BeliefParams", "CameraModel",
    "DepthFrame", "DetectionParams", "LaunchConfiguration", "LaunchParams", "LaunchPlan", "Placement",
    "PlacementParams", "ProfileParams", "RankedAperture", "VolumetricMap", "aperture_region", "attitude_ok",
    "detect_apertures", "eye_in_hand_frame", "mav_contour", "mav_silhouette", "plan_arm_path", "plan_launch",
    "plan_launches", "plan_placements", "pre_launch_pose", "profile_analysis", "rank_apertures", "sensor_cloud",
]
