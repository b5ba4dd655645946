"""Merge and selection: P_VS, tracking state, path length and the next pose P_R (Narváez et al., §IV-A-3).

At the merge-and-selection rate f_O the Motion Engine

1. turns the UAV pose P_Q^M into the online-PBVS target P_VS: the
   end-effector pose that puts the UAV marker in the centre of the
   eye-in-hand image (:func:`pbvs_target`);
2. measures the tracking state V_tr from the end-effector and UAV
   velocities in M (eqs. 9–11, K_pos = 2·K_ang, :func:`tracking_state`);
3. derives how far to travel on the graph, L_p = K_Lp·L_C / V_tr ≤ L_C
   (eq. 12, :func:`path_length`);
4. roots the path γ_eff at the vertex V_vs closest to P_VS and takes as P_R
   the vertex within L_p of it along the tree that lies farthest along the
   cord, the predicted direction of motion (:func:`select`, Fig. 10).

Frames: manipulator frame M, metres, radians; poses are 4×4 transforms.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from marsupial.api.tags import load_tag_bundle
from marsupial.geometry import yaw_of_rotation

from .graph import Graph


def _bundle_centre_Q() -> tuple[float, float, float]:
    """Centre of the Bebop 2's tag plate in its base frame Q (m): the marker PBVS centres."""
    bundle = load_tag_bundle()
    return (sum(bundle.plate_x) / 2.0, sum(bundle.plate_y) / 2.0, bundle.plate_z)


@dataclass(frozen=True)
class PbvsTarget:
    """Where the end effector goes relative to the UAV: the online-PBVS target P_VS (§IV-A-3).

    The arm frame ``frame`` looks straight up (its z axis, the camera's
    optical axis, along M's z) at the point ``aim_Q`` of the UAV from
    ``standoff`` below it, so the marker sits in the image centre. The
    end effector's heading follows the UAV's (plus ``yaw_offset``).

    Attributes:
        standoff: distance (m) from ``frame`` up to the aim point along the optical axis.
        aim_Q: aim point in the UAV base frame Q (m); default: centre of the tag plate.
        frame: arm frame whose z axis points at the aim point (default: the eye-in-hand
            optical frame; ``"part_a"`` with Part B's origin as ``aim_Q`` aligns the docking device).
        yaw_offset: heading of the end effector relative to the UAV's (rad, about M's z).
    """

    standoff: float = 0.5
    aim_Q: tuple[float, float, float] = field(default_factory=_bundle_centre_Q)
    frame: str = "eye_in_hand"
    yaw_offset: float = 0.0

    def __post_init__(self) -> None:
        if self.standoff < 0.0:
            raise ValueError(f"PbvsTarget needs standoff >= 0 m, got {self.standoff}")
        if len(self.aim_Q) != 3:
            raise ValueError(f"PbvsTarget.aim_Q must be a point [x, y, z] in the UAV frame, got {self.aim_Q}")


def rot_z(yaw: float) -> np.ndarray:
    """Rotation matrix of ``yaw`` (rad) about z."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def pbvs_target(
    T_M_Q: np.ndarray, T_E_F: np.ndarray, target: PbvsTarget = PbvsTarget()
) -> tuple[np.ndarray, np.ndarray]:
    """P_VS: position (m) and rotation of the end-effector (IK) frame E in M that centre the marker.

    Args:
        T_M_Q: the UAV pose P_Q^M (4×4).
        T_E_F: the aiming frame F (``target.frame``) in the end-effector frame E (4×4, constant);
            F's z axis must be E's z axis.
        target: :class:`PbvsTarget`.

    E is level (z up) with heading = UAV heading + ``yaw_offset``; F sits
    ``standoff`` straight below the aim point.
    """
    if not np.allclose(T_E_F[:3, 2], [0.0, 0.0, 1.0], atol=1e-9):
        raise ValueError("the aiming frame's z axis must be the end effector's z axis")
    p_aim_M = T_M_Q[:3, :3] @ np.asarray(target.aim_Q, dtype=float) + T_M_Q[:3, 3]
    R_M_E = rot_z(yaw_of_rotation(T_M_Q[:3, :3]) + target.yaw_offset)
    p_F_M = p_aim_M - np.array([0.0, 0.0, target.standoff])
    return p_F_M - R_M_E @ T_E_F[:3, 3], R_M_E


def rpy_of_rotation(R: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw (rad, R = Rz(yaw)·Ry(pitch)·Rx(roll)) of the rotation ``R``."""
    return np.array(
        [math.atan2(R[2, 1], R[2, 2]), math.asin(max(-1.0, min(1.0, -R[2, 0]))), math.atan2(R[1, 0], R[0, 0])]
    )


def pose_rates(T_before: np.ndarray, T_after: np.ndarray, dt: float) -> np.ndarray:
    """[Δx Δy Δz Δφ Δθ Δψ] / dt of a pose in M between two samples ``dt`` (s) apart (m/s, rad/s).

    The velocity vectors V^M of §IV-A-3; angle differences are wrapped to [−π, π).
    """
    if dt <= 0.0:
        raise ValueError(f"pose rates need dt > 0 s, got {dt}")
    linear = T_after[:3, 3] - T_before[:3, 3]
    angular = rpy_of_rotation(T_after[:3, :3]) - rpy_of_rotation(T_before[:3, :3])
    angular = (angular + math.pi) % (2.0 * math.pi) - math.pi
    return np.concatenate((linear, angular)) / dt


@dataclass(frozen=True)
class SelectionParams:
    """Gains of the tracking state and of the path length (the paper gives only K_pos = 2·K_ang).

    K_ang = 0.5 m/rad makes K_pos = 1, so V_tr is in m/s. K_Lp = 0.02 m/s
    gives L_p = 4.5 cm when the UAV and the end effector both move at
    0.2 m/s in M (V_tr = 0.067 m/s), about the arm's lag at that speed.

    Attributes:
        K_ang: gain K_ang of the angular velocities (rad/s) in eqs. (10)–(11), m/rad.
        K_Lp: constant K_Lp of eq. (12) (m/s): the tracking state at which L_p = L_C.
        L_C: cord length L_C (m), eq. (12) caps L_p at it (the cord's L_C, §IV-A-1).
    """

    K_ang: float = 0.5
    K_Lp: float = 0.02
    L_C: float = 0.15

    def __post_init__(self) -> None:
        if self.K_ang <= 0 or self.K_Lp < 0 or self.L_C <= 0:
            raise ValueError(f"SelectionParams needs K_ang > 0, K_Lp >= 0 and L_C > 0; got {self}")

    @property
    def K_pos(self) -> float:
        """Gain K_pos = 2·K_ang of the linear velocities, eqs. (10)–(11)."""
        return 2.0 * self.K_ang


def mean_motion(v: np.ndarray, params: SelectionParams = SelectionParams()) -> float:
    """Eqs. (10)–(11): (K_pos(|Δx|+|Δy|+|Δz|) + K_ang(|Δφ|+|Δθ|+|Δψ|)) / 6 of one velocity vector.

    The paper sums the components as "the quantity of movement expected in
    the image"; their magnitudes are summed so that opposite components do
    not cancel.
    """
    v = np.abs(np.asarray(v, dtype=float))
    return float(params.K_pos * v[:3].sum() + params.K_ang * v[3:].sum()) / 6.0


def tracking_state(v_eff_M: np.ndarray, v_uav_M: np.ndarray, params: SelectionParams = SelectionParams()) -> float:
    """Eq. (9): V_tr = mean(V_eff) + mean(V_UAV), from the end-effector and UAV velocities in M (eqs. 10–11)."""
    return mean_motion(v_eff_M, params) + mean_motion(v_uav_M, params)


def path_length(V_tr: float, params: SelectionParams = SelectionParams()) -> float:
    """Eq. (12): L_p = K_Lp·L_C / V_tr, at most L_C (m)."""
    if V_tr <= params.K_Lp:
        return params.L_C
    return params.K_Lp * params.L_C / V_tr


def cord_progress(points: np.ndarray, items: np.ndarray) -> np.ndarray:
    """``(n,)`` arc length (m) along the cord's polyline of each point's closest point on it (0 for one item)."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    items = np.asarray(items, dtype=float).reshape(-1, 3)
    if items.shape[0] < 2:
        return np.zeros(points.shape[0])
    a, segment = items[:-1], np.diff(items, axis=0)
    length = np.linalg.norm(segment, axis=1)
    start = np.concatenate(([0.0], np.cumsum(length)[:-1]))
    u = np.einsum("msk,sk->ms", points[:, None, :] - a[None], segment) / np.maximum(length**2, 1e-18)
    u = np.clip(u, 0.0, 1.0)
    closest = a[None] + u[..., None] * segment[None]
    nearest = np.argmin(np.sum((points[:, None, :] - closest) ** 2, axis=2), axis=1)
    rows = np.arange(points.shape[0])
    return start[nearest] + u[rows, nearest] * length[nearest]


@dataclass(frozen=True)
class Selection:
    """Outcome of :func:`select`.

    Attributes:
        v_vs: vertex V_vs closest to P_VS; v_R: the selected vertex P_R.
        path: γ_eff, the tree path from V_vs to P_R (vertex indices).
        p_R_M: position of P_R (m, M frame); q_R: the vertex's joint angles (rad).
        L_p: the path length bound used (m).
    """

    v_vs: int
    v_R: int
    path: list[int]
    p_R_M: np.ndarray
    q_R: np.ndarray
    L_p: float


def select(graph: Graph, p_vs_M: np.ndarray, cord_items: np.ndarray, L_p: float) -> Selection | None:
    """P_R: among the vertices within ``L_p`` of V_vs along the tree, the one farthest along the cord.

    Ties (a cordless plan has no direction) go to the vertex closest to V_vs
    along the tree, so a cordless plan selects V_vs itself. ``None`` on an
    empty graph.
    """
    v_vs = graph.nearest(p_vs_M)
    if v_vs < 0:
        return None
    distance = graph.distances_from(v_vs)
    candidates = np.flatnonzero(distance <= L_p + 1e-12)
    progress = cord_progress(graph.positions[candidates], cord_items)
    best = candidates[np.lexsort((distance[candidates], -progress))[0]]
    v_R = int(best)
    return Selection(v_vs, v_R, graph.path(v_vs, v_R), graph.positions[v_R].copy(), graph.q[v_R].copy(), L_p)
