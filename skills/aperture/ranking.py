"""Candidate apertures across frames and their ranking by the belief L_a (Arora & Papachristos, §IV-C, §IV-D).

The detections of successive windows are the same aperture when their
centres (navigation frame) lie within ``radius`` of each other: an
:class:`ApertureTrack` keeps the newest detection of each. A track's score
is the mean L_a (log-odds, eq. 1) over the voxels of its region that M
holds free, a voxel the belief never reached counting as the prior 0; the
tracks are ranked by it, "the most consistent candidate aperture" first.
Its map point m_A (§IV-D) is the voxel of highest L_a in the region that M sees through along n̂; of several
tied, the one farthest from M's occupied voxels, then the one nearest their centroid. The paper takes the voxel
of highest L_a; at a non-convex opening (a U) the tied voxels' centroid can lie on the wall and the ties
themselves at the rim, where a voxel free by M may have an occupied one in front of it: the approach's sight
line then fails for every base placement.

Frames and units: the navigation frame of the base estimate, metres; scores
in log-odds.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from .belief import ApertureBelief
from .detection import ApertureCandidate
from .placement import sight_clear
from .volumetric import FREE, VolumetricMap, voxel_centres

SIGHT_M = 0.5
"""Distance (m) along n̂ from which m_A must be in M's sight: the placement's default camera standoff."""
MAX_SIGHT_CHECKS = 400
"""Voxels tried, best first, for one seen through before m_A falls back to the best."""


@dataclass
class ApertureTrack:
    """One aperture as detected so far: its newest detection and how many windows detected it.

    Attributes:
        candidate: the newest detection.
        region_nav: its region's points (nav frame, m; :func:`~.belief.aperture_region`).
        detections: windows that detected it.
    """

    candidate: ApertureCandidate = field(repr=False)
    region_nav: np.ndarray = field(repr=False)
    detections: int = 1

    @property
    def centre_nav(self) -> np.ndarray:
        """The newest detection's centre (nav frame, m)."""
        return self.candidate.centre_nav


@dataclass(frozen=True)
class RankedAperture:
    """A tracked aperture with its belief score.

    Attributes:
        score: mean L_a (log-odds) over the free voxels of its region.
        m_A: the region's voxel of highest L_a seen through along n̂ (nav frame, m; ties: the one farthest from
            the occupied voxels, then nearest their centroid), the approach's target (§IV-D).
        centre_nav: the newest detection's contour centre on the plane (nav frame, m).
        normal_nav: its plane normal n̂ toward the sensor (nav frame).
        detections: windows that detected it.
        candidate: the newest detection (contour, fronto-parallel view).
    """

    score: float
    m_A: np.ndarray
    centre_nav: np.ndarray
    normal_nav: np.ndarray
    detections: int
    candidate: ApertureCandidate = field(repr=False)

    def summary(self) -> dict[str, object]:
        """A JSON-ready record (scores and positions rounded: log-odds, m)."""
        return {
            "score": round(self.score, 3), "detections": self.detections,
            "m_A": [round(float(x), 3) for x in self.m_A], "centre": [round(float(x), 3) for x in self.centre_nav],
            "normal": [round(float(x), 3) for x in self.normal_nav],
        }


def associate(tracks: list[ApertureTrack], candidate: ApertureCandidate, region_nav: np.ndarray,
              radius: float) -> ApertureTrack:
    """Add a detection to the track whose centre lies within ``radius`` (m) of its own, or start one."""
    centre = candidate.centre_nav
    near = [t for t in tracks if np.linalg.norm(t.centre_nav - centre) <= radius]
    if not near:
        tracks.append(ApertureTrack(candidate, region_nav))
        return tracks[-1]
    track = min(near, key=lambda t: float(np.linalg.norm(t.centre_nav - centre)))
    track.candidate, track.region_nav, track.detections = candidate, region_nav, track.detections + 1
    return track


def _occupied_tree(occupancy: VolumetricMap) -> cKDTree | None:
    """A KD-tree over the centres of M's occupied voxels (nav, m); none while M holds none."""
    centres, _ = occupancy.occupied_boxes()
    return cKDTree(centres) if len(centres) else None


def _m_A(voxels: np.ndarray, l_a: np.ndarray, normal: np.ndarray, occupancy: VolumetricMap,
         occupied: cKDTree | None) -> np.ndarray:
    """The map point m_A of a region's free voxels ``voxels`` ``(n, 3)`` (nav, m) with beliefs ``l_a``.

    The voxel of highest L_a (§IV-D) through which M sees along n̂ ``normal`` from :data:`SIGHT_M` (the check
    :func:`~.placement.plan_placements` makes first); of several tied, the one farthest from an occupied voxel
    (clearances within half a voxel equal), then nearest their centroid. None seen through: the first so ranked.
    """
    clearance = occupied.query(voxels)[0] if occupied is not None else np.zeros(len(voxels))
    steps = np.floor(clearance / (0.5 * occupancy.resolution))
    to_centroid = np.linalg.norm(voxels - voxels[l_a >= l_a.max() - 1e-6].mean(axis=0), axis=1)
    order = np.lexsort((to_centroid, -steps, -np.round(l_a, 6)))
    for i in order[:MAX_SIGHT_CHECKS]:
        if sight_clear(occupancy, voxels[i] + SIGHT_M * normal, voxels[i], keep_out=2.0 * occupancy.resolution):
            return voxels[i]
    return voxels[order[0]]


def rank_apertures(tracks: list[ApertureTrack], belief: ApertureBelief, occupancy: VolumetricMap
                   ) -> list[RankedAperture]:
    """The tracks ranked by their belief score, highest first; a track with no free voxel scores -inf."""
    ranked = []
    occupied = _occupied_tree(occupancy)
    for track in tracks:
        voxels = voxel_centres(track.region_nav, belief.resolution)
        voxels = voxels[occupancy.state(voxels) == FREE]
        if len(voxels):
            l_a = np.nan_to_num(belief.log_odds(voxels))  # never updated: the prior, 0
            normal = track.candidate.normal_nav / np.linalg.norm(track.candidate.normal_nav)
            score, m_A = float(l_a.mean()), _m_A(voxels, l_a, normal, occupancy, occupied)
        else:
            score, m_A = -np.inf, track.centre_nav
        ranked.append(RankedAperture(score, m_A, track.centre_nav, track.candidate.normal_nav, track.detections,
                                     track.candidate))
    return sorted(ranked, key=lambda r: -r.score)
