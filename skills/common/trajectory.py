"""Joint trajectories toward the selected pose, time-parameterised by toppra (Narváez et al., §IV-A-3, §V-B).

P_R becomes joint goal angles by IK; the arm then moves along the straight
line from the present joint set-point to them in joint space, timed by
TOPP-RA (``toppra``) under the 15 rpm joint speed limit of the Dynamixel
arm (§V-B) and a joint acceleration limit, and starting with the present
set-point speed so that successive trajectories (one per selection, at
f_O) join without a stop. The joint PIDs track the sampled set-point.

Limits: the speed limit is the arm's (:data:`JOINT_SPEED_LIMIT`, 15 rpm =
1.571 rad/s, the same figure as the arm's model, ``ArmKinematics.velocity_limit``).
The paper gives no acceleration limit: 10 rad/s² reaches
15 rpm in 0.16 s, within the joints' stall torques even for the arm
stretched horizontally with a 0.5 kg UAV at the tip (joint 2: 1.35 kg·m²
and 18.5 N·m of gravity from the pinocchio model, so 32 of its 44.7 N·m).
toppra runs on 101 gridpoints with the constant-acceleration
parametrizer, which honours both limits between gridpoints, each slightly
reduced (``margin``) against rounding.

Units: rad, rad/s, rad/s², seconds.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import toppra
import toppra.algorithm
import toppra.constraint

JOINT_SPEED_LIMIT = 15.0 * 2.0 * np.pi / 60.0  # rad/s: 15 rpm per joint, the Dynamixel arm of §V-B
TINY_MOTION = 1e-3  # rad: a joint motion this small is a set-point step, not a trajectory

logging.getLogger("toppra").setLevel(logging.WARNING)  # toppra logs every parametrisation at INFO


@dataclass(frozen=True)
class TrajectoryParams:
    """Joint limits of the time parameterisation.

    Attributes:
        v_max: joint speed limit (rad/s): 15 rpm, §V-B.
        a_max: joint acceleration limit (rad/s², chosen: 15 rpm in 0.16 s).
        margin: fraction of both limits handed to toppra.
        gridpoints: toppra gridpoints over the path parameter s ∈ [0, 1].
    """

    v_max: float = JOINT_SPEED_LIMIT
    a_max: float = 10.0
    margin: float = 0.98
    gridpoints: int = 101

    def __post_init__(self) -> None:
        if self.v_max <= 0 or self.a_max <= 0 or not 0 < self.margin <= 1 or self.gridpoints < 2:
            raise ValueError(f"TrajectoryParams needs v_max, a_max > 0, 0 < margin <= 1, gridpoints >= 2; got {self}")


class JointTrajectory:
    """A time-parameterised joint motion q(t), t ≥ 0 from its start; held at the goal after ``duration``.

    Attributes:
        q_start, q_goal: end points (rad); duration: time to reach the goal (s).
    """

    def __init__(
        self, q_start: np.ndarray, q_goal: np.ndarray, timed: toppra.interpolator.AbstractGeometricPath | None
    ):
        self.q_start = np.asarray(q_start, dtype=float).copy()
        self.q_goal = np.asarray(q_goal, dtype=float).copy()
        self._timed = timed
        self.duration = 0.0 if timed is None else float(timed.duration)

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Joint angles (rad) and speeds (rad/s) ``t`` seconds after the start."""
        if self._timed is None or t >= self.duration:
            return self.q_goal.copy(), np.zeros_like(self.q_goal)
        t = max(0.0, t)
        return np.asarray(self._timed(t), dtype=float), np.asarray(self._timed(t, 1), dtype=float)


def plan_joint_trajectory(
    q_start: np.ndarray,
    q_goal: np.ndarray,
    qd_start: np.ndarray | None = None,
    params: TrajectoryParams = TrajectoryParams(),
) -> JointTrajectory:
    """The time-optimal motion along the joint-space line from ``q_start`` to ``q_goal`` (rad), at rest at the goal.

    ``qd_start`` (rad/s) is the present set-point speed: its component along
    the line is kept as the start speed where the limits allow it (else the
    motion starts from rest).
    """
    q_start, q_goal = np.asarray(q_start, dtype=float), np.asarray(q_goal, dtype=float)
    if q_start.shape != q_goal.shape or q_start.ndim != 1:
        raise ValueError(f"expected two joint vectors of one shape, got {q_start.shape} and {q_goal.shape}")
    delta = q_goal - q_start
    if np.max(np.abs(delta)) < 1e-9:
        return JointTrajectory(q_start, q_goal, None)
    v = params.margin * params.v_max
    instance = _toppra(toppra.SplineInterpolator([0.0, 1.0], np.vstack((q_start, q_goal))), q_start.size, params)
    sd_start = 0.0
    if qd_start is not None:  # ṡ of the present speed along Δq, within the speed limit
        sd_start = float(np.clip(np.dot(qd_start, delta) / np.dot(delta, delta), 0.0, v / np.max(np.abs(delta))))
    timed = instance.compute_trajectory(sd_start, 0.0)
    if timed is None and sd_start > 0.0:  # too fast to stop in time on this line: start from rest
        timed = instance.compute_trajectory(0.0, 0.0)
    if timed is None and np.max(np.abs(delta)) < TINY_MOTION:  # toppra's solver fails on a few µrad: step there
        return JointTrajectory(q_start, q_goal, None)
    if timed is None:
        raise RuntimeError(f"toppra found no parameterisation from {q_start} to {q_goal}")
    return JointTrajectory(q_start, q_goal, timed)


def _toppra(path: toppra.interpolator.AbstractGeometricPath, dof: int, params: TrajectoryParams
            ) -> toppra.algorithm.TOPPRA:
    """TOPP-RA over ``path`` (s ∈ [0, 1]) under the joint speed and acceleration limits of ``params``."""
    v, a = params.margin * params.v_max, params.margin * params.a_max
    constraints = [
        toppra.constraint.JointVelocityConstraint(np.column_stack((np.full(dof, -v), np.full(dof, v)))),
        toppra.constraint.JointAccelerationConstraint(np.column_stack((np.full(dof, -a), np.full(dof, a)))),
    ]
    return toppra.algorithm.TOPPRA(
        constraints, path, gridpoints=np.linspace(0.0, 1.0, params.gridpoints), parametrizer="ParametrizeConstAccel"
    )


def time_joint_path(waypoints: np.ndarray, params: TrajectoryParams = TrajectoryParams()) -> JointTrajectory:
    """The time-optimal motion from rest to rest through ``waypoints`` ``(n, dof)`` (rad), under ``params``' limits.

    The path is the cubic spline through the waypoints over their cumulated joint-space length (s ∈ [0, 1]);
    densely spaced waypoints (a planner's path interpolated at its collision-check resolution) keep the
    spline within a small fraction of a spacing of the checked polyline.
    """
    waypoints = np.asarray(waypoints, dtype=float)
    if waypoints.ndim != 2 or waypoints.shape[0] < 2:
        raise ValueError(f"expected (n >= 2, dof) waypoints, got shape {waypoints.shape}")
    steps = np.linalg.norm(np.diff(waypoints, axis=0), axis=1)
    keep = np.concatenate(([True], steps > 1e-9))
    waypoints, s = waypoints[keep], np.concatenate(([0.0], np.cumsum(steps[steps > 1e-9])))
    if waypoints.shape[0] < 2:
        return JointTrajectory(waypoints[0], waypoints[0], None)
    timed = _toppra(toppra.SplineInterpolator(s / s[-1], waypoints), waypoints.shape[1], params).compute_trajectory(
        0.0, 0.0)
    if timed is None:
        raise RuntimeError(f"toppra found no parameterisation through {waypoints.shape[0]} waypoints")
    return JointTrajectory(waypoints[0], waypoints[-1], timed)
