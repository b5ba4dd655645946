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
  configurations {p, θ} at which C_m fits inside the aperture contour C_a.
"""

from .detection import ApertureCandidate, DepthFrame, DetectionParams, detect_apertures, eye_in_hand_frame
from .profile import LaunchConfiguration, ProfileParams, profile_analysis
from .silhouette import mav_contour, mav_silhouette

__all__ = [
    "ApertureCandidate", "DepthFrame", "DetectionParams", "LaunchConfiguration", "ProfileParams",
    "detect_apertures", "eye_in_hand_frame", "mav_contour", "mav_silhouette", "profile_analysis",
]
