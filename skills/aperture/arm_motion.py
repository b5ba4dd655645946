"""Collision-free arm motion of the MMS (Arora & Papachristos, §IV-F): fcl collision checks, OMPL RRT*, toppra timing.

"Collision-free arm planning" for grasping the launching apparatus from its
holster and for Phase I of the launch:

- :class:`ArmCollisionModel` — python-fcl shapes of the arm's links, taken
  from the URDF's ``<collision>`` elements and posed by the pinocchio model
  (:class:`~marsupial.api.kinematics.ArmKinematics`) at a joint vector,
  plus shapes carried by the tool (the apparatus and the MAV, in the tcp
  frame). They are checked against the occupied voxels of the volumetric
  map M (one fcl box per occupied OctoMap leaf, a broad-phase AABB tree),
  against the robot's own fixed links (base, holsters) and between arm
  links two or more joints apart.
- :func:`plan_arm_path` — OMPL RRT* in joint space within the joint limits,
  each state and each motion checked by the model (at ``resolution`` rad);
  seeded, and ended after a number of validity checks rather than a wall-clock
  budget, so a mission + seed plans the same path every run.
- :func:`~..common.trajectory.time_joint_path` (toppra) times the path.

Frames: the arm frame M (the kinematics' base link) for every pose; the
map's voxels are brought into M by the arm base's estimated pose in the
navigation frame. Metres, radians.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import fcl
import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from marsupial.api.kinematics import ArmKinematics
from marsupial.api.silhouette import _numbers

ou.setLogLevel(ou.LOG_WARN)  # OMPL reports every solve at INFO


def _request() -> fcl.CollisionRequest:
    """A boolean collision query by fcl's own GJK: its default (libccd) reports cylinders touching boxes they are
    centimetres from (measured: a 21 mm-radius cylinder 68 mm from a box, python-fcl 0.7)."""
    return fcl.CollisionRequest(gjk_solver_type=fcl.GJKSolverType.GST_INDEP)


@dataclass(frozen=True)
class Shape:
    """One collision shape rigidly attached to a link.

    Attributes:
        link: the link (frame of the arm model) it moves with.
        geometry: the fcl geometry (box, cylinder along z, sphere).
        T_link_shape: 4×4 pose of the shape in the link frame.
        name: what :meth:`ArmCollisionModel.contacts` calls it (default: the link's name).
    """

    link: str
    geometry: fcl.CollisionGeometry
    T_link_shape: np.ndarray
    name: str = ""

    @property
    def label(self) -> str:
        """The shape's name, else its link's."""
        return self.name or self.link


def _transform(xyz: Sequence[float], rpy: Sequence[float]) -> np.ndarray:
    """4×4 transform of a URDF ``<origin>`` (m, rad; R = Rz(yaw) Ry(pitch) Rx(roll))."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    T = np.eye(4)
    T[:3, :3] = np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                          [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                          [-sp, cp * sr, cp * cr]])
    T[:3, 3] = xyz
    return T


def _geometry(element: ET.Element) -> fcl.CollisionGeometry | None:
    """The fcl geometry of a URDF ``<geometry>`` (box, cylinder, sphere; ``None`` for meshes)."""
    if (box := element.find("box")) is not None:
        return fcl.Box(*_numbers(box, "size"))
    if (cylinder := element.find("cylinder")) is not None:
        return fcl.Cylinder(float(cylinder.get("radius", 0)), float(cylinder.get("length", 0)))
    if (sphere := element.find("sphere")) is not None:
        return fcl.Sphere(float(sphere.get("radius", 0)))
    return None


def urdf_shapes(urdf: str | Path, links: Sequence[str]) -> list[Shape]:
    """The ``<collision>`` shapes of ``links`` in a URDF file, each in its link's frame."""
    root = ET.parse(str(urdf)).getroot()
    shapes = []
    for link in root.iter("link"):
        name = link.get("name", "")
        if name not in links:
            continue
        for collision in link.iter("collision"):
            origin = collision.find("origin")
            xyz = _numbers(origin, "xyz") or [0.0, 0.0, 0.0]
            rpy = _numbers(origin, "rpy") or [0.0, 0.0, 0.0]
            geometry_element = collision.find("geometry")
            geometry = _geometry(geometry_element) if geometry_element is not None else None
            if geometry is not None:
                shapes.append(Shape(name, geometry, _transform(xyz, rpy)))
    return shapes


def _object(shape: Shape, T: np.ndarray) -> fcl.CollisionObject:
    """An fcl object of ``shape`` with its link at ``T`` (4×4)."""
    pose = T @ shape.T_link_shape
    return fcl.CollisionObject(shape.geometry, fcl.Transform(pose[:3, :3], pose[:3, 3]))


def voxel_manager(centres: np.ndarray, sizes: np.ndarray, extra: Sequence[fcl.CollisionObject] = ()
                  ) -> fcl.DynamicAABBTreeCollisionManager:
    """A broad-phase manager of one axis-aligned fcl box per voxel (centres ``(n, 3)`` and edges ``(n,)``, m),
    and of the ``extra`` objects."""
    manager = fcl.DynamicAABBTreeCollisionManager()
    objects = [fcl.CollisionObject(fcl.Box(s, s, s), fcl.Transform(np.asarray(c, dtype=float)))
               for c, s in zip(centres, sizes, strict=True)] + list(extra)
    if objects:
        manager.registerObjects(objects)
    manager.setup()
    return manager


class ArmCollisionModel:
    """The arm, what it carries and the robot's fixed links as fcl shapes; collision queries at a joint vector.

    Links are told apart by the arm joint that moves them (:meth:`ArmKinematics.moved_by`): shapes two or
    more joints apart are checked against each other, and the fixed links against the shapes moved by the
    third joint on (the first two joints' links are mounted on them).

    Args:
        kinematics: the arm model (its base link is frame M).
        urdf: the robot's URDF (collision elements of the arm's links and of ``fixed_links``).
        arm_links: the moving links (their shapes move with ``q``).
        fixed_links: links that do not move with the arm (base, holsters), in M.
        tool: shapes carried by the tool, ``(geometry, T_tcp_shape, name)`` in the kinematics' tip frame.
        obstacles: occupied voxels in M: ``(centres (n, 3), edges (n,))`` (m).
        extra: further fixed fcl objects in M by what they are (e.g. ``"rim"``, ``"stowed apparatus"``).
    """

    def __init__(self, kinematics: ArmKinematics, urdf: str | Path, arm_links: Sequence[str],
                 fixed_links: Sequence[str] = (), tool: Sequence[tuple[fcl.CollisionGeometry, np.ndarray, str]] = (),
                 obstacles: tuple[np.ndarray, np.ndarray] | None = None,
                 extra: Mapping[str, Sequence[fcl.CollisionObject]] | None = None):
        self.kinematics = kinematics
        shapes = urdf_shapes(urdf, list(arm_links))
        shapes += [Shape(kinematics.tip_link, g, np.asarray(T, dtype=float), name) for g, T, name in tool]
        self.shapes = shapes
        self.frames = sorted({s.link for s in shapes})
        self._frame_of = [self.frames.index(s.link) for s in shapes]
        self.objects = [fcl.CollisionObject(s.geometry, fcl.Transform()) for s in shapes]
        joint = [kinematics.moved_by(s.link) for s in shapes]
        zero = np.zeros(kinematics.dof)
        fixed = [_object(s, kinematics.transform(zero, s.link)) for s in urdf_shapes(urdf, list(fixed_links))]
        self.pairs = [(a, b) for a in range(len(shapes)) for b in range(a + 1, len(shapes))
                      if abs(joint[a] - joint[b]) >= 2]
        self.fixed_pairs = [(a, f) for a in range(len(shapes)) if joint[a] >= 3 for f in fixed]
        self.arm = fcl.DynamicAABBTreeCollisionManager()
        self.arm.registerObjects(self.objects)
        self.arm.setup()
        centres, edges = obstacles if obstacles is not None else (np.zeros((0, 3)), np.zeros(0))
        self.extra = dict(extra or {})
        every_extra = [obj for objects in self.extra.values() for obj in objects]
        self.voxels = voxel_manager(centres, edges) if len(centres) else None
        self.environment = voxel_manager(centres, edges, every_extra) if len(centres) or every_extra else None
        self.checks = 0

    def _pose(self, q: np.ndarray) -> None:
        """Move every shape's object to the arm at ``q`` (rad)."""
        transforms = self.kinematics.transforms(q, self.frames)
        for obj, shape, k in zip(self.objects, self.shapes, self._frame_of, strict=True):
            pose = transforms[k] @ shape.T_link_shape
            obj.setTransform(fcl.Transform(pose[:3, :3], pose[:3, 3]))
        self.arm.update()

    def _touching_map(self) -> bool:
        """Whether any posed shape touches an occupied voxel."""
        if self.environment is None:
            return False
        data = fcl.CollisionData(request=_request())
        self.environment.collide(self.arm, data, fcl.defaultCollisionCallback)
        return bool(data.result.is_collision)

    def contacts(self, q: np.ndarray) -> list[str]:
        """What the arm at ``q`` (rad) touches: ``"<shape>: map"`` (a voxel), ``"<shape>: <extra>"`` (e.g. rim),
        ``"<shape>: robot"``, ``"<shape>: <shape>"``; shapes by :attr:`Shape.label`."""
        self._pose(q)
        request = _request()
        found = []
        for a, obj in enumerate(self.objects):
            if self.voxels is not None:
                data = fcl.CollisionData(request=_request())
                self.voxels.collide(obj, data, fcl.defaultCollisionCallback)
                if data.result.is_collision:
                    found.append(f"{self.shapes[a].label}: map")
            found += [f"{self.shapes[a].label}: {name}" for name, objects in self.extra.items()
                      if any(fcl.collide(obj, other, request, fcl.CollisionResult()) for other in objects)]
        found += [f"{self.shapes[a].label}: robot" for a, f in self.fixed_pairs
                  if fcl.collide(self.objects[a], f, request, fcl.CollisionResult())]
        found += [f"{self.shapes[a].label}: {self.shapes[b].label}" for a, b in self.pairs
                  if fcl.collide(self.objects[a], self.objects[b], request, fcl.CollisionResult())]
        return sorted(set(found))

    def free(self, q: np.ndarray) -> bool:
        """Whether the arm at ``q`` (rad) is within its joint limits and touches nothing (counted in ``checks``)."""
        self.checks += 1
        if not self.kinematics.within_limits(q):
            return False
        self._pose(q)
        request = _request()
        if any(fcl.collide(self.objects[a], f, request, fcl.CollisionResult()) for a, f in self.fixed_pairs):
            return False
        if any(fcl.collide(self.objects[a], self.objects[b], request, fcl.CollisionResult()) for a, b in self.pairs):
            return False
        return not self._touching_map()


@dataclass(frozen=True)
class ArmPlanParams:
    """Settings of :func:`plan_arm_path`.

    Attributes:
        resolution: joint-space spacing (rad) of the motion checks and of the returned path.
        max_checks: the planner stops after this many validity checks (deterministic, unlike a time budget).
        goal_bias: fraction of RRT*'s samples drawn at the goal.
        range: RRT*'s longest extension (rad, joint-space norm).
    """

    resolution: float = 0.05
    max_checks: int = 4000
    goal_bias: float = 0.1
    range: float = 0.6


def densify(path: np.ndarray, resolution: float) -> np.ndarray:
    """The polyline ``path`` ``(n, dof)`` with points at most ``resolution`` (rad, joint-space norm) apart."""
    out = [path[0]]
    for a, b in zip(path[:-1], path[1:], strict=True):
        steps = max(1, math.ceil(float(np.linalg.norm(b - a)) / resolution))
        out += [a + (b - a) * k / steps for k in range(1, steps + 1)]
    return np.array(out)


class _SeededSamples(ob.GoalSampleableRegion):
    """RRT*'s samples from a seeded numpy generator, as goal samples (goal bias 1): the goal itself with
    probability ``goal_fraction``, else uniform within the joint limits; satisfied within ``threshold`` of the goal.

    OMPL 2.0.1's Python bindings cannot replace a space's state sampler, and its own generator is seeded once
    per process: feeding the samples this way makes a plan depend only on its seed.
    """

    def __init__(self, si: ob.SpaceInformation, goal: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                 seed: int, goal_fraction: float, threshold: float):
        super().__init__(si)
        self.goal, self.lower, self.upper = goal, lower, upper
        self.rng = np.random.default_rng(seed)
        self.goal_fraction = goal_fraction
        self.setThreshold(threshold)

    def sampleGoal(self, state: ob.State) -> None:  # noqa: N802 (OMPL's name)
        q = self.goal if self.rng.random() < self.goal_fraction else self.rng.uniform(self.lower, self.upper)
        for k, value in enumerate(q):
            state[k] = float(value)

    def maxSampleCount(self) -> int:  # noqa: N802
        return 1 << 30

    def distanceGoal(self, state: ob.State) -> float:  # noqa: N802
        return float(np.linalg.norm([state[k] - self.goal[k] for k in range(self.goal.size)]))


def plan_arm_path(model: ArmCollisionModel, q_start: np.ndarray, q_goal: np.ndarray, seed: int,
                  params: ArmPlanParams = ArmPlanParams()) -> np.ndarray | None:
    """A collision-free joint path ``(n, dof)`` (rad) from ``q_start`` to ``q_goal`` by OMPL RRT*, or ``None``.

    The straight joint-space line is taken when it is free. Otherwise RRT* runs on samples drawn with
    ``seed`` until ``params.max_checks`` validity checks, improving its path meanwhile; the path is returned
    densified to ``params.resolution``, every point checked free (``None`` if it found none).
    """
    kin = model.kinematics
    q_start, q_goal = np.asarray(q_start, dtype=float), np.asarray(q_goal, dtype=float)
    if not (model.free(q_start) and model.free(q_goal)):
        return None
    line = densify(np.vstack((q_start, q_goal)), params.resolution)
    if all(model.free(q) for q in line):
        return line
    space = ob.RealVectorStateSpace(kin.dof)
    bounds = ob.RealVectorBounds(kin.dof)
    for k in range(kin.dof):
        bounds.setLow(k, float(kin.lower[k]))
        bounds.setHigh(k, float(kin.upper[k]))
    space.setBounds(bounds)
    si = ob.SpaceInformation(space)
    si.setStateValidityChecker(lambda state: model.free(np.array([state[k] for k in range(kin.dof)])))
    si.setStateValidityCheckingResolution(params.resolution / float(np.linalg.norm(kin.upper - kin.lower)))
    si.setup()
    start = si.allocState()
    for k in range(kin.dof):
        start[k] = float(q_start[k])
    samples = _SeededSamples(si, q_goal, kin.lower, kin.upper, seed, params.goal_bias, params.resolution / 2.0)
    problem = ob.ProblemDefinition(si)
    problem.addStartState(start)
    problem.setGoal(samples)
    planner = og.RRTstar(si)
    planner.setProblemDefinition(problem)
    planner.setGoalBias(1.0)  # every sample comes from the seeded feed
    planner.setRange(params.range)
    planner.setup()
    first = model.checks
    planner.solve(ob.PlannerTerminationCondition(lambda: model.checks - first >= params.max_checks))
    if not problem.hasExactSolution():
        return None
    solution = problem.getSolutionPath()
    path = np.array([[solution.getState(i)[k] for k in range(kin.dof)] for i in range(solution.getStateCount())])
    dense = densify(path, params.resolution)
    return dense if all(model.free(q) for q in dense) else None
