"""RRT* graph of Narváez et al. (Algorithm 2) built by OMPL over IK-valid poses of the vicinity.

Every vertex lies inside the vicinity, outside every zone, and is reached by
joint angles within the ranges; the tree is RRT*'s (one vertex per valid
pose, near-optimal paths from the root, straight along a line); the next
cycle recycles the previous vertices still inside the new vicinity and
valid, counted exactly; the graph is deterministic for a seed.
"""

import itertools
import math

import numpy as np
import pytest

from marsupial.api.kinematics import ArmKinematics
from marsupial.skills.common.ik_engine import IKEngine
from marsupial.skills.uav_docking.cord import Cord, CordParams
from marsupial.skills.uav_docking.graph import Graph, GraphParams, build_graph, rrt_star_tree, section_of
from marsupial.skills.uav_docking.vicinity import build_vicinity
from marsupial.skills.uav_docking.zones import ZoneMap, carrier_zones

L_S = CordParams().L_S
N_ITEMS = CordParams().N  # items in the cord
Q_READY = np.array([0.0, -0.87, 1.98, 0.0, -1.11, 0.0])  # the carrier's "docking_ready" arm pose
UP = np.eye(3)  # Part A pointing up, heading along M's x


@pytest.fixture(scope="module")
def kinematics():
    return ArmKinematics.from_urdf("mobile_manipulator.urdf", "arm_base", "part_a")


@pytest.fixture(scope="module")
def ik(kinematics):
    with IKEngine(kinematics) as engine:
        yield engine


def _line_vicinity(start, heading=0.0, N=N_ITEMS):
    d = np.array([math.cos(heading), math.sin(heading), 0.0])
    items = np.asarray(start, dtype=float) + L_S * np.arange(N)[:, None] * d
    return build_vicinity(Cord(items, 1 if N > 1 else 0, 0, np.zeros(2), False, d[:2]), L_S)


def _fk(kinematics, q):
    return np.array([kinematics.transform(qi) for qi in q])


def test_every_vertex_is_inside_the_vicinity_free_and_ik_valid(kinematics, ik):
    zones = carrier_zones(kinematics, "mobile_manipulator.urdf")
    vicinity = _line_vicinity([0.30, -0.06, 0.70], heading=0.3)
    zones.add_box("crate", vicinity.centers[2], [0.025, 0.025, 0.025], kind="obstacle")  # in the middle section
    graph = build_graph(vicinity, zones, ik, UP, np.random.default_rng(0), Q_READY)
    assert 250 <= graph.n <= GraphParams().samples  # the crate takes its share, hundreds remain
    assert vicinity.contains(graph.positions).all()
    assert zones.points_free(graph.positions).all()
    assert np.all(graph.q >= kinematics.lower) and np.all(graph.q <= kinematics.upper)
    reached = _fk(kinematics, graph.q)
    np.testing.assert_allclose(reached[:, :3, 3], graph.positions, atol=1e-9)
    np.testing.assert_allclose(reached[:, :3, :3], np.broadcast_to(UP, (graph.n, 3, 3)), atol=1e-9)
    # one tree: every vertex but the root has a parent, the root is the vertex nearest to I_1 = P_VS
    assert graph.parent[graph.root] == -1 and np.sum(graph.parent < 0) == 1
    assert graph.edges.shape == (graph.n - 1, 2)
    assert graph.root == graph.nearest(vicinity.centers[0])
    assert np.all(graph.depth[graph.parent[graph.parent >= 0]] < graph.depth[graph.parent >= 0])
    # RRT*: the tree paths from the root are nearly straight (rewiring), never shorter than straight
    straight = np.linalg.norm(graph.positions - graph.positions[graph.root], axis=1)
    assert np.all(graph.cost >= straight - 1e-12)
    assert np.mean(graph.cost[straight > 0.02] / straight[straight > 0.02]) < 1.1


def test_rrt_star_inserts_each_pose_once_and_goes_straight_along_a_line():
    t = np.linspace(0.0, 0.2, 41)
    poses = np.column_stack((t, 0.5 * t, 0.7 + 0.0 * t))  # fed from the root outward, as the sections are
    parent = rrt_star_tree(poses, 0)
    graph = Graph(poses, np.zeros((t.size, 6)), parent, np.zeros(t.size, int), np.zeros(t.size, bool), UP, 0)
    assert graph.n == t.size and np.sum(parent < 0) == 1
    # collinear poses: the cost-to-come is the straight distance from the root, the path runs along the line
    np.testing.assert_allclose(graph.cost, np.linalg.norm(poses - poses[0], axis=1), atol=1e-12)
    assert np.all(np.diff(graph.path(0, t.size - 1)) > 0)
    shuffled = rrt_star_tree(poses[np.random.default_rng(1).permutation(t.size)], 0)
    assert np.sum(shuffled < 0) == 1 and shuffled.size == t.size  # any order: one vertex per pose, one root
    with pytest.raises(ValueError, match="distinct x"):
        rrt_star_tree(np.array([[0.1, 0.0, 0.0], [0.1, 0.1, 0.0]]), 0)


def test_tree_distances_follow_the_paths(kinematics, ik):
    graph = build_graph(_line_vicinity([0.3, 0.0, 0.7]), ZoneMap(), ik, UP, np.random.default_rng(2), Q_READY)
    rng = np.random.default_rng(3)
    for a in rng.choice(graph.n, 5, replace=False):
        distance = graph.distances_from(int(a))
        for b in rng.choice(graph.n, 10, replace=False):
            path = graph.path(int(a), int(b))
            assert path[0] == a and path[-1] == b
            assert all(graph.parent[u] == v or graph.parent[v] == u for u, v in itertools.pairwise(path))  # tree edges
            length = np.sum(np.linalg.norm(np.diff(graph.positions[path], axis=0), axis=1))
            assert distance[b] == pytest.approx(length, abs=1e-12)


def test_recycling_keeps_the_previous_vertices_still_valid(kinematics, ik):
    zones = carrier_zones(kinematics, "mobile_manipulator.urdf")
    rng = np.random.default_rng(4)
    first = build_graph(_line_vicinity([0.30, 0.0, 0.70]), zones, ik, UP, rng, Q_READY)
    assert first.n_recycled == 0
    moved = _line_vicinity([0.32, 0.0, 0.70])  # the next cycle: the vicinity moved 2 cm along the cord
    zones.add_box("new", [0.36, 0.05, 0.70], [0.02, 0.02, 0.05], kind="obstacle")  # and a new obstacle appeared
    per_section = -(-GraphParams().samples // moved.N)
    # the previous vertices expected back: inside the new vicinity, at most MaxSectionSamples per section
    # (the first ones of the previous graph), free of the zones and reachable
    section = section_of(moved, first.positions)
    listed = np.zeros(first.n, dtype=bool)
    for i in range(moved.N):
        listed[np.flatnonzero(section == i)[:per_section]] = True
    still = listed & zones.points_free(first.positions) & ik.solve(first.positions, UP, Q_READY).valid
    second = build_graph(moved, zones, ik, UP, rng, Q_READY, previous=first)
    assert second.n_recycled == int(still.sum()) > 0.5 * first.n
    old = {tuple(p) for p in first.positions[still]}
    assert {tuple(p) for p in second.positions[second.recycled]} == old  # kept exactly where they were
    assert not zones.points_free(first.positions).all()  # some were dropped by the new obstacle
    assert zones.points_free(second.positions).all()
    assert np.all(np.bincount(second.section, minlength=moved.N) <= per_section)
    far = build_graph(_line_vicinity([0.0, 0.45, 0.6], heading=1.6), zones, ik, UP, rng, Q_READY, previous=second)
    assert far.n_recycled == 0 and far.n > 300


def test_same_seed_same_graph_and_empty_when_unreachable(kinematics, ik):
    vicinity = _line_vicinity([0.25, 0.1, 0.75], heading=-0.8, N=1)  # cordless: one ellipsoid
    a = build_graph(vicinity, ZoneMap(), ik, UP, np.random.default_rng(5), Q_READY)
    b = build_graph(vicinity, ZoneMap(), ik, UP, np.random.default_rng(5), Q_READY)
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.parent, b.parent)
    assert a.n == GraphParams().samples  # one section holds every sample
    beyond = build_graph(_line_vicinity([1.2, 0.0, 0.7]), ZoneMap(), ik, UP, np.random.default_rng(6), Q_READY)
    assert beyond.n == 0 and beyond.root == -1 and beyond.nearest(np.zeros(3)) == -1
