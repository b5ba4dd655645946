"""RRT* graph of end-effector positions inside the vicinity (Narváez et al., §IV-A-2, Algorithm 2).

Each planning cycle fills, section by section, a list of random poses:
first the previous graph's vertices that fall inside the section
(``RecycleVertices``), then new random positions drawn in the section's
ellipsoid (``RandomPoseGenerate``, rotated and translated onto S_i) up to
``MaxSectionSamples``. The IK engine keeps the poses the arm reaches with
every joint in range (Algorithm 3); poses inside a prohibited zone are
dropped too (the vicinity is free after the repair, but a failed repair
must not leak a vertex into a zone). RRT* then inserts every valid pose
into one tree G(V, E).

The tree is built by OMPL's RRT* (``ompl.geometric.RRTstar``, r-disc
neighbourhoods, the original RRT* of Karaman & Frazzoli, the paper's [47])
in a 3-D position space bounded by the valid poses' bounding box. The
OMPL 2.0.1 Python bindings let a ``StateSampler`` be subclassed but offer
no way to install one in a state space (no ``setStateSamplerAllocator``),
and RRT* ignores valid-state samplers; so the valid poses reach RRT*
through its goal sampler instead: a ``GoalSampleableRegion``
that hands them out one per iteration, with goal bias 1 (every RRT*
sample is a goal sample) and a goal that is never satisfied. The planner
stops after one iteration per pose, and the steering range covers the
whole space, so each sample becomes a vertex exactly where it was drawn,
connected to the neighbour of least cost-to-come and rewired as RRT* does.
States are not collision-checked inside OMPL (an all-valid checker): every
vertex was validated before insertion and the vicinity is free of the
zones, which is the paper's argument ("there is no need for collision
evaluation for each new pose added to the graph"). A stop after a fixed
number of iterations (not a time budget) keeps the graph deterministic.

Measured on the project's 2-core machine (``benchmarks/motion_engine.py``):
RRT* over 360 poses ≈ 4–7 ms with r-disc neighbourhoods, the whole graph
stage (IK engine, zone check, RRT*) ≈ 9 ms CPU at the median; OMPL's
default k-nearest neighbourhoods took ≈ 12 ms for 300 poses alone and grew
quadratically (≈ 45 ms for 600), hence ``setKNearest(False)``.

Frame: manipulator frame M, metres; every vertex shares one end-effector
orientation per cycle (the P_VS orientation).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from ..common.ik_engine import IKEngine
from .vicinity import PointZones, Vicinity

ou.setLogLevel(ou.LOG_WARN)  # RRT* informs about its set-up on every cycle otherwise


@dataclass(frozen=True)
class GraphParams:
    """Graph-building parameters (the paper gives "several hundreds of valid vertices in every iteration").

    Attributes:
        samples: random poses per cycle, recycled ones included; each of the N sections
            gets MaxSectionSamples = ceil(samples / N) (Algorithm 2, line 4).
        rewire_factor: OMPL RRT*'s rewire factor (≥ 1 for asymptotic optimality).
        padding: margin (m) of the RRT* state-space bounds around the poses.
    """

    samples: int = 360
    rewire_factor: float = 1.1
    padding: float = 1e-3

    def __post_init__(self) -> None:
        if self.samples < 1 or self.rewire_factor <= 0 or self.padding <= 0:
            raise ValueError(f"GraphParams needs samples >= 1, rewire_factor > 0 and padding > 0; got {self}")


@dataclass(frozen=True)
class Graph:
    """The tree G(V, E) of end-effector positions, all IK-valid with one orientation (M frame).

    Attributes:
        positions: ``(n, 3)`` vertex positions (m).
        q: ``(n, dof)`` joint angles reaching each vertex (rad), within the joint ranges.
        parent: ``(n,)`` parent vertex of each vertex in the tree, -1 for the root.
        section: ``(n,)`` vicinity section S_i the vertex was drawn in.
        recycled: ``(n,)`` True for vertices kept from the previous graph.
        rotation: the end-effector orientation (3×3 in M) of every vertex.
        root: index of the root vertex (-1 in an empty graph).
        order: ``(n,)`` vertices by depth in the tree, root first (every parent before its children).
        depth: ``(n,)`` number of edges from the root.
        cost: ``(n,)`` length (m) of the tree path from the root (RRT*'s cost-to-come).
    """

    positions: np.ndarray
    q: np.ndarray
    parent: np.ndarray
    section: np.ndarray
    recycled: np.ndarray
    rotation: np.ndarray
    root: int
    order: np.ndarray = field(init=False, repr=False)
    depth: np.ndarray = field(init=False, repr=False)
    cost: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        order, depth, cost = _tree_levels(self.positions, self.parent, self.root)
        object.__setattr__(self, "order", order)
        object.__setattr__(self, "depth", depth)
        object.__setattr__(self, "cost", cost)

    @classmethod
    def empty(cls, rotation: np.ndarray, dof: int = 6) -> Graph:
        """A graph without vertices (nothing valid in the vicinity)."""
        none = np.zeros(0, dtype=int)
        return cls(np.zeros((0, 3)), np.zeros((0, dof)), none, none, np.zeros(0, dtype=bool), rotation, -1)

    @property
    def n(self) -> int:
        """Number of vertices."""
        return int(self.positions.shape[0])

    @property
    def n_recycled(self) -> int:
        """Number of vertices kept from the previous graph."""
        return int(self.recycled.sum())

    @property
    def edges(self) -> np.ndarray:
        """``(n - 1, 2)`` tree edges (parent, child)."""
        child = np.flatnonzero(self.parent >= 0)
        return np.column_stack((self.parent[child], child))

    def nearest(self, point: np.ndarray) -> int:
        """Index of the vertex closest to ``point`` (m, M frame); -1 in an empty graph."""
        if self.n == 0:
            return -1
        return int(np.argmin(np.sum((self.positions - np.asarray(point, dtype=float)) ** 2, axis=1)))

    def path_to_root(self, v: int) -> list[int]:
        """Vertices from ``v`` up to the root, both included."""
        path = [v]
        while self.parent[path[-1]] >= 0:
            path.append(int(self.parent[path[-1]]))
        return path

    def path(self, a: int, b: int) -> list[int]:
        """The tree path from vertex ``a`` to vertex ``b``, both included."""
        up_a, up_b = self.path_to_root(a), self.path_to_root(b)
        on_b = set(up_b)
        meet = next(v for v in up_a if v in on_b)  # lowest common ancestor
        return up_a[: up_a.index(meet) + 1] + up_b[: up_b.index(meet)][::-1]

    def distances_from(self, a: int) -> np.ndarray:
        """``(n,)`` length (m) of the tree path from vertex ``a`` to every vertex.

        d(a, v) = c(a) + c(v) − 2·c(lca(a, v)) with c the cost from the root;
        the lowest common ancestors of all v are found level by level.
        """
        on_a = np.zeros(self.n, dtype=bool)
        on_a[self.path_to_root(a)] = True
        lca = np.arange(self.n)
        bounds = np.searchsorted(self.depth[self.order], np.arange(1, int(self.depth.max(initial=0)) + 2))
        for start, end in itertools.pairwise(bounds):
            level = self.order[start:end]
            lca[level] = np.where(on_a[level], level, lca[self.parent[level]])
        return self.cost[a] + self.cost - 2.0 * self.cost[lca]


def _tree_levels(positions: np.ndarray, parent: np.ndarray, root: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices by depth (root first), their depth and their path length from the root (m).

    Pointer doubling: each round adds the depth and length of the path up to
    the present ancestor and jumps to that ancestor's ancestor.
    """
    n = parent.size
    if n == 0:
        return np.zeros(0, dtype=int), np.zeros(0, dtype=int), np.zeros(0)
    child = parent >= 0
    if child.sum() != n - 1 or parent[root] != -1:
        raise RuntimeError("the RRT* tree must have one root and a parent for every other vertex")
    depth = child.astype(int)
    cost = np.zeros(n)
    cost[child] = np.linalg.norm(positions[child] - positions[parent[child]], axis=1)
    jump = parent.copy()
    for _ in range(n):
        up = np.flatnonzero(jump >= 0)
        if up.size == 0:
            break
        ancestor = jump[up]
        depth[up] += depth[ancestor]
        cost[up] += cost[ancestor]
        jump[up] = jump[ancestor]
    return np.argsort(depth, kind="stable"), depth, cost


class _PoseFeed(ob.GoalSampleableRegion):
    """The valid poses, handed to RRT* one per iteration as its samples; never satisfied as a goal."""

    def __init__(self, si: ob.SpaceInformation, poses: list[list[float]]):
        super().__init__(si)
        self.poses = poses
        self.drawn = 0

    def sampleGoal(self, state: ob.State) -> None:  # noqa: N802 (OMPL's name)
        x, y, z = self.poses[self.drawn]
        state[0], state[1], state[2] = x, y, z
        self.drawn += 1

    def maxSampleCount(self) -> int:  # noqa: N802
        return len(self.poses)

    def distanceGoal(self, state: ob.State) -> float:  # noqa: N802
        return float("inf")


def rrt_star_tree(
    poses: np.ndarray, root: int, params: GraphParams = GraphParams()
) -> np.ndarray:
    """OMPL RRT* over the given positions, each inserted once in the given order, from ``poses[root]``.

    Args:
        poses: ``(n, 3)`` positions (m) with distinct x coordinates (each vertex is found by its x).
        root: index of the tree's start state.

    Returns the ``(n,)`` parent of each pose in the tree (-1 for the root).
    """
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    n = poses.shape[0]
    if n == 1:
        return np.array([-1])
    index_of_x = {float(x): i for i, x in enumerate(poses[:, 0])}  # OMPL's vertices are exact copies of the poses
    if len(index_of_x) != n:
        raise ValueError("rrt_star_tree needs poses with distinct x coordinates (random poses have them)")
    space = ob.RealVectorStateSpace(3)
    bounds = ob.RealVectorBounds(3)
    lower, upper = poses.min(axis=0) - params.padding, poses.max(axis=0) + params.padding
    for k in range(3):
        bounds.setLow(k, float(lower[k]))
        bounds.setHigh(k, float(upper[k]))
    space.setBounds(bounds)
    si = ob.SpaceInformation(space)
    si.setStateValidityChecker(ob.AllValidStateValidityChecker(si))
    si.setStateValidityCheckingResolution(0.5)  # all valid: one check per half extent is plenty
    si.setup()
    start = si.allocState()
    start[0], start[1], start[2] = (float(v) for v in poses[root])
    others = np.delete(np.arange(n), root)
    feed = _PoseFeed(si, poses[others].tolist())
    problem = ob.ProblemDefinition(si)
    problem.addStartState(start)
    problem.setGoal(feed)
    planner = og.RRTstar(si)
    planner.setProblemDefinition(problem)
    planner.setGoalBias(1.0)  # every sample comes from the feed
    planner.setRange(float(np.linalg.norm(upper - lower)))  # never steer short of a sample
    planner.setKNearest(False)  # r-disc neighbourhoods
    planner.setRewireFactor(params.rewire_factor)
    planner.setup()
    planner.solve(ob.PlannerTerminationCondition(lambda: feed.drawn >= len(feed.poses)))
    data = ob.PlannerData(si)
    planner.getPlannerData(data)
    if data.numVertices() != n:
        raise RuntimeError(f"RRT* kept {data.numVertices()} of {n} poses")
    pose_of = np.empty(n, dtype=int)
    parent_vertex = np.full(n, -1)
    for v in range(n):
        pose_of[v] = index_of_x[data.getVertex(v).getState()[0]]
        incoming = data.getIncomingEdges(v)
        if incoming:
            parent_vertex[v] = incoming[0]
    parent = np.full(n, -1)
    has_parent = parent_vertex >= 0
    parent[pose_of[has_parent]] = pose_of[parent_vertex[has_parent]]
    return parent


def section_of(vicinity: Vicinity, points: np.ndarray) -> np.ndarray:
    """``(n,)`` section S_i of each point (m, M frame), -1 outside the vicinity.

    A point inside several (overlapping) sections belongs to the one in whose
    ellipsoid it lies deepest (smallest normalised radius).
    """
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    local = np.einsum("nji,mnj->mni", vicinity.rotations, points[:, None, :] - vicinity.centers[None])
    radius = np.sum((local / vicinity.semi_axes[None]) ** 2, axis=2)
    deepest = np.argmin(radius, axis=1)
    return np.where(radius[np.arange(points.shape[0]), deepest] <= 1.0, deepest, -1)


def build_graph(
    vicinity: Vicinity,
    zones: PointZones,
    ik: IKEngine,
    rotation: np.ndarray,
    rng: np.random.Generator,
    q_ref: np.ndarray | None = None,
    previous: Graph | None = None,
    params: GraphParams = GraphParams(),
) -> Graph:
    """Algorithm 2: the RRT* graph inside ``vicinity``, recycling ``previous``'s vertices.

    Args:
        vicinity: the (repaired) vicinity, M frame.
        zones: the zone map (vertices must be free of it).
        ik: the IK engine (Algorithm 3).
        rotation: end-effector orientation (3×3 in M) of every pose.
        rng: the random source of the new poses.
        q_ref: the arm's present configuration (rad): each vertex keeps the IK branch closest to it.
        previous: the previous cycle's graph G_0(V_0) (``None`` on the first cycle).

    The root is the valid pose closest to the first item I_1 (P_VS).
    """
    rotation = np.asarray(rotation, dtype=float)
    per_section = -(-params.samples // vicinity.N)  # MaxSectionSamples
    # RecycleVertices(V_0): previous vertices inside the new vicinity, each in the section it lies deepest in
    old = np.zeros((0, 3)) if previous is None else previous.positions
    old_section = section_of(vicinity, old)
    kept = old_section >= 0
    old, old_section = old[kept], old_section[kept]
    recycled_per_section = np.bincount(old_section, minlength=vicinity.N)
    keep_old = np.zeros(old.shape[0], dtype=bool)
    for i in range(vicinity.N):  # a section holds at most MaxSectionSamples poses
        keep_old[np.flatnonzero(old_section == i)[:per_section]] = True
    old, old_section = old[keep_old], old_section[keep_old]
    recycled_per_section = np.minimum(recycled_per_section, per_section)
    # RandomPoseGenerate → Rotate → Translate, up to MaxSectionSamples per section
    new, new_section = vicinity.sample(per_section, rng)
    rank = np.arange(new.shape[0]) - new_section * per_section
    fill = rank < per_section - recycled_per_section[new_section]
    positions = np.concatenate((old, new[fill]))
    section = np.concatenate((old_section, new_section[fill]))
    recycled = np.arange(positions.shape[0]) < old.shape[0]
    # IK engine (Algorithm 3) and the zone check
    solution = ik.solve(positions, rotation, q_ref)
    valid = solution.valid & zones.points_free(positions)
    if not valid.any():
        return Graph.empty(rotation, solution.q.shape[1])
    sort = np.argsort(section[valid], kind="stable")  # section by section, as Algorithm 2 inserts them
    index = np.flatnonzero(valid)[sort]
    positions, q, section, recycled = positions[index], solution.q[index], section[index], recycled[index]
    root = int(np.argmin(np.sum((positions - vicinity.centers[0]) ** 2, axis=1)))
    return Graph(positions, q, rrt_star_tree(positions, root, params), section, recycled, rotation, root)
