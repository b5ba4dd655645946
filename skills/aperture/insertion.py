"""Planning the grasp, the insertion and the retreat of a launching apparatus (Arora & Papachristos, §IV-F).

The MMS "grasps the MAVs which are carried ... at a priori known holster-like
mounting arrangements" with "collision-free manipulation planning ...
regardless", brings the MAV to g (Phase I), "gently slips" it through the
aperture along −n̂ (Phase II) and turns it to the launch attitude
(Phase III). This module plans those motions in joint space; the skills
``insert_scout`` and ``launch_scout`` execute them.

- The grasp (:data:`T_HANDLE_TCP`): the fingers close across the handle's
  width from above it (tcp z = −handle z, 5 mm above the handle's centre);
  the apparatus and its MAV then ride at fixed poses in the tcp frame, from
  ``launching_apparatus.urdf`` and ``tello.urdf`` (:func:`tool_shapes`).
- What the arm may not touch (:func:`environment`): the occupied voxels of M,
  except those in and around the opening, which at M's 3 cm resolution
  would close an aperture of centimetre clearances; there the aperture's own
  contour C_a (measured in the fronto-parallel image at pixel resolution)
  stands for the rim, as a band of thin boxes on the plane extruded
  ``wall_depth`` into it (:func:`rim_objects`); and the other holsters'
  stowed apparatuses and MAVs.
- Cartesian segments (the descent onto the handle, Phase II, Phase III) are
  interpolated in the task space and solved by the closed-form IK point by
  point (:func:`cartesian_path`); free motions (to the holster, Phase I) are
  OMPL RRT* (:func:`~.arm_motion.plan_arm_path`).

Departure from the paper, named: Phase II stops the handle short of ξ_MAV
(the paper moves the end effector to ξ_MAV, the MAV then d_l past the plane):
the gripper sits 5–9 cm above the handle, and with the handle on the
aperture plane it would reach into the wall above an opening lower than
about 0.2 m. :func:`insertion_depth` takes the deepest insertion, at most
d_l, whose whole line is collision-free, and at least enough for the MAV to
clear the wall's back face by ``clear_back``.

Frames: poses are 4×4 transforms; ``nav`` is the navigation frame of the
MMS's estimate, M the arm frame (:meth:`~marsupial.api.views.ArmModelView.arm_base_pose`).
Metres, radians.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import cv2
import fcl
import numpy as np
import shapely

from marsupial.api.assets import asset_path
from marsupial.api.kinematics import ArmKinematics
from marsupial.api.silhouette import MAV_IN_CRADLE
from marsupial.geometry import transform, yaw_of_rotation

from ..common.carrier_frame import CarrierFrame
from ..common.ik_engine import ClosedFormIK
from .arm_motion import ArmCollisionModel, urdf_shapes
from .launch_pose import LaunchPlan

ARM_LINKS = (*(f"arm_link_{i}" for i in range(1, 7)), "gripper_base", "finger_left", "finger_right")
"""The MMS links that move with the arm (mms.urdf)."""
FIXED_LINKS = ("base_link", "holster_left", "holster_right", "arm_base_link")
"""The MMS links the arm must keep clear of."""
HOLSTERS = ("holster_left", "holster_right")
MMS_URDF = str(asset_path("mms.urdf"))

HANDLE_TO_CRADLE = np.array([0.30, 0.0, 0.0])  # cradle frame in the handle frame (launching_apparatus.urdf)
GRASP_HEIGHT = 0.005  # tcp above the handle's centre when grasping (m): the finger tips stay clear of the pocket


T_HANDLE_TCP = transform((0.0, 0.0, GRASP_HEIGHT), np.diag([-1.0, 1.0, -1.0]))
"""The tcp in the handle frame when grasped: approach axis down onto the handle, closing across its width (y)."""
T_TCP_HANDLE = np.linalg.inv(T_HANDLE_TCP)
T_HANDLE_MAV = transform(HANDLE_TO_CRADLE + MAV_IN_CRADLE, np.eye(3))
"""The MAV's base frame in the handle frame while it sits in the cradle (body x = the apparatus's x)."""


def held_mav_pose(port: Any) -> tuple[np.ndarray, float]:
    """Where the MAV in the held apparatus is, as the MMS knows it: its position (m) and heading (rad) in the MMS's
    navigation frame, from the arm's forward kinematics at the encoder angles, the grasp (``T_HANDLE_TCP``), the
    cradle (``T_HANDLE_MAV``) and the MMS's base estimate (``port``: its onboard interface or command port)."""
    kinematics = port.arm_kinematics
    T_M_mav = kinematics.transform(port.joint_positions(), kinematics.tip_link) @ T_TCP_HANDLE @ T_HANDLE_MAV
    frame = CarrierFrame.of(port)
    return frame.to_world(T_M_mav[:3, 3]), frame.yaw + yaw_of_rotation(T_M_mav[:3, :3])


def tool_shapes(with_mav: bool = True) -> list[tuple[fcl.CollisionGeometry, np.ndarray, str]]:
    """The held apparatus (and its MAV) as fcl shapes in the tcp frame, from their URDFs' collision elements, each
    named ``apparatus <link>`` or ``mav``."""
    T_handle = {"handle": np.eye(4), "cradle": transform(HANDLE_TO_CRADLE, np.eye(3))}
    shapes = [(s.geometry, T_TCP_HANDLE @ T_handle[s.link] @ s.T_link_shape, f"apparatus {s.link}")
              for s in urdf_shapes(asset_path("launching_apparatus.urdf"), list(T_handle))]
    if with_mav:
        shapes += [(s.geometry, T_TCP_HANDLE @ T_HANDLE_MAV @ s.T_link_shape, "mav")
                   for s in urdf_shapes(asset_path("tello.urdf"), ["base_link"])]
    return shapes


def stowed_objects(T_M_holsters: Sequence[np.ndarray]) -> list[fcl.CollisionObject]:
    """fcl objects (in M) of a stowed apparatus and its MAV in each holster frame of ``T_M_holsters``."""
    objects = []
    for T_M_handle in T_M_holsters:
        for geometry, T_tcp_shape, _ in tool_shapes():
            pose = T_M_handle @ T_HANDLE_TCP @ T_tcp_shape
            objects.append(fcl.CollisionObject(geometry, fcl.Transform(pose[:3, :3], pose[:3, 3])))
    return objects


@dataclass(frozen=True)
class Rim:
    """The aperture's measured contour on its plane: C_a in the navigation frame and the plane's frame.

    Attributes:
        contour: ``(n, 3)`` points of C_a on the model plane (nav, m), in order round the opening.
        R_nav_plane: columns: the plane's in-plane axes u, v and its normal n̂ toward the sensor (nav).
        centre: a point of the plane inside the opening (nav, m).
    """

    contour: np.ndarray
    R_nav_plane: np.ndarray
    centre: np.ndarray

    def plane_coordinates(self, points: np.ndarray) -> np.ndarray:
        """``(n, 3)`` nav points as (u, v, height above the plane along n̂) (m)."""
        return (np.asarray(points, dtype=float) - self.centre) @ self.R_nav_plane

    def polygon(self) -> shapely.Polygon:
        """C_a as a polygon in the plane's (u, v) coordinates (m)."""
        return shapely.Polygon(self.plane_coordinates(self.contour)[:, :2]).buffer(0)


def rim_of(plan: LaunchPlan) -> Rim:
    """The :class:`Rim` of a launch plan's aperture (its contour and plane, from the plan's candidate)."""
    n = plan.normal / np.linalg.norm(plan.normal)
    u = np.cross((0.0, 0.0, 1.0), n)
    u = u / np.linalg.norm(u) if np.linalg.norm(u) > 1e-6 else np.array([1.0, 0.0, 0.0])
    return Rim(plan.rim, np.column_stack((u, np.cross(n, u), n)), plan.pre_launch)


def rim_objects(rim: Rim, T_M_nav: np.ndarray, wall_depth: float, band: float = 0.04,
                thickness: float = 0.003, simplify_m: float = 0.002) -> list[fcl.CollisionObject]:
    """The rim as fcl boxes in M: along each edge of C_a, a box ``band`` wide outward from it (plus ``thickness``
    inward), extruded from the plane ``wall_depth`` into the wall (along −n̂)."""
    polygon = rim.polygon()
    ring = np.asarray(polygon.exterior.coords)
    ring = cv2.approxPolyDP(ring.astype(np.float32).reshape(-1, 1, 2), simplify_m, True).reshape(-1, 2)
    if shapely.Polygon(ring).exterior.is_ccw is False:
        ring = ring[::-1]
    objects = []
    width = band + thickness
    previous, following = np.roll(ring, 1, axis=0), np.roll(ring, -1, axis=0)
    d_in, d_out = ring - previous, following - ring
    turn = d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]  # > 0: a convex corner of the opening (ccw ring)
    for i, (a, b) in enumerate(zip(ring, following, strict=True)):
        edge = b - a
        length = float(np.linalg.norm(edge))
        if length < 1e-6:
            continue
        along = edge / length
        outward = np.array([along[1], -along[0]])  # the ring runs counter-clockwise: outward is to its right
        # lengthened by half a width at each convex end, so the corners close; at a reflex corner the boxes
        # overlap already and a lengthened end would reach into the opening
        ext_a = width / 2.0 if turn[i] > 0 else 0.0
        ext_b = width / 2.0 if turn[(i + 1) % len(ring)] > 0 else 0.0
        mid = (a + b) / 2.0 + along * (ext_b - ext_a) / 2.0 + outward * (band - thickness) / 2.0
        x_nav = rim.R_nav_plane[:, :2] @ along
        y_nav = rim.R_nav_plane[:, :2] @ outward
        z_nav = rim.R_nav_plane[:, 2]
        centre = rim.centre + rim.R_nav_plane[:, :2] @ mid - z_nav * wall_depth / 2.0
        pose = T_M_nav @ transform(centre, np.column_stack((x_nav, y_nav, z_nav)))
        box = fcl.Box(length + ext_a + ext_b, width, wall_depth)
        objects.append(fcl.CollisionObject(box, fcl.Transform(pose[:3, :3], pose[:3, 3])))
    return objects


def voxels_off_the_opening(centres: np.ndarray, edges: np.ndarray, rim: Rim, wall_depth: float
                           ) -> tuple[np.ndarray, np.ndarray]:
    """M's occupied voxels (nav centres, edges) without those whose box reaches into the opening of C_a."""
    if len(centres) == 0:
        return centres, edges
    local = rim.plane_coordinates(centres)
    reach = edges * math.sqrt(3.0) / 2.0
    slab = (local[:, 2] <= reach) & (local[:, 2] >= -wall_depth - reach)
    near = np.zeros(len(centres), dtype=bool)
    polygon = rim.polygon()
    for r in np.unique(reach):
        grown = polygon.buffer(float(r))
        rows = slab & (reach == r)
        near[rows] = shapely.contains_xy(grown, local[rows, 0], local[rows, 1])
    keep = ~near
    return centres[keep], edges[keep]


def environment(kinematics: ArmKinematics, urdf: str, T_M_nav: np.ndarray, voxels: tuple[np.ndarray, np.ndarray],
                tool: Sequence[tuple[fcl.CollisionGeometry, np.ndarray, str]],
                extra: Mapping[str, Sequence[fcl.CollisionObject]]) -> ArmCollisionModel:
    """The arm's collision model with ``tool`` carried, against ``voxels`` (nav) and ``extra`` objects (M, by what
    they are)."""
    centres, edges = voxels
    centres_M = (np.c_[centres, np.ones(len(centres))] @ T_M_nav.T)[:, :3] if len(centres) else centres
    return ArmCollisionModel(kinematics, urdf, ARM_LINKS, FIXED_LINKS, tool=tool, obstacles=(centres_M, edges),
                             extra=extra)


def cartesian_path(ik: ClosedFormIK, poses: Sequence[np.ndarray], q_start: np.ndarray,
                   max_jump: float = 0.15) -> np.ndarray | None:
    """Joint angles ``(n, 6)`` (rad) of the tcp at each of ``poses`` (4×4, M), each solution the nearest to the
    one before; ``None`` if one is unreachable or the arm would jump more than ``max_jump`` (rad) between two."""
    q_prev, path = np.asarray(q_start, dtype=float), []
    for T in poses:
        solution = ik.solve(T[:3, 3][None], T[:3, :3][None], q_prev)
        q = solution.q[0]
        if not solution.valid[0] or float(np.max(np.abs(q - q_prev))) > max_jump:
            return None
        path.append(q)
        q_prev = q
    return np.array(path)


def line_poses(T_from: np.ndarray, T_to: np.ndarray, step: float = 0.005, step_angle: float = 0.02
               ) -> list[np.ndarray]:
    """Poses from ``T_from`` to ``T_to`` (4×4): the position on the straight line, the rotation by the shortest
    turn, at most ``step`` (m) and ``step_angle`` (rad) apart; ``T_from`` excluded, ``T_to`` included."""
    R_rel = T_from[:3, :3].T @ T_to[:3, :3]
    rotvec, _ = cv2.Rodrigues(R_rel)
    angle = float(np.linalg.norm(rotvec))
    distance = float(np.linalg.norm(T_to[:3, 3] - T_from[:3, 3]))
    n = max(1, math.ceil(distance / step), math.ceil(angle / step_angle))
    poses = []
    for k in range(1, n + 1):
        s = k / n
        R_s, _ = cv2.Rodrigues(rotvec * s)
        poses.append(transform(T_from[:3, 3] + s * (T_to[:3, 3] - T_from[:3, 3]), T_from[:3, :3] @ R_s))
    return poses


def handle_pose_for_mav(R_mav: np.ndarray, p_mav: np.ndarray) -> np.ndarray:
    """The handle frame (4×4) that puts the MAV held in the cradle at ``p_mav`` with attitude ``R_mav``."""
    return transform(p_mav, R_mav) @ np.linalg.inv(T_HANDLE_MAV)


@dataclass(frozen=True)
class InsertionGoals:
    """The tcp goals (4×4, M) of the three launch phases of one plan.

    Attributes:
        approach: the tcp ``standoff`` out along n̂ from ``phase1``: where Phase I's free motion ends; a straight
            line along −n̂ then brings the MAV onto the plane.
        phase1: the tcp at g: the MAV centred on the aperture plane, rotated to fit (end of Phase I).
        phase2: the tcp at the end of the slip along −n̂ (end of Phase II), ``depth`` past phase1.
        phase3: the tcp once the MAV is turned about its body x to the launch attitude (end of Phase III).
        depth: how far (m) the MAV's centre went past the aperture plane.
    """

    approach: np.ndarray
    phase1: np.ndarray
    phase2: np.ndarray
    phase3: np.ndarray
    depth: float


def insertion_goals(plan: LaunchPlan, T_M_nav: np.ndarray, depth: float, standoff: float) -> InsertionGoals:
    """The tcp goals in M of ``plan``: the MAV ``standoff`` (m) out in front of the plane, on it, and ``depth`` (m)
    past it at the end of Phase II."""
    into = -plan.normal / np.linalg.norm(plan.normal)

    def tcp(R_mav: np.ndarray, p_mav: np.ndarray) -> np.ndarray:
        return T_M_nav @ handle_pose_for_mav(R_mav, p_mav) @ T_HANDLE_TCP

    p_end = plan.pre_launch + depth * into
    return InsertionGoals(tcp(plan.R_pre_launch, plan.pre_launch - standoff * into),
                          tcp(plan.R_pre_launch, plan.pre_launch), tcp(plan.R_pre_launch, p_end),
                          tcp(plan.R_launch, p_end), depth)


@dataclass(frozen=True)
class LaunchPhases:
    """The joint paths (``(n, 6)``, rad) of one plan's straight segments, each checked collision-free.

    Attributes:
        goals: the tcp goals they join.
        entry: the end of Phase I, ``goals.approach`` → g (the MAV onto the aperture plane).
        slip: Phase II, g → the end of the slip.
        turn: Phase III, the turn to the launch attitude.
    """

    goals: InsertionGoals
    entry: np.ndarray
    slip: np.ndarray
    turn: np.ndarray


def _checked(model: ArmCollisionModel, ik: ClosedFormIK, T_from: np.ndarray, T_to: np.ndarray, q_from: np.ndarray
             ) -> np.ndarray | str:
    """The straight tcp segment ``T_from`` → ``T_to`` in joint space from ``q_from``, with ``q_from``; if it is
    unreachable or touches anything, why (``out of reach``, or the first contacts, ArmCollisionModel.contacts)."""
    path = cartesian_path(ik, line_poses(T_from, T_to), q_from)
    if path is None:
        return "out of reach"
    for q in path:
        if not model.free(q):
            return " & ".join(model.contacts(q)) or "joint limits"
    return np.vstack((q_from, path))


def launch_phases(model: ArmCollisionModel, ik: ClosedFormIK, plan: LaunchPlan, T_M_nav: np.ndarray,
                  q_approach: np.ndarray, standoff: float, shallowest: float, deepest: float, step: float = 0.01
                  ) -> LaunchPhases | str:
    """The straight segments of ``plan`` from the arm at ``q_approach`` (the tcp at the approach pose), with the
    deepest Phase II within ``[shallowest, deepest]`` (m) for which the whole sequence is collision-free; if there
    is none, which segment refused it and why (``entry …``, or ``slip …``/``turn …`` at the shallowest depth)."""
    depth, refused = deepest, "slip"
    while depth >= shallowest - 1e-9:
        goals = insertion_goals(plan, T_M_nav, depth, standoff)
        entry = _checked(model, ik, goals.approach, goals.phase1, q_approach)
        if isinstance(entry, str):
            return f"entry {entry}"
        slip = _checked(model, ik, goals.phase1, goals.phase2, entry[-1])
        turn = slip if isinstance(slip, str) else _checked(model, ik, goals.phase2, goals.phase3, slip[-1])
        if not isinstance(slip, str) and not isinstance(turn, str):
            return LaunchPhases(goals, entry, slip, turn)
        refused = f"slip {slip}" if isinstance(slip, str) else f"turn {turn}"
        depth -= step
    return refused


def level_insertion_tcp(target: np.ndarray, normal: np.ndarray, offset: float) -> np.ndarray:
    """The tcp pose (4×4, nav) holding the MAV level, heading along −n̂, its centre ``offset`` (m) in front of
    ``target`` along n̂ (negative: past the plane): the reach a base placement must give the arm."""
    n = np.asarray(normal, dtype=float)
    heading = -np.array([n[0], n[1], 0.0]) / math.hypot(n[0], n[1])
    R_mav = np.column_stack((heading, np.cross((0.0, 0.0, 1.0), heading), (0.0, 0.0, 1.0)))
    return handle_pose_for_mav(R_mav, np.asarray(target, dtype=float) + offset * n / np.linalg.norm(n)) @ T_HANDLE_TCP
