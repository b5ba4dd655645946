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
- :mod:`.scan` — the ``aperture_scan`` skill: arm scanning poses → M, L_a, ranked candidates.
"""

from .belief import ApertureBelief, BeliefParams, aperture_region
from .detection import ApertureCandidate, DepthFrame, DetectionParams, detect_apertures, eye_in_hand_frame
from .profile import LaunchConfiguration, ProfileParams, profile_analysis
from .ranking import RankedAperture, rank_apertures
from .silhouette import mav_contour, mav_silhouette
from .volumetric import VolumetricMap, sensor_cloud

__all__ = [
    "ApertureBelief", "ApertureCandidate", "BeliefParams", "DepthFrame", "DetectionParams", "LaunchConfiguration",
    "ProfileParams", "RankedAperture", "VolumetricMap", "aperture_region", "detect_apertures", "eye_in_hand_frame",
    "mav_contour", "mav_silhouette", "profile_analysis", "rank_apertures", "sensor_cloud",
]
