"""Relocalising the MMS's base against its own map M: planar point-to-plane ICP of a depth frame (§III, §IV-D).

The paper's MMS keeps its pose consistent with its map by "multi-modal
Simultaneous Localization and Mapping" (§III-A, [27, 33–36]). The simulated
MMS has wheel odometry only (``odom``), which drifts with distance
(:mod:`marsupial.world.estimation.ground`: measured here 4–7.5 cm over the
1.3–1.8 m drive to the placement). M was built from the scan before that
drive, so after it the arm's planning frame and the map disagree by the
drift: the wall's voxels stand centimetres off the aperture detected again,
and at the clearances of the insertion (1–3 cm) every launch plan then
touches the stale wall. :func:`register_planar` closes the loop the way a
SLAM back-end's scan matching does: a fresh depth frame, posed by the
present estimate, is aligned to the surface points M kept
(:attr:`~.volumetric.VolumetricMap.surface`) by point-to-plane ICP over the
base's planar error (x, y, yaw), and the correction is applied to the
estimate (``reset_estimate``).

Method (Chen & Medioni 1992, point-to-plane; Gauss–Newton on three
parameters):

- reference normals: principal axis of least variance of each surface
  point's ``neighbours`` nearest points (scipy's k-d tree);
- each iteration pairs every frame point with its nearest reference point
  within ``max_distance`` (shrinking from ``start_distance``), with the
  residual r = n·(R(δψ)(p − c) + c + δt − q) about the pivot c, and solves
  (JᵀJ + μI) Δ = −(Jᵀr + μx): μ = (σ_point / σ_prior)² holds the directions
  the view does not constrain (along a plain wall) at the odometry's value
  instead of letting them slide;
- it stops when the step is below ``tolerance``, and is rejected (no
  correction) with fewer than ``min_pairs`` pairs.

:func:`register_searched` handles a drift far beyond ``start_distance``: a wheel that slips (the base held by an
obstacle it does not sense, its wheels turning) lets the odometry run on along the heading by as much as the
wheels turned. Measured in insertion trials: the MMS's side caught on a debris slab 1–5 cm high at the start of
the drive, and the odometry ran 0.58 m and 0.82 m ahead of the base. When the frame does not register at the
odometry's pose (or pairs less than ``min_fraction`` of its points), it is registered from poses moved along the
heading by each of ``search_offsets``, and the one pairing the most points is kept.

Frames and units: the navigation frame of the base estimate, metres,
radians; the correction is a rotation about z through ``pivot`` then a
translation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from .volumetric import SensorCloud, VolumetricMap


@dataclass(frozen=True)
class RegistrationParams:
    """Settings of :func:`register_planar` (chosen; the paper's SLAM is not described).

    Attributes:
        start_distance: largest pairing distance (m) of the first iteration (above the drift expected).
        max_distance: largest pairing distance (m) once converging (a few times the depth noise).
        iterations: most Gauss–Newton iterations.
        tolerance: the step (m, and rad × 1 m) below which it has converged.
        neighbours: reference points per normal estimate.
        sigma_point: the depth noise (m) weighting the residuals against the prior.
        sigma_prior: the odometry's error (m; rad for yaw: ``sigma_prior / 1 m``) the prior allows.
        min_pairs: fewer pairs than this and the frame is not registered.
        max_correction: a correction beyond this (m, and rad × 1 m) is refused: twice the pairing reach, more than
            the odometry drifts between registrations (a frame of floor and little else once slid 3 m).
        min_fraction: :func:`register_searched` searches when fewer than this fraction of the frame's points pair,
            and keeps no registration pairing fewer.
        search_offsets: the offsets (m) along the heading :func:`register_searched` starts from (negative: the base
            behind its estimate, as a slipping wheel leaves it); spaced within ``start_distance``.
        refine_iterations: the best of the search is registered again from where it ended with this many
            iterations: the offset's component across the wall (a drive not square to it) converges slowly.
    """

    start_distance: float = 0.15
    max_distance: float = 0.03
    iterations: int = 30
    tolerance: float = 1e-5
    neighbours: int = 10
    sigma_point: float = 0.005
    sigma_prior: float = 0.1
    min_pairs: int = 200
    max_correction: float = 0.3
    min_fraction: float = 0.5
    search_offsets: tuple[float, ...] = tuple(round(0.1 * k, 1) for k in range(-15, 6) if k)
    refine_iterations: int = 100


@dataclass(frozen=True)
class Registration:
    """The planar correction of the base estimate found by :func:`register_planar`.

    Attributes:
        translation: ``(dx, dy)`` (nav, m), applied after the rotation.
        yaw: δψ (rad) about z through ``pivot``.
        pivot: the rotation's centre (nav, m).
        pairs: point pairs of the last iteration.
        rms: their point-to-plane residual (m), after the correction.
        iterations: Gauss–Newton iterations run.
    """

    translation: np.ndarray
    yaw: float
    pivot: np.ndarray
    pairs: int
    rms: float
    iterations: int

    def apply(self, position: np.ndarray, yaw: float) -> tuple[np.ndarray, float]:
        """A pose (position m, yaw rad, nav) moved by the correction."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        offset = np.asarray(position, dtype=float)[:2] - self.pivot[:2]
        moved = self.pivot[:2] + np.array([c * offset[0] - s * offset[1], s * offset[0] + c * offset[1]])
        out = np.array(position, dtype=float)
        out[:2] = moved + self.translation
        return out, math.remainder(yaw + self.yaw, math.tau)

    def summary(self) -> dict[str, object]:
        """A JSON-ready record (m, rad, rounded)."""
        return {"dx": round(float(self.translation[0]), 4), "dy": round(float(self.translation[1]), 4),
                "dyaw": round(self.yaw, 5), "pairs": self.pairs, "rms": round(self.rms, 4),
                "iterations": self.iterations}


def surface_normals(points: np.ndarray, tree: cKDTree, neighbours: int) -> np.ndarray:
    """Unit normals ``(n, 3)`` of ``points`` (m): the least-variance axis of each one's ``neighbours`` nearest."""
    _, index = tree.query(points, k=min(neighbours, len(points)))
    local = points[index] - points[index].mean(axis=1, keepdims=True)
    _, vectors = np.linalg.eigh(np.einsum("nki,nkj->nij", local, local))
    return vectors[:, :, 0]


def _moved(points: np.ndarray, pivot: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``points`` rotated by ``x[2]`` about z through ``pivot`` and moved by ``x[:2]``."""
    c, s = math.cos(x[2]), math.sin(x[2])
    offset = points - pivot
    out = points.copy()
    out[:, 0] = pivot[0] + c * offset[:, 0] - s * offset[:, 1] + x[0]
    out[:, 1] = pivot[1] + s * offset[:, 0] + c * offset[:, 1] + x[1]
    return out


def register_planar(points: np.ndarray, reference: np.ndarray, pivot: np.ndarray,
                    params: RegistrationParams | None = None) -> Registration | None:
    """The planar correction (x, y, yaw) aligning a frame's ``points`` ``(n, 3)`` to ``reference`` ``(m, 3)`` (nav,
    m) by point-to-plane ICP (module docstring); ``None`` with too few pairs or a correction beyond
    ``max_correction``."""
    params = params or RegistrationParams()
    points = np.asarray(points, dtype=float)
    reference = np.asarray(reference, dtype=float)
    lo, hi = points.min(axis=0) - params.start_distance, points.max(axis=0) + params.start_distance
    reference = reference[np.all((reference >= lo) & (reference <= hi), axis=1)]
    if len(reference) < params.min_pairs or len(points) < params.min_pairs:
        return None
    tree = cKDTree(reference)
    normals = surface_normals(reference, tree, params.neighbours)
    pivot = np.asarray(pivot, dtype=float)
    mu = (params.sigma_point / params.sigma_prior) ** 2
    x = np.zeros(3)
    residual, pairs = np.zeros(0), 0
    for iteration in range(1, params.iterations + 1):
        reach = max(params.max_distance, params.start_distance * 0.5 ** (iteration - 1))
        moved = _moved(points, pivot, x)
        distance, index = tree.query(moved, distance_upper_bound=reach)
        paired = np.isfinite(distance)
        pairs = int(np.count_nonzero(paired))
        if pairs < params.min_pairs:
            return None
        p, n = moved[paired], normals[index[paired]]
        residual = np.einsum("ij,ij->i", n, p - reference[index[paired]])
        lever = p[:, :2] - pivot[:2] - x[:2]  # d(R(ψ)(p − c))/dψ = ẑ × R(ψ)(p − c)
        J = np.column_stack((n[:, 0], n[:, 1], n[:, 1] * lever[:, 0] - n[:, 0] * lever[:, 1]))
        step = np.linalg.solve(J.T @ J + mu * np.eye(3), -(J.T @ residual + mu * x))
        x = x + step
        if reach <= params.max_distance and float(np.linalg.norm(step)) < params.tolerance:
            break
    moved = _moved(points, pivot, x)
    distance, index = tree.query(moved, distance_upper_bound=params.max_distance)
    paired = np.isfinite(distance)
    residual = np.einsum("ij,ij->i", normals[index[paired]], moved[paired] - reference[index[paired]])
    rms = float(np.sqrt(np.mean(residual**2))) if len(residual) else math.inf
    if max(float(np.linalg.norm(x[:2])), abs(float(x[2]))) > params.max_correction:
        return None
    return Registration(x[:2].copy(), float(x[2]), pivot, int(np.count_nonzero(paired)), rms, iteration)


def register_searched(points: np.ndarray, reference: np.ndarray, pivot: np.ndarray, heading: float,
                      params: RegistrationParams | None = None) -> Registration | None:
    """:func:`register_planar` at the odometry's pose and, when it fails or pairs less than ``min_fraction`` of
    ``points``, from the poses ``search_offsets`` along ``heading`` (rad, nav: the base's, about the way it drove) from
    it (module docstring): the registration pairing the most points, refined (``refine_iterations``); ``None`` when
    none pairs ``min_fraction`` of them."""
    params = params or RegistrationParams()
    points = np.asarray(points, dtype=float)
    pivot = np.asarray(pivot, dtype=float)
    enough = params.min_fraction * len(points)
    found = register_planar(points, reference, pivot, params)
    if found is not None and found.pairs >= enough:
        return found
    along = np.array([math.cos(heading), math.sin(heading), 0.0])
    best = found
    for offset in params.search_offsets:
        shift = offset * along
        moved = register_planar(points + shift, reference, pivot + shift, params)
        if moved is not None and (best is None or moved.pairs > best.pairs):
            best = Registration(moved.translation + shift[:2], moved.yaw, pivot, moved.pairs, moved.rms,
                                moved.iterations)
    if best is None or best.pairs < enough:  # found, if no offset paired more, pairs fewer than enough
        return None
    # registered again from where the best ended, about the pivot moved with it: R_r R_b (p − c) + c + t_b + t_r
    aligned = _moved(points, pivot, np.r_[best.translation, best.yaw])
    refined = register_planar(aligned, reference, pivot + np.r_[best.translation, 0.0],
                              replace(params, iterations=params.refine_iterations))
    if refined is None or refined.pairs < enough:
        return best
    return Registration(best.translation + refined.translation, best.yaw + refined.yaw, pivot, refined.pairs,
                        refined.rms, best.iterations + refined.iterations)


def relocalize_base(robot: Any, cloud: SensorCloud, occupancy: VolumetricMap,
                    searched: bool = False) -> Registration | None:
    """Register ``cloud`` (a fresh frame's rays, posed by the present base estimate) against M's surface and, if it
    registers, reset the robot's base estimate by the correction; returns it (``None``: the estimate is kept).

    ``robot``: the MMS's onboard interface (``estimate``, ``reset_estimate``); nav frame, m, rad. ``searched``: by
    :func:`register_searched` along the base's heading (a frame that sees a wall square ahead: a slipped drive);
    otherwise :func:`register_planar` at the estimate only.
    """
    returns = cloud.points[np.linalg.norm(cloud.points - cloud.origin, axis=1) < cloud.max_range]
    estimate = robot.estimate()
    if searched:
        found = register_searched(returns, occupancy.surface, estimate.position, estimate.yaw)
    else:
        found = register_planar(returns, occupancy.surface, estimate.position)
    if found is not None:
        robot.reset_estimate(*found.apply(estimate.position, estimate.yaw))
    return found
