"""Switching-regression cord (Narváez et al., §IV-A-1, Algorithm 1, eqs. 2–6).

The cord predicts where the end effector will have to go over the next
L_C ≈ 0.15 m: a succession of N items I_i = [x_i y_i z_i] (eq. 2) spaced
L_S = L_C / N apart, starting at the visual-servoing target I_1 = P_VS and
following a polynomial y = f(x) (eq. 3) fitted by least squares to the
stored P_VS history OP (eqs. 4–6). The order switches: linear (n = 1) when
the UGV moves faster than the UAV, quadratic (n = 2) when the UAV has more
activity. Too little motion in OP gives a cordless plan (N = 1); an abrupt
change of the motion direction cancels the cord (N = 1) and restarts the
history so that the next cord follows the new direction.

Everything is in the manipulator frame M (m); the cord keeps z = z_VS.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CordParams:
    """Parameters of the switching regression (paper values where the paper gives them).

    Attributes:
        L_C: cord length L_C (m), "around 15 cm", §IV-A-1.
        N: number of items N of a full cord (L_C = N·L_S, §IV-A-1).
        N_OP: number N_OP of stored P_VS values in OP used for the fit (eqs. 4–6);
            at the merge-and-selection rate f_O = 8 Hz, 16 values are 2 s.
        min_motion: extent (m) of OP along its main horizontal axis below which
            the relative pose is "more or less static" and the cord is cordless.
        turn_window: number of latest OP values that give the new motion direction.
        max_turn: angle (rad) between the older and the newest motion direction
            above which the motion changed abruptly and the cord is cancelled.
        step: the "small increment" δ (m) of Algorithm 1, lines 6 and 13.
    """

    L_C: float = 0.15
    N: int = 5
    N_OP: int = 16
    min_motion: float = 0.02
    turn_window: int = 4
    max_turn: float = math.radians(60.0)
    step: float = 0.0005

    def __post_init__(self) -> None:
        if self.L_C <= 0 or self.N < 1 or self.step <= 0:
            raise ValueError(f"CordParams needs L_C > 0, N >= 1 and step > 0; got {self}")
        if not 2 <= self.turn_window < self.N_OP:
            raise ValueError(f"CordParams needs 2 <= turn_window < N_OP; got {self.turn_window}, {self.N_OP}")

    @property
    def L_S(self) -> float:
        """Item spacing L_S = L_C / N (m)."""
        return self.L_C / self.N


@dataclass(frozen=True)
class Cord:
    """A cord of items in M.

    Attributes:
        items: ``(N, 3)`` items I_i (m); ``items[0]`` is P_VS.
        order: regression order n (1 linear, 2 quadratic; 0 when cordless).
        axis: independent variable of eq. (3): 0 for y = f(x), 1 for x = f(y).
        coefficients: a_0 … a_n of eq. (3), in the independent variable (empty when cordless).
        cancelled: True when an abrupt direction change cancelled the regression.
        direction: unit horizontal vector of the motion at I_1 (the cord's main
            direction; the latest motion, or M's x axis without any, when cordless).
    """

    items: np.ndarray
    order: int
    axis: int
    coefficients: np.ndarray
    cancelled: bool
    direction: np.ndarray

    @property
    def N(self) -> int:
        """Number of items."""
        return int(self.items.shape[0])

    @property
    def cordless(self) -> bool:
        """True for a single-item cord (N = 1)."""
        return self.N == 1


def fit_polynomial(u: np.ndarray, v: np.ndarray, order: int) -> np.ndarray:
    """Coefficients a_0 … a_n of v = Σ a_k u^k (eq. 3) by least squares (eqs. 4–6).

    Solving X A = B (eq. 5) by A = X^{-1} B (eq. 6) with the normal-equation
    sums of eq. (4) is the least-squares solution of the Vandermonde system
    V A = v; ``numpy.linalg.lstsq`` solves that system directly (same A,
    better conditioned than forming X).
    """
    V = np.vander(np.asarray(u, dtype=float), order + 1, increasing=True)
    coefficients, *_ = np.linalg.lstsq(V, np.asarray(v, dtype=float), rcond=None)
    return coefficients


def regression_order(ugv_speed: float, uav_speed: float) -> int:
    """Switching rule of §IV-A-1: linear (1) when the UGV moves faster than the UAV, else quadratic (2)."""
    return 1 if ugv_speed > uav_speed else 2


def _unit(v: np.ndarray) -> np.ndarray | None:
    norm = float(np.linalg.norm(v))
    return v / norm if norm > 1e-12 else None


def motion_turn(history: np.ndarray, turn_window: int) -> float:
    """Angle (rad) between the older and the newest horizontal motion direction of ``history``.

    The newest direction is the displacement over the last ``turn_window``
    values, the older one the displacement over the values before them. 0
    when either displacement is zero.
    """
    xy = np.asarray(history, dtype=float)[:, :2]
    if xy.shape[0] < 2 * turn_window:
        return 0.0
    split = xy.shape[0] - turn_window
    new = _unit(xy[-1] - xy[split - 1])
    old = _unit(xy[split - 1] - xy[0])
    if new is None or old is None:
        return 0.0
    return float(np.arccos(np.clip(new @ old, -1.0, 1.0)))


def build_cord(
    p_vs: np.ndarray,
    history: np.ndarray,
    ugv_speed: float,
    uav_speed: float,
    params: CordParams = CordParams(),
) -> Cord:
    """Algorithm 1: the cord from P_VS and the stored history OP (both in M, m).

    Args:
        p_vs: P_VS = [x_VS y_VS z_VS], the visual-servoing target of the end effector.
        history: ``(N_OP, 3)`` stored P_VS values, oldest first (the latest may be P_VS itself).
        ugv_speed, uav_speed: speeds of the carrier and of the UAV (m/s, world frame) for the switching.
        params: :class:`CordParams`.

    Stateless: the abrupt-change cancellation is reported with ``cancelled``
    (see :class:`CordPlanner` for the history handling around it).
    """
    p_vs = np.asarray(p_vs, dtype=float)
    history = np.asarray(history, dtype=float).reshape(-1, 3)[-params.N_OP :]
    xy = history[:, :2]
    extent = np.ptp(xy, axis=0) if len(xy) else np.zeros(2)  # CalculateAxesVariation: Δx, Δy
    order = regression_order(ugv_speed, uav_speed)
    latest = _unit(xy[-1] - xy[0]) if len(xy) >= 2 else None
    direction = latest if latest is not None else np.array([1.0, 0.0])

    def single(cancelled: bool) -> Cord:
        return Cord(p_vs[None, :].copy(), 0, 0, np.zeros(0), cancelled, direction)

    if params.N == 1 or len(xy) < order + 2 or extent.max() < params.min_motion:
        return single(False)  # cordless: not enough motion to predict
    if motion_turn(history, params.turn_window) > params.max_turn:
        return single(True)
    axis = 0 if extent[0] > extent[1] else 1  # Algorithm 1, line 5: y = f(x) when Δx > Δy
    u, v = xy[:, axis], xy[:, 1 - axis]
    u0 = float(u.mean())  # centring keeps the fit well conditioned; f is still a polynomial in u
    coefficients = fit_polynomial(u - u0, v, order)
    forward = 1.0 if u[-1] >= u[-min(len(u), params.turn_window)] else -1.0
    # Algorithm 1, lines 6-18: from the previous item, advance u by small increments δ (0 … L_S) and take
    # the first point of the curve at least L_S away from it (the paper's √(x² + y²) ≥ L_S, measured from
    # the previous item). All increments of one item are evaluated at once.
    deltas = np.arange(0.0, params.L_S + params.step, params.step)
    items = np.empty((params.N, 3))
    items[0] = p_vs
    items[1:, 2] = p_vs[2]
    previous = p_vs[:2].copy()
    for i in range(1, params.N):
        u_candidates = previous[axis] + forward * deltas
        v_candidates = np.polynomial.polynomial.polyval(u_candidates - u0, coefficients)
        du = u_candidates - previous[axis]
        dv = v_candidates - previous[1 - axis]
        far = np.flatnonzero(np.hypot(du, dv) >= params.L_S - 1e-12)
        k = int(far[0]) if far.size else deltas.size - 1
        items[i, axis], items[i, 1 - axis] = u_candidates[k], v_candidates[k]
        previous = items[i, :2]
    cord_direction = _unit(items[1, :2] - items[0, :2])
    return Cord(items, order, axis, coefficients, False, cord_direction if cord_direction is not None else direction)


class CordPlanner:
    """Keeps the P_VS history OP and builds a cord each planning cycle (Algorithm 1 with cancellation).

    Call :meth:`record` with every new P_VS (merge-and-selection rate f_O) and
    :meth:`plan` at the planning rate f_B. After a cancellation the history
    keeps only the values after the turn, so the next cord, drawn at the
    next cycle, follows the new direction (§IV-A-1).
    """

    def __init__(self, params: CordParams = CordParams()):
        self.params = params
        self.history: deque[np.ndarray] = deque(maxlen=params.N_OP)

    def record(self, p_vs: np.ndarray) -> None:
        """Store one P_VS (m, M frame) in OP."""
        self.history.append(np.asarray(p_vs, dtype=float).reshape(3).copy())

    def reset(self) -> None:
        """Forget the history (e.g. when tracking is lost)."""
        self.history.clear()

    def plan(self, p_vs: np.ndarray, ugv_speed: float, uav_speed: float) -> Cord:
        """The cord from P_VS and the stored history; trims the history after a cancellation."""
        cord = build_cord(p_vs, np.array(self.history).reshape(-1, 3), ugv_speed, uav_speed, self.params)
        if cord.cancelled:
            recent = list(self.history)[-self.params.turn_window :]
            self.history.clear()
            self.history.extend(recent)
        return cord
