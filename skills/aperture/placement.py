"""Base placement for reaching an aperture (Arora & Papachristos, §IV-D): where the MMS stands to see and reach it.

From the approach pose P_a (the aperture's target point t_a and its model
plane normal n̂), the paper "project[s] a cone of constant radius ρ = 2 m
onto the extracted groundmap plane, and randomly sample[s] candidate poses
for the mobile base within their intersection, which also qualifies as valid
by a collision check query to the volumetric map M"; for each surviving base
location b_i an end-effector goal "oriented to maintain sight of [the]
aperture" is tested for a feasible inverse-kinematics solution.

Here, with numpy and the arm's pinocchio model:

1. :func:`sample_cone` — base poses (x, y, yaw) drawn uniformly over the
   ground sector of radius ρ and half-angle β about the horizontal
   projection of n̂, apex at t_a projected on the ground, each facing t_a
   within ± ``yaw_spread``;
2. :class:`FootprintGrid` — M over the sector, collapsed to the ground: a
   cell is blocked when any voxel of the base's height band above it is
   occupied *or unknown* (M holds only what the camera saw); the base's
   rectangle (inflated by ``margin``) is tested point by point against it,
   every candidate at once (vectorised numpy);
3. :func:`camera_goal` — the eye-in-hand camera ``standoff`` in front of t_a
   along n̂, its optical axis along −n̂ (looking at t_a), image rows level;
   with a ``view_point`` (the centre of the aperture's contour) the camera is
   moved across n̂ in front of it, t_a still in view: m_A can lie 10–15 cm
   off a U's centre, and a camera 0.4 m from the wall in front of it saw
   the far arm of a 30 cm U cut by the image border (analysed again, it was
   not detected);
4. the camera link's goal in each candidate's arm frame M, solved by the
   closed-form IK of the spherical-wrist arm (:class:`~..common.ik_engine.ClosedFormIK`
   on the pinocchio model) within the joint limits, and checked by pinocchio
   forward kinematics: the solution must place the camera at the goal and
   project t_a inside its image, in front of the near clip.

Departures and choices (the paper gives no more detail): the groundmap
connectivity graph of [38] is not built; the base drives straight to its
placement (the skill). The arm's own collisions along its motion are not
checked (the paper's collision-aware planner [36]); only the camera's line
of sight to t_a through M is. The paper stops at the first feasible
candidate; here every candidate is tested and the feasible ones are ranked by
:func:`placement_cost` (drive distance, turn and joint motion). Cells under
the robot's present footprint count as free (the robot stands there: M holds
them unknown, or occupied where the camera saw the robot's own body).
python-fcl's octree collision treats unknown space as free, so the footprint
check is done on the collapsed grid instead.

Frames and units: the navigation frame of the base estimate (``odom``), z up,
metres, radians; base poses are of ``base_footprint`` on the ground plane
z = ``ground_z``.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..common.ik_engine import ClosedFormIK, DlsIK
from ..navigation import Footprint
from .detection import CAMERA_LINK
from .volumetric import FREE, OCCUPIED, UNKNOWN, VolumetricMap

RHO_M = 2.0  # ρ, radius of the sampling cone (m), §IV-D


@dataclass(frozen=True)
class PlacementParams:
    """Parameters of base placement (§IV-D); ρ from the paper, the others chosen (the paper gives none).

    Attributes:
        rho: ρ (m), radius of the sampling cone on the ground.
        half_angle: β (rad), half-angle of the cone about n̂'s ground projection.
        samples: candidate base poses drawn.
        yaw_spread: candidates face t_a within ± this (rad).
        standoff: distance (m) of the camera from t_a along n̂ (beyond the camera's 0.1 m near clip, close
            enough for the profile analysis's vantage point, §IV-E).
        footprint: front, rear, half-width (m) of the base rectangle about ``base_footprint`` (mms.urdf's
            0.99 × 0.67 m collision box).
        height: top of the base's collision box above the ground (m).
        ground_clearance: voxels lower than this above the ground are the ground itself, not obstacles (m).
        margin: the rectangle is inflated by this (m) before the check.
        w_turn: cost (m/rad) of turning the base, against metres of drive.
        w_joint: cost (m/rad) of the arm's joint motion from its present angles.
        view_margin_px: t_a must project this far inside the image border (px).
    """

    rho: float = RHO_M
    half_angle: float = math.radians(45.0)
    samples: int = 300
    yaw_spread: float = 0.3
    standoff: float = 0.5
    footprint: tuple[float, float, float] = (0.495, 0.495, 0.335)
    height: float = 0.39
    ground_clearance: float = 0.06
    margin: float = 0.05
    w_turn: float = 0.2
    w_joint: float = 0.1
    view_margin_px: float = 10.0


@dataclass(frozen=True)
class CameraModel:
    """The eye-in-hand camera as the arm model carries it (the camera port's static facts).

    Attributes:
        offset: optical centre in ``link``'s frame (m).
        R_link_optical: rotation of the OpenCV optical frame (x right, y down, z along the axis) in ``link``'s.
        K: 3×3 intrinsics (px); width, height: image size (px); near: near clip (m).
        link: the arm-model link the camera is mounted on.
    """

    offset: np.ndarray
    R_link_optical: np.ndarray
    K: np.ndarray
    width: int
    height: int
    near: float
    link: str = CAMERA_LINK

    @classmethod
    def of_port(cls, port: Any, link: str = CAMERA_LINK) -> CameraModel:
        """From a camera's onboard port (``offset``, ``R_link_optical``, ``intrinsics``)."""
        intrinsics = port.intrinsics
        return cls(np.asarray(port.offset, dtype=float), np.asarray(port.R_link_optical, dtype=float),
                   np.asarray(intrinsics.K, dtype=float), int(intrinsics.width), int(intrinsics.height),
                   float(intrinsics.near), link)

    def project(self, points_optical: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixels ``(..., 2)`` of points ``(..., 3)`` of the optical frame (m), and their depths (m)."""
        z = points_optical[..., 2]
        safe = np.where(np.abs(z) < 1e-9, 1e-9, z)
        u = self.K[0, 0] * points_optical[..., 0] / safe + self.K[0, 2]
        v = self.K[1, 1] * points_optical[..., 1] / safe + self.K[1, 2]
        return np.stack((u, v), axis=-1), z


@dataclass(frozen=True)
class Placement:
    """One feasible base placement, best first in :func:`plan_placements`' list.

    Attributes:
        pose: ``(x, y, yaw)`` of ``base_footprint`` (nav frame, m, rad).
        q: arm joint angles (rad) placing the camera at its goal.
        camera_position: the camera's optical centre at ``q`` from that pose (nav frame, m).
        cost: :func:`placement_cost` (m-equivalent; lower is better).
    """

    pose: np.ndarray
    q: np.ndarray
    camera_position: np.ndarray
    cost: float

    def summary(self) -> dict[str, object]:
        """A JSON-ready record (m, rad, rounded)."""
        return {"pose": [round(float(x), 3) for x in self.pose], "q": [round(float(x), 3) for x in self.q],
                "camera": [round(float(x), 3) for x in self.camera_position], "cost": round(self.cost, 3)}


def rot_z_batch(yaw: np.ndarray) -> np.ndarray:
    """Rotations ``(n, 3, 3)`` about z by ``yaw`` ``(n,)`` (rad)."""
    c, s = np.cos(yaw), np.sin(yaw)
    R = np.zeros(yaw.shape + (3, 3))
    R[..., 0, 0], R[..., 0, 1], R[..., 1, 0], R[..., 1, 1], R[..., 2, 2] = c, -s, s, c, 1.0
    return R


def cone_axis(normal: np.ndarray) -> float:
    """Heading (rad) of n̂'s ground projection: the cone's axis. ``ValueError`` for a horizontal plane."""
    n = np.asarray(normal, dtype=float)
    if math.hypot(n[0], n[1]) < 1e-3:
        raise ValueError("the aperture's plane is horizontal: no ground direction faces it")
    return math.atan2(n[1], n[0])


def sample_cone(target: np.ndarray, normal: np.ndarray, params: PlacementParams,
                rng: np.random.Generator) -> np.ndarray:
    """``(samples, 3)`` base poses ``(x, y, yaw)`` uniform over the ground sector in front of ``target`` (nav, m).

    The sector: apex at ``target``'s ground projection, axis along n̂'s, radius ρ, half-angle β (uniform by
    area: r = ρ√u). Each pose faces the apex, its yaw perturbed uniformly within ± ``yaw_spread``.
    """
    axis = cone_axis(normal)
    n = params.samples
    r = params.rho * np.sqrt(rng.uniform(0.0, 1.0, n))
    bearing = axis + params.half_angle * rng.uniform(-1.0, 1.0, n)
    x = target[0] + r * np.cos(bearing)
    y = target[1] + r * np.sin(bearing)
    yaw = bearing + math.pi + params.yaw_spread * rng.uniform(-1.0, 1.0, n)
    return np.column_stack((x, y, np.remainder(yaw + math.pi, math.tau) - math.pi))


def footprint_points(poses: np.ndarray, footprint: Footprint, spacing: float) -> np.ndarray:
    """Ground points ``(n, P, 2)`` (nav, m) covering the rectangle ``footprint`` at each pose ``(n, 3)``."""
    local = footprint.samples(spacing)
    c, s = np.cos(poses[:, 2:3]), np.sin(poses[:, 2:3])
    x = poses[:, 0:1] + c * local[:, 0] - s * local[:, 1]
    y = poses[:, 1:2] + s * local[:, 0] + c * local[:, 1]
    return np.stack((x, y), axis=-1)


def voxel_states(occupancy: VolumetricMap, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """M's voxels over the box from corner ``lo`` to ``hi`` (nav, m) as a dense array.

    Returns the OctoMap key (floor(coordinate / resolution)) of the box's first voxel ``(3,)`` and the states
    ``(nx, ny, nz)`` (:data:`~.volumetric.UNKNOWN`, ``FREE``, ``OCCUPIED``) of the voxels from there; built from
    the octree's leaves in the box (one pass over the known voxels; pruned leaves fill their blocks).
    """
    res = occupancy.resolution
    key_lo = np.floor(np.asarray(lo, dtype=float) / res + 1e-9).astype(np.int64)
    key_hi = np.floor(np.asarray(hi, dtype=float) / res).astype(np.int64)
    shape = tuple(int(k) for k in key_hi - key_lo + 1)
    states = np.full(shape, UNKNOWN, dtype=np.int8)
    tree = occupancy.tree
    leaves = [(*leaf.getCoordinate(), leaf.getSize(), tree.isNodeOccupied(leaf))
              for leaf in tree.begin_leafs_bbx(key_lo * res, (key_hi + 1) * res)]
    if leaves:
        table = np.array(leaves, dtype=float)
        size = table[:, 3]
        first = np.rint((table[:, :3] - size[:, None] / 2.0) / res).astype(np.int64) - key_lo
        count = np.maximum(1, np.rint(size / res).astype(np.int64))
        value = np.where(table[:, 4] > 0, OCCUPIED, FREE).astype(np.int8)
        single = (count == 1) & np.all((first >= 0) & (first < shape), axis=1)
        states[tuple(first[single].T)] = value[single]
        for k in np.flatnonzero(count > 1):  # pruned leaves: blocks of voxels
            a = np.maximum(first[k], 0)
            b = np.minimum(first[k] + count[k], shape)
            if np.all(b > a):
                states[a[0]:b[0], a[1]:b[1], a[2]:b[2]] = value[k]
    return key_lo, states


class FootprintGrid:
    """M collapsed onto the ground over a box: a cell is blocked when a voxel of the base's height band is occupied
    or none of them is known.

    The ground views (``approach_aperture``) see the band's voxels along slanted rays, which leave some upper voxels of
    a column unknown above voxels seen free; an obstacle standing there would have been seen by those rays or by the
    level scan, so a column with free voxels and no occupied one is free.

    Cells are M's voxel columns (OctoMap keys: floor(coordinate / resolution)). Built from the octree's
    leaves in the box (one pass over the known voxels), so everything not listed is unknown.

    Args:
        occupancy: M.
        lo, hi: ground corners ``(x, y)`` of the box (nav, m).
        z_band: heights ``(z_lo, z_hi)`` (nav, m) the base occupies.
        known_free: ground points ``(m, 2)`` (nav, m) of space the robot itself stands in: their cells count
            as free (what M holds there, unknown or occupied, is the robot's own body).
    """

    def __init__(self, occupancy: VolumetricMap, lo: np.ndarray, hi: np.ndarray, z_band: tuple[float, float],
                 known_free: np.ndarray | None = None):
        res = occupancy.resolution
        self.resolution = res
        key_lo, states = voxel_states(occupancy, np.r_[lo, z_band[0]], np.r_[hi, z_band[1]])
        self.key_lo = key_lo[:2]
        self.shape = states.shape[:2]
        self.occupied = (states == OCCUPIED).any(axis=2)
        self.blocked = self.occupied | (states == UNKNOWN).all(axis=2)
        if known_free is not None and len(known_free):
            ij = self._cells(np.asarray(known_free, dtype=float))
            inside = self._inside(ij)
            self.blocked[ij[inside, 0], ij[inside, 1]] = False

    def _cells(self, points: np.ndarray) -> np.ndarray:
        return np.floor(points / self.resolution).astype(np.int64) - self.key_lo

    def _inside(self, ij: np.ndarray) -> np.ndarray:
        return np.all((ij >= 0) & (ij < self.shape), axis=-1)

    def collides(self, points: np.ndarray) -> np.ndarray:
        """For ground points ``(n, P, 2)`` (nav, m): ``(n,)`` True where any falls on a blocked cell or off the box."""
        ij = self._cells(points)
        inside = self._inside(ij)
        i, j = np.where(inside, ij[..., 0], 0), np.where(inside, ij[..., 1], 0)
        return (~inside | self.blocked[i, j]).any(axis=-1)


def camera_goal(target: np.ndarray, normal: np.ndarray, standoff: float) -> tuple[np.ndarray, np.ndarray]:
    """The camera's goal: optical centre ``standoff`` m from ``target`` along n̂, ``R_nav_optical`` looking at it.

    Optical z = −n̂; optical y (image down) is gravity's direction orthogonal to it, x = y × z (nav frame).
    """
    n = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
    z = -n
    down = np.array([0.0, 0.0, -1.0])
    y = down - (down @ z) * z
    if np.linalg.norm(y) < 1e-6:
        raise ValueError("the aperture's plane is horizontal: the camera cannot look at it level")
    y /= np.linalg.norm(y)
    return np.asarray(target, dtype=float) + standoff * n, np.column_stack((np.cross(y, z), y, z))


def view_target(target: np.ndarray, normal: np.ndarray, view_point: np.ndarray | None) -> np.ndarray:
    """The point (nav, m) the camera looks at: ``view_point`` moved along n̂ to ``target``'s depth (none: ``target``)."""
    target = np.asarray(target, dtype=float)
    if view_point is None:
        return target
    n = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
    point = np.asarray(view_point, dtype=float)
    return point + float((target - point) @ n) * n


def arm_frames(poses: np.ndarray, ground_z: float, arm_mount: tuple[np.ndarray, np.ndarray]
               ) -> tuple[np.ndarray, np.ndarray]:
    """Frame M of the arm at each base pose ``(n, 3)``: positions ``(n, 3)`` (nav, m) and ``R_nav_M`` ``(n, 3, 3)``.

    ``arm_mount``: M's position (m) and rotation in the ``base_footprint`` frame (the onboard ``arm_mount()``).
    """
    R_fp = rot_z_batch(poses[:, 2])
    p_fp = np.column_stack((poses[:, :2], np.full(len(poses), ground_z)))
    p_M_fp, R_fp_M = (np.asarray(a, dtype=float) for a in arm_mount)
    return p_fp + R_fp @ p_M_fp, R_fp @ R_fp_M


def sight_clear(occupancy: VolumetricMap, camera: np.ndarray, target: np.ndarray, keep_out: float) -> bool:
    """Whether no voxel of M is occupied on the segment from ``camera`` to within ``keep_out`` m of ``target``."""
    length = float(np.linalg.norm(target - camera))
    steps = max(2, int(math.ceil(length / (0.5 * occupancy.resolution))))
    t = np.linspace(0.0, max(0.0, 1.0 - keep_out / length), steps)
    points = camera + t[:, None] * (target - camera)
    return not bool(np.any(occupancy.state(points) == OCCUPIED))


def placement_cost(poses: np.ndarray, q: np.ndarray, start: np.ndarray, q_ref: np.ndarray,
                   params: PlacementParams) -> np.ndarray:
    """Cost ``(n,)``: drive distance (m) + ``w_turn`` · |turn| (rad) + ``w_joint`` · ‖q − q_ref‖ (rad)."""
    drive = np.hypot(poses[:, 0] - start[0], poses[:, 1] - start[1])
    turn = np.abs(np.remainder(poses[:, 2] - start[2] + math.pi, math.tau) - math.pi)
    return drive + params.w_turn * turn + params.w_joint * np.linalg.norm(q - q_ref, axis=1)


def plan_placements(target: np.ndarray, normal: np.ndarray, occupancy: VolumetricMap, kinematics: Any,
                    camera: CameraModel, arm_mount: tuple[np.ndarray, np.ndarray], start: Sequence[float],
                    q_ref: np.ndarray, ground_z: float, rng: np.random.Generator,
                    params: PlacementParams | None = None, tool_goals: Sequence[np.ndarray] = (),
                    refused: Counter[str] | None = None, view_point: np.ndarray | None = None) -> list[Placement]:
    """Feasible base placements to see and reach the aperture at ``target`` (§IV-D), lowest cost first.

    Args:
        target: t_a, the approach pose's position (nav, m): the point the camera looks at (m_A).
        normal: n̂, the model plane's normal toward the sensor (nav).
        occupancy: M.
        kinematics: the arm's :class:`~marsupial.api.kinematics.ArmKinematics` (frame M → its links).
        camera: the eye-in-hand camera on the arm.
        arm_mount: M in the ``base_footprint`` frame (position m, rotation).
        start: the present base pose ``(x, y, yaw)`` (nav, m, rad): its footprint counts as free space.
        q_ref: the present arm angles (rad): the IK branch nearest them is kept.
        ground_z: height of the ground plane (nav, m): the base estimate's z.
        rng: the random stream of the cone samples (deterministic given its seed).
        params: :class:`PlacementParams`.
        tool_goals: tip-frame poses (4×4, nav) the arm must also reach by IK from the placement (the insertion
            through the aperture: "the mounted arm workspace reaches the aperture").
        refused: if given, counts why candidates were dropped, by the first check each failed (``sight blocked``
            for all of them, ``footprint blocked``, ``camera out of reach``, ``insertion out of reach``,
            ``camera off its goal``, ``aperture out of view``).
        view_point: the point (nav, m) the camera's view is centred on across n̂ (its distance from the plane
            stays ``standoff`` from t_a's); none, or with the sight from there to t_a blocked in M: t_a.

    Returns:
        :class:`Placement` s (empty when the cone is blocked, unreachable, or the camera's sight is blocked).
    """
    params = params or PlacementParams()
    refused = Counter() if refused is None else refused
    target = np.asarray(target, dtype=float)
    start_pose = np.asarray(start, dtype=float)
    q_ref = np.asarray(q_ref, dtype=float)
    p_opt, R_opt = camera_goal(view_target(target, normal, view_point), normal, params.standoff)
    if view_point is not None and not sight_clear(occupancy, p_opt, target, keep_out=2.0 * occupancy.resolution):
        p_opt, R_opt = camera_goal(target, normal, params.standoff)
    if not sight_clear(occupancy, p_opt, target, keep_out=2.0 * occupancy.resolution):
        refused["sight blocked"] += params.samples
        return []
    poses = sample_cone(target, normal, params, rng)
    footprint = Footprint(*(d + params.margin for d in params.footprint))
    spacing = 0.5 * occupancy.resolution
    reach = params.rho + math.hypot(footprint.front + footprint.rear, 2 * footprint.half_width) + spacing
    grid = FootprintGrid(occupancy, target[:2] - reach, target[:2] + reach,
                         (ground_z + params.ground_clearance, ground_z + params.height),
                         footprint_points(start_pose[None], Footprint(*params.footprint), spacing)[0])
    clear = ~grid.collides(footprint_points(poses, footprint, spacing))
    refused["footprint blocked"] += int(np.count_nonzero(~clear))
    poses = poses[clear]
    if not len(poses):
        return []
    # the camera link's goal in each candidate's M: R_nav_link = R_nav_opt R_link_opt^T, origin behind the offset
    R_link = R_opt @ camera.R_link_optical.T
    p_link = p_opt - R_link @ camera.offset
    p_M, R_M = arm_frames(poses, ground_z, arm_mount)
    R_M_T = np.swapaxes(R_M, 1, 2)
    goals_p = np.einsum("nij,nj->ni", R_M_T, p_link - p_M)
    goals_R = R_M_T @ R_link
    solution = ClosedFormIK(kinematics, camera.link).solve(goals_p, goals_R, q_ref)
    reaches = np.ones(len(poses), dtype=bool)
    tip_ik = ClosedFormIK(kinematics) if len(tool_goals) else None
    for T in tool_goals:
        assert tip_ik is not None
        tip = tip_ik.solve(np.einsum("nij,nj->ni", R_M_T, T[:3, 3] - p_M), R_M_T @ T[:3, :3], q_ref)
        reaches &= tip.valid
    refused["camera out of reach"] += int(np.count_nonzero(~solution.valid))
    refused["insertion out of reach"] += int(np.count_nonzero(solution.valid & ~reaches))
    placements = []
    costs = placement_cost(poses, solution.q, start_pose, q_ref, params)
    for i in np.flatnonzero(solution.valid & reaches):
        reached = _camera_at(kinematics, camera, solution.q[i], p_M[i], R_M[i])
        if reached is None or np.linalg.norm(reached[0] - p_opt) > 1e-4:
            refused["camera off its goal"] += 1
            continue
        if not in_view(camera, reached[0], reached[1], target, params.view_margin_px):
            refused["aperture out of view"] += 1
            continue
        placements.append(Placement(poses[i], solution.q[i], reached[0], float(costs[i])))
    return sorted(placements, key=lambda pl: pl.cost)


def aim_camera(kinematics: Any, camera: CameraModel, arm_mount: tuple[np.ndarray, np.ndarray], pose: Sequence[float],
               ground_z: float, p_opt: np.ndarray, R_opt: np.ndarray, q_ref: np.ndarray) -> np.ndarray | None:
    """Arm angles (rad) placing the camera's optical centre at ``p_opt`` with ``R_nav_optical`` ``R_opt`` (nav) from
    the base pose ``pose`` ``(x, y, yaw)`` (nav, m, rad), found from ``q_ref`` by damped least squares (the
    nearest solution: the closed-form branch nearest ``q_ref`` turns the wrist by a radian near its singularity),
    checked by forward kinematics; ``None`` out of reach.

    The base stops within its tolerances of a placement, and the relocalisation then moves the estimate by the
    odometry's drift: solved again from there, the camera stands where the placement put it.
    """
    p_M, R_M = arm_frames(np.asarray(pose, dtype=float)[None], ground_z, arm_mount)
    R_link = np.asarray(R_opt, dtype=float) @ camera.R_link_optical.T
    p_link = np.asarray(p_opt, dtype=float) - R_link @ camera.offset
    q, ok = DlsIK(kinematics, camera.link).solve_one(R_M[0].T @ (p_link - p_M[0]), R_M[0].T @ R_link,
                                                     np.asarray(q_ref, dtype=float))
    if not ok:
        return None
    reached = _camera_at(kinematics, camera, q, p_M[0], R_M[0])
    if reached is None or np.linalg.norm(reached[0] - p_opt) > 1e-4:
        return None
    return q


def _camera_at(kinematics: Any, camera: CameraModel, q: np.ndarray, p_M: np.ndarray, R_M: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray] | None:
    """The optical centre (nav, m) and ``R_nav_optical`` at ``q`` (pinocchio FK), ``None`` off the joint limits."""
    if not kinematics.within_limits(q):
        return None
    p_l, R_l = kinematics.forward(q, camera.link)
    R = R_M @ R_l
    return p_M + R_M @ p_l + R @ camera.offset, R @ camera.R_link_optical


def in_view(camera: CameraModel, position: np.ndarray, R_nav_optical: np.ndarray, point: np.ndarray,
            margin_px: float = 0.0) -> bool:
    """Whether ``point`` (nav, m) projects inside the image (``margin_px`` from its border), beyond the near clip."""
    uv, depth = camera.project(R_nav_optical.T @ (np.asarray(point, dtype=float) - position))
    return bool(depth > camera.near and margin_px <= uv[0] <= camera.width - 1 - margin_px
                and margin_px <= uv[1] <= camera.height - 1 - margin_px)
