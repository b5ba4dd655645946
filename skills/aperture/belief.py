"""The aperture belief L_a over the voxels of M (Arora & Papachristos, §IV-C, eq. 1).

For each voxel m_i a log-odds L_a(m_i) = log[p_a / (1 - p_a)] that it belongs
to a good aperture candidate is accumulated over the sensor's detections z_t:

    L_a(m_i | z_1:t) = L_a(m_i | z_1:t-1) + L_a(m_i | z_t)        (1)

"a hits-or-misses update model": a *hit* where an aperture is detected, a
*miss* for "the remaining m_i within the sensor's unobstructed field of
view (by performing raycasting)". One update per detection, on the newest
frame of the detection's window:

- hit, L_hit = log[p_hit / (1 - p_hit)], on the voxels of each detected
  aperture's region that M holds free: the inside of its contour C_a from
  the plane face to d_a behind it (Definition 1: the region "up to a depth
  threshold offset d_a from the planar face corresponds to ⊂ M_free");
- miss, L_miss = log[p_miss / (1 - p_miss)] < 0, on every other voxel the
  frame's rays cross before their return (once a frame); the voxels the
  rays end in (obstacles) are not in the unobstructed view and keep theirs.

The belief is a second OctoMap octree over the same voxels as M, its rays
inserted with p_hit = 0.5 (no change where a ray ends) and p_miss, the hits
then set so that a detected voxel's net update is L_hit whether or not a ray
crossed it. Units: log-odds (natural logarithm), L = 0 for p_a = 0.5 (the
prior of a voxel never seen); clamped to [logit p_min, logit p_max] so that
a long run of hits or misses can still be overturned. The paper gives no
probabilities: p_hit and p_miss are OctoMap's [26] occupancy defaults.

Frames and units: the navigation frame of the base estimate, metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pyoctomap

from .detection import ApertureCandidate
from .volumetric import FREE, SensorCloud, VolumetricMap, tree_log_odds, voxel_centres


def logit(p: float) -> float:
    """log[p / (1 - p)] (natural log), the log-odds of probability ``p``."""
    return math.log(p / (1.0 - p))


@dataclass(frozen=True)
class BeliefParams:
    """Parameters of the aperture belief (§IV-C); the paper gives none, so all are chosen.

    Attributes:
        p_hit: p_a(m_i | z_t) of a voxel in a detected aperture's region (OctoMap's hit probability).
        p_miss: p_a(m_i | z_t) of a voxel in the unobstructed view without a detection (OctoMap's miss).
        p_min: lower clamp of p_a.
        p_max: upper clamp of p_a.
        d_a: d_a (m), how far behind the plane face a detection's region reaches (Definition 1); the
            ``collapsed_mockup`` aperture wall is 0.1 m thick.
    """

    p_hit: float = 0.7
    p_miss: float = 0.4
    p_min: float = 0.02
    p_max: float = 0.98
    d_a: float = 0.1


def aperture_region(candidate: ApertureCandidate, resolution: float, d_a: float) -> np.ndarray:
    """Points (nav frame, m) filling a candidate's region: inside C_a, from the plane face to ``d_a`` behind it.

    Sampled every half voxel (``resolution``, m) across the plane and in depth, so that every voxel the
    region touches holds at least one point.
    """
    view = candidate.view
    step_px = max(1, int(0.5 * resolution * view.K[0, 0] / view.plane_depth))
    v, u = np.nonzero(candidate.mask()[::step_px, ::step_px])
    on_plane_I = view.pixel_to_I(np.stack((u, v), axis=1).astype(float) * step_px)
    behind = np.linspace(0.0, d_a, math.ceil(d_a / (0.5 * resolution)) + 1)  # along -n̂: into the opening
    region_I = on_plane_I[:, None, :] - behind[None, :, None] * candidate.normal_I
    return candidate.frame.to_nav(region_I.reshape(-1, 3))


class ApertureBelief:
    """L_a over the voxels of M (eq. 1), as an OctoMap octree of the same resolution (nav frame, m; log-odds)."""

    def __init__(self, resolution: float = 0.03, params: BeliefParams | None = None):
        """A belief with every voxel at the prior L_a = 0."""
        self.params = params or BeliefParams()
        self.resolution = float(resolution)
        self.tree = pyoctomap.OcTree(self.resolution)
        self.tree.setProbHit(0.5)  # a ray's end is an obstacle, outside the unobstructed view: no update
        self.tree.setProbMiss(self.params.p_miss)
        self.tree.setClampingThresMin(self.params.p_min)
        self.tree.setClampingThresMax(self.params.p_max)
        self.l_hit = logit(self.params.p_hit)

    def update(self, cloud: SensorCloud, regions: list[np.ndarray], occupancy: VolumetricMap) -> None:
        """Eq. (1) for one detection z_t: misses along ``cloud``'s rays, hits on the free voxels of ``regions``.

        ``regions``: the detected apertures' region points (nav frame, m; :func:`aperture_region`), empty
        when nothing was detected. ``occupancy``: M, already holding ``cloud`` (the hits go to its free voxels).
        """
        hits = np.empty((0, 3))
        if regions:
            hits = voxel_centres(np.concatenate(regions), self.resolution)
            hits = hits[occupancy.state(hits) == FREE]
        before = np.nan_to_num(self.log_odds(hits))
        self.tree.insertPointCloud(cloud.points, cloud.origin, max_range=cloud.max_range)
        missed = np.nan_to_num(self.log_odds(hits)) - before  # L_miss where a ray crossed the voxel, else 0
        for centre, miss in zip(hits, missed, strict=True):
            self.tree.updateNode(centre, float(self.l_hit - miss))  # net update of a detected voxel: L_hit

    def log_odds(self, points: np.ndarray) -> np.ndarray:
        """L_a at ``points`` ``(n, 3)`` (nav frame, m); NaN where no update ever reached the voxel (prior 0)."""
        return tree_log_odds(self.tree, points)
