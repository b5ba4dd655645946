"""Vicinity of the cord: ellipse sections around its items (Narváez et al., §IV-A-2, eqs. 7–8, Fig. 7).

Each item I_i of the cord carries a section S_i: an ellipse drawn
perpendicular to the cord's main direction, with semimajor axis a_i
(horizontal, across the cord) and semiminor axis b_i (vertical), and the
thickness L_S along the cord in which Algorithm 2 draws its random poses
(``RandomPoseGenerate(a_i, b_i, L_S)``). A section is therefore the
ellipsoid of semi-axes (L_S, a_i, b_i) along (cord, across, up). The sizes
grow with the distance from the cord origin (eq. 7):

    L_os,i = 1 + Σ_{k=1..i} L_S = 1 + i·L_S,    a_i = K_a·L_os,i²,    b_i = K_b·L_os,i / 2.

A cordless plan (N = 1) has one ellipsoid with doubled gains (eq. 8):
a_1 = 2K_a·L_os,1², b_1 = 2K_b·L_os,1 / 2, c_1 = L_S.

Frame: manipulator frame M, metres. ``rotations[i]`` holds the section's
axes as columns: along the cord, across it (horizontal), and up.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from .cord import Cord


@dataclass(frozen=True)
class VicinityParams:
    """Gains of the section sizes. The paper gives no values; these keep the vicinity local to the arm.

    Attributes:
        K_a: gain K_a of the semimajor axes a_i = K_a·L_os² (eq. 7), 1/m.
        K_b: gain K_b of the semiminor axes b_i = K_b·L_os / 2 (eq. 7), dimensionless.
    """

    K_a: float = 0.05
    K_b: float = 0.06

    def __post_init__(self) -> None:
        if self.K_a <= 0 or self.K_b <= 0:
            raise ValueError(f"VicinityParams needs K_a > 0 and K_b > 0; got {self}")


def section_sizes(N: int, L_S: float, params: VicinityParams = VicinityParams()) -> np.ndarray:
    """``(N, 3)`` semi-axes (along, across, up) = (L_S, a_i, b_i) of the sections, eqs. (7)–(8), metres."""
    if N < 1:
        raise ValueError(f"a vicinity needs at least one item, got N = {N}")
    L_os = 1.0 + L_S * np.arange(1, N + 1)  # L_os,i = 1 + Σ_{k=1}^{i} L_S, eq. (7)
    K_a, K_b = (2.0 * params.K_a, 2.0 * params.K_b) if N == 1 else (params.K_a, params.K_b)  # K_sa, K_sb, eq. (8)
    return np.column_stack((np.full(N, L_S), K_a * L_os**2, K_b * L_os / 2.0))


def section_frames(items: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """``(N, 3, 3)`` section axes (columns: along, across, up) perpendicular to the cord at each item.

    The tangent at an item is the central difference of its neighbours (one
    side at the ends); a single item uses ``direction`` (horizontal unit vector).
    """
    items = np.asarray(items, dtype=float)
    tangents = np.array([[direction[0], direction[1], 0.0]]) if items.shape[0] == 1 else np.gradient(items, axis=0)
    tangents = tangents / np.linalg.norm(tangents, axis=1, keepdims=True)
    up = np.array([0.0, 0.0, 1.0])
    across = np.cross(up, tangents)
    norms = np.linalg.norm(across, axis=1, keepdims=True)
    vertical = norms[:, 0] < 1e-9  # a vertical tangent: any horizontal axis is across
    across[vertical] = [0.0, 1.0, 0.0]
    across /= np.where(vertical[:, None], 1.0, norms)
    normal = np.cross(tangents, across)
    return np.stack((tangents, across, normal), axis=2)


@dataclass(frozen=True)
class Vicinity:
    """The union of the sections S_i (ellipsoids) around the cord items, in M.

    Attributes:
        centers: ``(N, 3)`` section centres I_i (m).
        rotations: ``(N, 3, 3)`` section axes as columns (along, across, up).
        semi_axes: ``(N, 3)`` semi-axes (L_S, a_i, b_i) along those axes (m).
    """

    centers: np.ndarray
    rotations: np.ndarray
    semi_axes: np.ndarray

    @property
    def N(self) -> int:
        """Number of sections."""
        return int(self.centers.shape[0])

    @property
    def max_semi_axis(self) -> float:
        """Largest semi-axis of any section (m): a_N for a corded vicinity (the map thickening, §IV-A-2)."""
        return float(self.semi_axes.max())

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Boolean mask of the ``(n, 3)`` points (m) inside at least one section."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        local = np.einsum("nji,mnj->mni", self.rotations, points[:, None, :] - self.centers[None])
        return np.any(np.sum((local / self.semi_axes[None]) ** 2, axis=2) <= 1.0, axis=1)

    def sample(self, per_section: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """Uniform random positions inside each section (Algorithm 2, lines 5–7).

        Draws in the unit ball, scales by (L_S, a_i, b_i), rotates by the
        section axes and translates to I_i. Returns ``(N·per_section, 3)``
        positions (m) and the section index of each.
        """
        n = self.N * per_section
        directions = rng.standard_normal((n, 3))
        directions /= np.linalg.norm(directions, axis=1, keepdims=True)
        radii = rng.random(n) ** (1.0 / 3.0)
        section = np.repeat(np.arange(self.N), per_section)
        local = directions * radii[:, None] * self.semi_axes[section]
        points = np.einsum("nij,nj->ni", self.rotations[section], local) + self.centers[section]
        return points, section


def build_vicinity(cord: Cord, L_S: float, params: VicinityParams = VicinityParams()) -> Vicinity:
    """The vicinity of ``cord`` (eqs. 7–8); ``L_S`` is the cord's item spacing (m)."""
    return Vicinity(
        cord.items.copy(),
        section_frames(cord.items, cord.direction),
        section_sizes(cord.N, L_S, params),
    )


class PointZones(Protocol):
    """What the validation needs of a zone map (:class:`~.zones.ZoneMap`)."""

    def points_free(self, points: np.ndarray, clearance: float = 0.0) -> np.ndarray: ...


class PoseSolver(Protocol):
    """What the validation needs of an IK engine (:class:`~..common.ik_engine.IKEngine`)."""

    def solve(self, positions: np.ndarray, rotations: np.ndarray, q_ref: np.ndarray | None = None) -> Any: ...


@dataclass(frozen=True)
class VicinityCheck:
    """Outcome of the random-sample validation.

    Attributes:
        ok: every sample is free and at least ``min_reachable`` of them are reachable.
        free_fraction: share of samples outside every zone and inside the bounds.
        reachable_fraction: share of samples the IK engine reaches within the joint ranges (1 without IK).
    """

    ok: bool
    free_fraction: float
    reachable_fraction: float


def validate_vicinity(
    vicinity: Vicinity,
    zones: PointZones,
    rng: np.random.Generator,
    samples: int = 32,
    ik: PoseSolver | None = None,
    rotation: np.ndarray | None = None,
    q_ref: np.ndarray | None = None,
    min_reachable: float = 1.0,
) -> VicinityCheck:
    """Quick validation of a (repaired) vicinity with scattered random poses (§IV-A-2).

    Draws about ``samples`` positions over the sections; they must all be
    outside the zones, and, with an IK engine, reachable with the end-effector
    orientation ``rotation`` (3×3 in M, default M's axes) from ``q_ref``.
    """
    per_section = max(1, -(-samples // vicinity.N))
    points, _ = vicinity.sample(per_section, rng)
    free = float(np.mean(zones.points_free(points)))
    reachable = 1.0
    if ik is not None:
        R = np.eye(3) if rotation is None else np.asarray(rotation, dtype=float)
        reachable = float(np.mean(ik.solve(points, R, q_ref).valid))
    return VicinityCheck(free == 1.0 and reachable >= min_reachable, free, reachable)
