"""IK engine: inverse kinematics of many random end-effector poses with joint-range checks (Algorithm 3).

Narváez et al. (§IV-A-2) pre-load the arm model and its Jacobian in each of
M threads and solve the random poses of the vicinity in parallel, keeping
those whose joint angles are within range. Two solvers are offered on the
pinocchio model built from the robot's URDF:

- :class:`ClosedFormIK` — the carrier's arm is a vertical anthropomorphic
  arm with a spherical wrist (axes z, y, y, z, y, z, every joint origin on
  the first axis at q = 0), so the wrist centre fixes joints 1–3 (two
  shoulder × two elbow solutions) and the wrist rotation fixes joints 4–6
  (ZYZ Euler angles, two solutions). All eight candidates of a whole batch
  are computed at once in numpy, the in-range one closest to a reference
  configuration is kept.
- :class:`DlsIK` — damped-least-squares iterations on the pinocchio frame
  Jacobian, one pose after the other: the paper's per-thread solver, usable
  on any arm.

:class:`IKEngine` runs either in this process or split over a pool of M
worker processes (Algorithm 3's "for M threads do in parallel"). Measured on
the project's 2-core machine (shared with other jobs, load ≈ 2), poses
inside a 24 cm cube in front of the arm, warm-started from the docking pose:

==============  ==================  ====================
solver          1 process           pool of 2 workers
==============  ==================  ====================
closed form     120–150 k solves/s  65–110 k solves/s
DLS (per pose)  2.5–3.0 k solves/s  2.6–2.7 k solves/s
==============  ==================  ====================

The closed form solves 300 poses in ≈ 2.4 ms of one core, 50× the DLS
rate; shipping so cheap a batch to other processes (pickling, queues,
wake-ups) costs more than solving it, and on two busy cores the workers
cannot run in parallel anyway. The default is therefore the closed form in
one process; ``workers > 1`` stays available to measure the scaling.

Frames: targets are poses of the IK frame (default the kinematics' tip,
``part_a``) in the manipulator frame M; metres, radians.
"""

from __future__ import annotations

import math
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from multiprocessing import get_context
from typing import Literal

import numpy as np
import pinocchio as pin

from marsupial.api.errors import UnknownNameError
from marsupial.api.kinematics import ArmKinematics

TWO_PI = 2.0 * math.pi
_AXIS_Z = np.array([0.0, 0.0, 1.0])
_AXIS_Y = np.array([0.0, 1.0, 0.0])


def _root_to_base(kinematics: ArmKinematics) -> np.ndarray:
    """4×4 ``T_M_root``: the model's root (universe) frame in the base frame M (M is fixed to the root)."""
    model = kinematics.model
    frame = model.frames[model.getFrameId(kinematics.base_link, pin.FrameType.BODY)]
    if frame.parentJoint != 0:
        raise ValueError(f"base link '{kinematics.base_link}' must not move with the arm joints")
    return frame.placement.inverse().homogeneous


def _frame_index(kinematics: ArmKinematics, frame: str | None) -> int:
    """Pinocchio frame id of link ``frame`` (default: the tip); the error lists the model's links."""
    name = kinematics.tip_link if frame is None else frame
    if name not in kinematics.links:
        raise UnknownNameError("link of the arm model", name, kinematics.links)
    return kinematics.model.getFrameId(name, pin.FrameType.BODY)


def _batch(positions: np.ndarray, rotations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Targets as ``(n, 3)`` positions and ``(n, 3, 3)`` rotations (one rotation is broadcast)."""
    p = np.asarray(positions, dtype=float).reshape(-1, 3)
    R = np.asarray(rotations, dtype=float)
    if R.shape == (3, 3):
        R = np.broadcast_to(R, (p.shape[0], 3, 3))
    if R.shape != (p.shape[0], 3, 3):
        raise ValueError(f"expected rotations of shape (3, 3) or ({p.shape[0]}, 3, 3), got {R.shape}")
    return p, R


def _wrap_into(q: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Angles wrapped to (-π, π], then shifted by ±2π where that brings them into [lower, upper]."""
    q = math.pi - np.mod(math.pi - q, TWO_PI)
    q = q + TWO_PI * (q < lower)
    return q - TWO_PI * (q > upper)


@dataclass(frozen=True)
class IKSolution:
    """Joint angles for a batch of poses.

    Attributes:
        q: ``(n, dof)`` joint angles (rad); rows of invalid poses hold the reference configuration.
        valid: ``(n,)`` True where the pose is reachable with every joint within its range.
    """

    q: np.ndarray
    valid: np.ndarray


@dataclass(frozen=True)
class ArmGeometry:
    """Dimensions of a vertical anthropomorphic arm with a spherical wrist, read from its model (m).

    Attributes:
        shoulder: intersection of axes 1 and 2 in M.
        upper_arm: shoulder → elbow (axis 3) length L2.
        forearm: elbow → wrist centre (axis 5) length L3.
        flange: wrist centre → joint-6 frame distance along the last axis.
        T_6_ik: the IK frame in the joint-6 frame (4×4, constant).
    """

    shoulder: np.ndarray
    upper_arm: float
    forearm: float
    flange: float
    T_6_ik: np.ndarray

    @property
    def reach(self) -> float:
        """Largest distance (m) from the shoulder to the IK frame's origin."""
        return self.upper_arm + self.forearm + self.flange + float(np.linalg.norm(self.T_6_ik[:3, 3]))

    @classmethod
    def from_kinematics(cls, kinematics: ArmKinematics, frame: str | None = None) -> ArmGeometry:
        """Read the dimensions; raises ``ValueError`` naming the first property the arm lacks."""
        if kinematics.dof != 6:
            raise ValueError(f"closed-form IK needs a 6-DoF arm, got {kinematics.dof} joints")
        model, data = kinematics.model, kinematics.model.createData()
        q0 = np.zeros(6)
        pin.forwardKinematics(model, data, q0)
        T_M_root = _root_to_base(kinematics)
        T_M_joint = np.array([T_M_root @ data.oMi[j].homogeneous for j in range(1, 7)])
        axes = kinematics.jacobian(q0)[3:].T  # joint axes in M at q = 0
        expected = (_AXIS_Z, _AXIS_Y, _AXIS_Y, _AXIS_Z, _AXIS_Y, _AXIS_Z)
        if not all(np.allclose(a, e, atol=1e-9) for a, e in zip(axes, expected, strict=True)):
            raise ValueError(
                f"closed-form IK expects joint axes z, y, y, z, y, z in M at q = 0 (arm upright); got {axes.round(3)}"
            )
        origins = T_M_joint[:, :3, 3]
        if not np.allclose(origins[:, :2], origins[0, :2], atol=1e-9) or not np.allclose(
            T_M_joint[:, :3, :3], np.eye(3), atol=1e-9
        ):
            raise ValueError("closed-form IK expects every joint frame on the first axis and aligned with M at q = 0")
        fid = _frame_index(kinematics, frame)
        T_6_ik = np.linalg.inv(T_M_joint[5]) @ (T_M_root @ pin.updateFramePlacement(model, data, fid).homogeneous)
        z = origins[:, 2]
        return cls(origins[1].copy(), z[2] - z[1], z[4] - z[2], z[5] - z[4], T_6_ik)


class ClosedFormIK:
    """Vectorised closed-form IK of the carrier's arm (spherical wrist), all eight branches at once.

    Args:
        kinematics: pinocchio model of the arm (poses in M).
        frame: the frame whose pose is given (default: the kinematics' tip, ``part_a``).
        singular: |sin q5| (wrist) or wrist-to-axis-1 distance (m, shoulder) below which the
            free angle of the singular configuration is taken from the reference.
    """

    def __init__(self, kinematics: ArmKinematics, frame: str | None = None, singular: float = 1e-9):
        self.kinematics = kinematics
        self.geometry = ArmGeometry.from_kinematics(kinematics, frame)
        self.T_ik_6 = np.linalg.inv(self.geometry.T_6_ik)
        self.lower, self.upper = kinematics.lower, kinematics.upper
        self.singular = singular

    def candidates(
        self, positions: np.ndarray, rotations: np.ndarray, q_ref: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """All eight solutions: ``(n, 8, 6)`` angles (rad) and ``(n, 8)`` validity (reachable and in range)."""
        g = self.geometry
        p, R = _batch(positions, rotations)
        n = p.shape[0]
        q_ref = np.broadcast_to(np.asarray(q_ref, dtype=float), (n, 6))
        # joint-6 frame from the IK frame's target, then the wrist centre one flange length below it
        R6 = R @ self.T_ik_6[:3, :3]
        p6 = p + R @ self.T_ik_6[:3, 3]
        w = p6 - g.flange * R6[:, :, 2] - g.shoulder
        rho = np.hypot(w[:, 0], w[:, 1])
        phi = np.where(rho > self.singular, np.arctan2(w[:, 1], w[:, 0]), q_ref[:, 0])
        q1 = np.stack((phi, phi + math.pi), axis=1)  # (n, 2): front / back shoulder
        r = np.stack((rho, -rho), axis=1)
        h = w[:, 2:3]
        L2, L3 = g.upper_arm, g.forearm
        D = (r**2 + h**2 - L2**2 - L3**2) / (2.0 * L2 * L3)
        reachable = np.abs(D) <= 1.0
        q3 = np.arccos(np.clip(D, -1.0, 1.0))[..., None] * np.array([1.0, -1.0])  # (n, 2, 2): elbow
        q2 = np.arctan2(r, h)[..., None] - np.arctan2(L3 * np.sin(q3), L2 + L3 * np.cos(q3))
        q1 = np.broadcast_to(q1[..., None], q2.shape)
        # wrist: R_3^T R_6 = Rz(q4) Ry(q5) Rz(q6), with R_3 = Rz(q1) Ry(q2 + q3)
        c1, s1 = np.cos(q1), np.sin(q1)
        c23, s23 = np.cos(q2 + q3), np.sin(q2 + q3)
        R3 = np.empty(q2.shape + (3, 3))
        R3[..., 0, 0], R3[..., 0, 1], R3[..., 0, 2] = c1 * c23, -s1, c1 * s23
        R3[..., 1, 0], R3[..., 1, 1], R3[..., 1, 2] = s1 * c23, c1, s1 * s23
        R3[..., 2, 0], R3[..., 2, 1], R3[..., 2, 2] = -s23, 0.0, c23
        W = np.swapaxes(R3, -1, -2) @ R6[:, None, None]
        s5 = np.hypot(W[..., 0, 2], W[..., 1, 2])
        q5 = np.arctan2(s5, W[..., 2, 2])
        regular = s5 > self.singular
        ref4 = q_ref[:, None, None, 3]
        q4 = np.where(regular, np.arctan2(W[..., 1, 2], W[..., 0, 2]), ref4)
        q6 = np.where(regular, np.arctan2(W[..., 2, 1], -W[..., 2, 0]), np.arctan2(W[..., 1, 0], W[..., 0, 0]) - ref4)
        arm = np.stack((q1, q2, q3), axis=-1)  # (n, 2, 2, 3)
        wrist = np.stack(
            (np.stack((q4, q5, q6), axis=-1), np.stack((q4 + math.pi, -q5, q6 + math.pi), axis=-1)), axis=3
        )  # (n, 2, 2, 2, 3): the two wrist solutions
        q = np.concatenate((np.broadcast_to(arm[:, :, :, None, :], wrist.shape), wrist), axis=-1).reshape(n, 8, 6)
        q = _wrap_into(q, self.lower, self.upper)
        ok = np.broadcast_to(reachable[:, :, None, None], (n, 2, 2, 2)).reshape(n, 8)
        ok = ok & np.all((q >= self.lower) & (q <= self.upper), axis=2)
        return q, ok

    def solve(self, positions: np.ndarray, rotations: np.ndarray, q_ref: np.ndarray | None = None) -> IKSolution:
        """The valid solution closest to ``q_ref`` for each target pose.

        Args:
            positions: ``(n, 3)`` positions (m, M frame); rotations: ``(n, 3, 3)`` or one ``(3, 3)``.
            q_ref: reference configuration (rad), ``(6,)`` or one per pose ``(n, 6)``; default zeros.
        """
        q_ref = np.zeros(6) if q_ref is None else np.asarray(q_ref, dtype=float)
        q, ok = self.candidates(positions, rotations, q_ref)
        cost = np.where(ok, np.sum((q - np.asarray(q_ref)[..., None, :]) ** 2, axis=2), np.inf)
        best = np.argmin(cost, axis=1)
        rows = np.arange(q.shape[0])
        valid = ok[rows, best]
        chosen = np.where(valid[:, None], q[rows, best], np.broadcast_to(q_ref, (q.shape[0], 6)))
        return IKSolution(chosen, valid)


class DlsIK:
    """Damped-least-squares IK on the pinocchio frame Jacobian, one pose at a time (any arm).

    Args:
        kinematics: pinocchio model of the arm.
        frame: the frame whose pose is given (default: the tip).
        damping: λ of ``dq = Jᵀ (J Jᵀ + λ² I)⁻¹ e``.
        tolerance: convergence threshold on the 6-D error (m, rad).
        max_iterations: iterations before a pose is declared unreachable.
    """

    def __init__(
        self,
        kinematics: ArmKinematics,
        frame: str | None = None,
        damping: float = 1e-3,
        tolerance: float = 1e-6,
        max_iterations: int = 100,
    ):
        self.kinematics = kinematics
        self.model, self.data = kinematics.model, kinematics.model.createData()
        self.frame_id = _frame_index(kinematics, frame)
        self.T_root_M = np.linalg.inv(_root_to_base(kinematics))
        self.lower, self.upper = kinematics.lower, kinematics.upper
        self.damping, self.tolerance, self.max_iterations = damping, tolerance, max_iterations

    def solve_one(self, position: np.ndarray, rotation: np.ndarray, q_ref: np.ndarray) -> tuple[np.ndarray, bool]:
        """Joint angles reaching one pose from ``q_ref``, and whether they converged within the ranges."""
        model, data, fid = self.model, self.data, self.frame_id
        target = pin.SE3(self.T_root_M[:3, :3] @ rotation, self.T_root_M[:3, :3] @ position + self.T_root_M[:3, 3])
        q = np.array(q_ref, dtype=float)
        damping = self.damping**2 * np.eye(6)
        for _ in range(self.max_iterations):
            pin.computeJointJacobians(model, data, q)  # forward kinematics and every joint's Jacobian
            current = pin.updateFramePlacement(model, data, fid)
            error = pin.log6(current.actInv(target)).vector  # in the frame's local axes
            if np.linalg.norm(error) < self.tolerance:
                q = _wrap_into(q, self.lower, self.upper)
                return q, bool(np.all((q >= self.lower) & (q <= self.upper)))
            J = pin.getFrameJacobian(model, data, fid, pin.LOCAL)
            q = q + J.T @ np.linalg.solve(J @ J.T + damping, error)
        return q, False

    def solve(self, positions: np.ndarray, rotations: np.ndarray, q_ref: np.ndarray | None = None) -> IKSolution:
        """Every pose of the batch, one after the other, each from its ``q_ref`` (see :meth:`ClosedFormIK.solve`)."""
        p, R = _batch(positions, rotations)
        q_ref = np.zeros(self.model.nq) if q_ref is None else np.asarray(q_ref, dtype=float)
        starts = np.broadcast_to(q_ref, (p.shape[0], self.model.nq))
        q = np.empty((p.shape[0], self.model.nq))
        valid = np.zeros(p.shape[0], dtype=bool)
        for i in range(p.shape[0]):
            q[i], valid[i] = self.solve_one(p[i], R[i], starts[i])
        q[~valid] = starts[~valid]
        return IKSolution(q, valid)


SOLVERS = {"closed_form": ClosedFormIK, "dls": DlsIK}

_worker_solver: ClosedFormIK | DlsIK | None = None


def _init_worker(model: pin.Model, base_link: str, tip_link: str, solver: str, frame: str | None) -> None:
    """Pool initializer: pre-load the arm model and the solver once per worker process (§IV-A-2)."""
    global _worker_solver
    _worker_solver = SOLVERS[solver](ArmKinematics(model, base_link, tip_link), frame)


def _solve_chunk(positions: np.ndarray, rotations: np.ndarray, q_ref: np.ndarray) -> IKSolution:
    assert _worker_solver is not None
    return _worker_solver.solve(positions, rotations, q_ref)


class IKEngine:
    """Algorithm 3: IK of a list of random poses, keeping those reachable within the joint ranges.

    Args:
        kinematics: pinocchio model of the arm (poses in M).
        solver: ``"closed_form"`` (default, vectorised) or ``"dls"`` (per-pose Jacobian iterations).
        workers: M; above 1 the batch is split over M worker processes, each with
            its own pre-loaded model (close the engine, or use it as a context manager).
        frame: the frame whose poses are solved (default: the kinematics' tip).
    """

    def __init__(
        self,
        kinematics: ArmKinematics,
        solver: Literal["closed_form", "dls"] = "closed_form",
        workers: int = 1,
        frame: str | None = None,
    ):
        if solver not in SOLVERS:
            raise ValueError(f"unknown IK solver '{solver}'; expected one of {sorted(SOLVERS)}")
        if workers < 1:
            raise ValueError(f"the IK engine needs at least one worker, got {workers}")
        self.kinematics = kinematics
        self.workers = workers
        self.solver = SOLVERS[solver](kinematics, frame)
        self._pool: ProcessPoolExecutor | None = None
        if workers > 1:
            self._pool = ProcessPoolExecutor(
                workers,
                mp_context=get_context("spawn"),
                initializer=_init_worker,
                initargs=(kinematics.model, kinematics.base_link, kinematics.tip_link, solver, frame),
            )

    def solve(self, positions: np.ndarray, rotations: np.ndarray, q_ref: np.ndarray | None = None) -> IKSolution:
        """Joint angles and validity (reachable, every joint in range) of each pose.

        Args:
            positions: ``(n, 3)`` positions (m, M frame); rotations: ``(n, 3, 3)`` or one ``(3, 3)``.
            q_ref: reference configuration (rad), ``(dof,)`` or ``(n, dof)``: the closed form keeps the
                solution closest to it, DLS starts from it; default zeros.
        """
        p, R = _batch(positions, rotations)
        q_ref = np.zeros(self.kinematics.dof) if q_ref is None else np.asarray(q_ref, dtype=float)
        if self._pool is None or p.shape[0] < self.workers:
            return self.solver.solve(p, R, q_ref)
        starts = np.broadcast_to(q_ref, (p.shape[0], self.kinematics.dof))
        chunks = np.array_split(np.arange(p.shape[0]), self.workers)
        parts = list(
            self._pool.map(
                _solve_chunk,
                [p[c] for c in chunks],
                [np.ascontiguousarray(R[c]) for c in chunks],
                [np.ascontiguousarray(starts[c]) for c in chunks],
            )
        )
        return IKSolution(np.concatenate([s.q for s in parts]), np.concatenate([s.valid for s in parts]))

    def valid_poses(
        self, positions: np.ndarray, rotations: np.ndarray, q_ref: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Algorithm 3's ValidPoses: indices of the reachable poses and their joint angles ``(k, dof)``."""
        solution = self.solve(positions, rotations, q_ref)
        index = np.flatnonzero(solution.valid)
        return index, solution.q[index]

    def close(self) -> None:
        """Stop the worker processes (no-op with one worker)."""
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None

    def __enter__(self) -> IKEngine:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
