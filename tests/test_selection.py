"""Merge and selection of Narváez et al. (§IV-A-3): P_VS, eqs. (9)–(12) and P_R on the graph.

Hand-computed cases: the tracking state V_tr of eqs. (9)–(11) with
K_pos = 2·K_ang, the path length L_p of eq. (12) capped at L_C, pose rates
with wrapped angles, the cord progress of a point, and the vertex P_R at
most L_p along the tree from V_vs, farthest along the cord. P_VS puts the
marker in the centre of the eye-in-hand image, checked through the arm's
forward kinematics.
"""

import math

import numpy as np
import pytest

from marsupial.api.kinematics import ArmKinematics
from marsupial.skills.common.ik_engine import IKEngine
from marsupial.skills.uav_docking.graph import Graph
from marsupial.skills.uav_docking.selection import (
    PbvsTarget,
    SelectionParams,
    cord_progress,
    mean_motion,
    path_length,
    pbvs_target,
    pose_rates,
    rot_z,
    select,
    tracking_state,
)

Q_READY = np.array([0.0, -0.87, 1.98, 0.0, -1.11, 0.0])


def _pose(p, yaw=0.0, roll=0.0):
    T = np.eye(4)
    c, s = math.cos(roll), math.sin(roll)
    T[:3, :3] = rot_z(yaw) @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    T[:3, 3] = p
    return T


def test_tracking_state_eqs_9_to_11_by_hand():
    params = SelectionParams(K_ang=0.5)
    assert params.K_pos == 2.0 * params.K_ang == 1.0  # K_pos = 2·K_ang, §IV-A-3
    v_eff = np.array([0.10, -0.20, 0.05, 0.30, 0.0, -0.10])
    v_uav = np.array([0.15, 0.00, -0.03, 0.00, 0.2, 0.00])
    # eq. (10): (1.0·(0.10 + 0.20 + 0.05) + 0.5·(0.30 + 0 + 0.10)) / 6 = (0.35 + 0.20) / 6
    assert mean_motion(v_eff, params) == pytest.approx(0.55 / 6)
    # eq. (11): (1.0·(0.15 + 0 + 0.03) + 0.5·(0 + 0.2 + 0)) / 6 = (0.18 + 0.10) / 6
    assert mean_motion(v_uav, params) == pytest.approx(0.28 / 6)
    assert tracking_state(v_eff, v_uav, params) == pytest.approx(0.83 / 6)  # eq. (9)
    # positions weigh twice the angles: 0.1 m/s moves V_tr as much as 0.2 rad/s
    assert mean_motion([0.1, 0, 0, 0, 0, 0], params) == pytest.approx(mean_motion([0, 0, 0, 0.2, 0, 0], params))
    other = SelectionParams(K_ang=0.8)
    assert other.K_pos == pytest.approx(1.6)


def test_path_length_eq_12_by_hand():
    params = SelectionParams(K_ang=0.5, K_Lp=0.02, L_C=0.15)
    assert path_length(0.10, params) == pytest.approx(0.02 * 0.15 / 0.10)  # 0.03 m
    assert path_length(0.05, params) == pytest.approx(0.06)
    assert path_length(0.02, params) == pytest.approx(0.15)  # = L_C at V_tr = K_Lp
    assert path_length(0.001, params) == pytest.approx(0.15)  # never beyond L_C
    assert path_length(0.0, params) == pytest.approx(0.15)


def test_pose_rates_wrap_angles():
    before = _pose([0.2, 0.0, 1.0], yaw=math.radians(179.0))
    after = _pose([0.25, -0.1, 1.0], yaw=math.radians(-179.0), roll=0.1)
    rates = pose_rates(before, after, 0.5)
    np.testing.assert_allclose(rates[:3], [0.1, -0.2, 0.0], atol=1e-12)
    np.testing.assert_allclose(rates[3:], [0.2, 0.0, math.radians(4.0)], atol=1e-9)  # +2° over the wrap, per 0.5 s
    with pytest.raises(ValueError, match="dt"):
        pose_rates(before, after, 0.0)


def test_pbvs_target_centres_the_marker_in_the_eye_in_hand_image():
    kinematics = ArmKinematics.from_urdf("mobile_manipulator.urdf", "arm_base", "part_a")
    T_E_C = np.linalg.inv(kinematics.transform(np.zeros(6))) @ kinematics.transform(np.zeros(6), "eye_in_hand")
    target = PbvsTarget(standoff=0.5)
    # the tag plate's centre (x -0.130..0.095 m) under the Bebop 2
    assert target.aim_Q == pytest.approx((-0.0175, 0.0, -0.034))
    T_M_Q = _pose([0.30, -0.10, 1.25], yaw=0.6)
    p_E_M, R_M_E = pbvs_target(T_M_Q, T_E_C, target)
    np.testing.assert_allclose(R_M_E, rot_z(0.6), atol=1e-12)  # Part A level, heading with the UAV
    with IKEngine(kinematics) as ik:
        solution = ik.solve(p_E_M[None], R_M_E, Q_READY)
    assert solution.valid[0]
    T_M_C = kinematics.transform(solution.q[0], "eye_in_hand")
    p_aim_M = T_M_Q[:3, :3] @ np.array(target.aim_Q) + T_M_Q[:3, 3]
    p_aim_C = T_M_C[:3, :3].T @ (p_aim_M - T_M_C[:3, 3])
    np.testing.assert_allclose(p_aim_C, [0.0, 0.0, 0.5], atol=1e-9)  # on the optical axis, 0.5 m away
    # Part A under Part B instead (the docking device's alignment for the contact phase)
    p_B_Q = (0.11, 0.0, -0.08)
    p_A_M, _ = pbvs_target(T_M_Q, np.eye(4), PbvsTarget(standoff=0.05, aim_Q=p_B_Q, frame="part_a"))
    np.testing.assert_allclose(p_A_M, T_M_Q[:3, :3] @ np.array(p_B_Q) + T_M_Q[:3, 3] - [0, 0, 0.05], atol=1e-12)
    with pytest.raises(ValueError, match="standoff"):
        PbvsTarget(standoff=-0.1)


def test_cord_progress_by_hand():
    items = np.array([[0.0, 0.0, 0.7], [0.03, 0.0, 0.7], [0.03, 0.04, 0.7]])  # 3 cm along x, then 4 cm along y
    points = np.array([[0.01, 0.015, 0.7], [0.05, 0.02, 0.75], [-0.02, 0.0, 0.7], [0.04, 0.10, 0.7]])
    np.testing.assert_allclose(cord_progress(points, items), [0.01, 0.05, 0.0, 0.07], atol=1e-12)
    np.testing.assert_allclose(cord_progress(points, items[:1]), 0.0)  # cordless: no direction


def _chain_graph():
    """A tree along x (1 cm steps from the root at x = 0) with a side branch at x = 0.02 going +y."""
    x = np.arange(0.0, 0.081, 0.01)
    main = np.column_stack((x, np.zeros(x.size), np.full(x.size, 0.7)))
    side = np.array([[0.021, 0.01, 0.7], [0.022, 0.02, 0.7], [0.023, 0.03, 0.7]])
    positions = np.vstack((main, side))
    parent = np.concatenate(([-1], np.arange(x.size - 1), [2, x.size, x.size + 1]))
    q = np.arange(positions.shape[0])[:, None] * np.ones((1, 6))
    n = positions.shape[0]
    return Graph(positions, q, parent, np.zeros(n, int), np.zeros(n, bool), np.eye(3), 0)


def test_select_takes_the_vertex_farthest_along_the_cord_within_L_p():
    graph = _chain_graph()
    cord = np.array([[0.01, 0.0, 0.7], [0.04, 0.0, 0.7], [0.07, 0.0, 0.7]])  # the motion goes +x
    p_vs = np.array([0.011, 0.002, 0.7])
    chosen = select(graph, p_vs, cord, L_p=0.045)
    assert chosen.v_vs == 1  # the vertex nearest to P_VS
    # within 4.5 cm along the tree from x = 0.01: x ≤ 0.055 on the main line, the side branch up to 0.02 + ~0.03
    assert chosen.v_R == 5 and chosen.path == [1, 2, 3, 4, 5]
    np.testing.assert_allclose(chosen.p_R_M, [0.05, 0.0, 0.7])
    np.testing.assert_allclose(chosen.q_R, 5.0)
    # the motion goes +y: the side branch leads
    sideways = select(graph, p_vs, np.array([[0.02, 0.0, 0.7], [0.02, 0.03, 0.7]]), L_p=0.045)
    assert graph.positions[sideways.v_R, 1] > 0.0 and sideways.path[:2] == [1, 2]
    # cordless: nothing to anticipate, P_R = V_vs; an empty graph selects nothing
    assert select(graph, p_vs, cord[:1], L_p=0.045).v_R == 1
    assert select(Graph.empty(np.eye(3)), p_vs, cord, 0.05) is None
