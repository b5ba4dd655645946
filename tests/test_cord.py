"""Switching-regression cord of Narváez et al. (Algorithm 1, eqs. 2–6).

The cord fits the stored P_VS history OP by least squares — a line when the
UGV moves faster than the UAV, a parabola otherwise — and lays N items L_S
apart from P_VS along it; it goes cordless (N = 1) with too little motion and
is cancelled (N = 1) on an abrupt direction change.
"""

import math

import numpy as np
import pytest

from marsupial.skills.uav_docking.cord import (
    CordParams,
    CordPlanner,
    build_cord,
    fit_polynomial,
    regression_order,
)

PARAMS = CordParams()
Z = 0.7  # m, height of the history in M


def _history(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    return np.column_stack((x, y, np.full(x.size, Z)))


def _spacing(items: np.ndarray) -> np.ndarray:
    return np.linalg.norm(np.diff(items, axis=0), axis=1)


def test_paper_values_and_switching_rule():
    assert pytest.approx(0.15) == PARAMS.L_C  # L_C ≈ 15 cm, §IV-A-1
    assert pytest.approx(PARAMS.L_C) == PARAMS.L_S * PARAMS.N  # L_C = N·L_S
    assert regression_order(ugv_speed=0.5, uav_speed=0.2) == 1  # UGV faster: linear
    assert regression_order(ugv_speed=0.2, uav_speed=0.5) == 2  # UAV more active: quadratic


def test_least_squares_is_the_normal_equation_solution_of_eqs_4_to_6():
    rng = np.random.default_rng(3)
    u, v = rng.uniform(-0.1, 0.1, 20), rng.uniform(-0.1, 0.1, 20)
    n = 2
    X = np.array([[np.sum(u ** (r + c)) for c in range(n + 1)] for r in range(n + 1)])  # eq. (4)
    B = np.array([np.sum(u**r * v) for r in range(n + 1)])
    np.testing.assert_allclose(fit_polynomial(u, v, n), np.linalg.solve(X, B), atol=1e-9)  # A = X⁻¹B, eq. (6)


def test_linear_cord_recovers_a_known_line_when_the_ugv_is_faster():
    x = np.linspace(0.20, 0.35, PARAMS.N_OP)
    line = lambda x: 0.10 + 0.5 * x  # noqa: E731
    history = _history(x, line(x))
    cord = build_cord(history[-1], history, ugv_speed=0.5, uav_speed=0.1)
    assert (cord.order, cord.axis, cord.N, cord.cancelled) == (1, 0, PARAMS.N, False)
    np.testing.assert_allclose(cord.items[0], history[-1])  # I_1 = P_VS
    np.testing.assert_allclose(cord.items[:, 1], line(cord.items[:, 0]), atol=1e-9)  # on the line, eq. (3)
    np.testing.assert_allclose(cord.items[:, 2], Z)  # constant height
    assert np.all(np.diff(cord.items[:, 0]) > 0)  # ahead, in the direction of motion
    assert np.all(_spacing(cord.items) >= PARAMS.L_S - 1e-12)
    assert np.all(_spacing(cord.items) <= PARAMS.L_S + PARAMS.step)


def test_quadratic_cord_recovers_a_known_parabola_when_the_uav_is_faster():
    x = np.linspace(0.20, 0.35, PARAMS.N_OP)
    parabola = lambda x: 0.30 - 2.0 * (x - 0.30) ** 2  # noqa: E731
    history = _history(x, parabola(x))
    cord = build_cord(history[-1], history, ugv_speed=0.1, uav_speed=0.6)
    assert (cord.order, cord.N) == (2, PARAMS.N)
    np.testing.assert_allclose(cord.items[:, 1], parabola(cord.items[:, 0]), atol=1e-9)
    # the curvature is followed: the cord bends away from the tangent at P_VS
    assert np.all(np.diff(cord.items[:, 1]) < 0)


def test_motion_along_y_fits_x_of_y_and_follows_a_negative_direction():
    y = np.linspace(0.1, -0.1, PARAMS.N_OP)  # moving toward -y
    history = _history(0.4 + 0.2 * y, y)
    cord = build_cord(history[-1], history, ugv_speed=0.5, uav_speed=0.1)
    assert cord.axis == 1  # Δy > Δx: x = f(y), Algorithm 1 line 12
    np.testing.assert_allclose(cord.items[:, 0], 0.4 + 0.2 * cord.items[:, 1], atol=1e-9)
    assert np.all(np.diff(cord.items[:, 1]) < 0)
    assert cord.direction[1] < -0.9


def test_noisy_history_still_gives_the_line():
    rng = np.random.default_rng(7)
    x = np.linspace(0.0, 0.2, PARAMS.N_OP)
    history = _history(x, -0.05 + 0.3 * x + rng.normal(0.0, 0.002, x.size))
    cord = build_cord(history[-1], history, ugv_speed=0.5, uav_speed=0.1)
    np.testing.assert_allclose(cord.items[1:, 1], -0.05 + 0.3 * cord.items[1:, 0], atol=0.004)


def test_static_relative_pose_is_cordless():
    rng = np.random.default_rng(1)
    p = np.array([0.3, 0.0, Z])
    history = p + rng.normal(0.0, 0.002, (PARAMS.N_OP, 3))  # hovering: a few mm of jitter
    cord = build_cord(p, history, ugv_speed=0.0, uav_speed=0.05)
    assert cord.cordless and not cord.cancelled and cord.order == 0
    np.testing.assert_allclose(cord.items, p[None])
    assert build_cord(p, history[:2], 0.5, 0.1).cordless  # too short a history to fit


def test_abrupt_direction_change_cancels_and_the_next_cord_follows_the_new_direction():
    planner = CordPlanner(PARAMS)
    for x in np.linspace(0.2, 0.35, 12):  # moving along +x ...
        planner.record([x, 0.0, Z])
    turn = [[0.35, -0.03 * k, Z] for k in range(1, 5)]  # ... then sharply toward -y
    for p in turn:
        planner.record(p)
    cancelled = planner.plan(turn[-1], ugv_speed=0.1, uav_speed=0.5)
    assert cancelled.cancelled and cancelled.cordless
    np.testing.assert_allclose(cancelled.items[0], turn[-1])
    assert len(planner.history) == PARAMS.turn_window  # only the poses after the turn are kept
    planner.record([0.35, -0.15, Z])
    resumed = planner.plan([0.35, -0.15, Z], ugv_speed=0.1, uav_speed=0.5)
    assert not resumed.cancelled and resumed.N == PARAMS.N
    assert resumed.direction[1] < -math.cos(math.radians(20))  # along the new direction (-y)


def test_gentle_curve_is_not_cancelled():
    angle = np.linspace(0.0, math.radians(40), PARAMS.N_OP)  # 40° turn over the history
    history = _history(0.3 * np.sin(angle), 0.3 * (1 - np.cos(angle)))
    assert not build_cord(history[-1], history, 0.1, 0.5).cancelled


def test_bad_parameters_are_rejected():
    with pytest.raises(ValueError, match="L_C > 0"):
        CordParams(L_C=0.0)
    with pytest.raises(ValueError, match="turn_window"):
        CordParams(turn_window=20, N_OP=16)
