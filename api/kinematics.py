"""Kinematic model of a serial arm, built with pinocchio from a robot's URDF.

The URDF that pybullet loads is the single source of truth: :class:`ArmKinematics`
parses the same file, keeps the joints on the chain from ``base_link`` to
``tip_link`` and locks every other movable joint (wheels, other arms) at a
reference value. Poses and Jacobians are expressed in the frame of
``base_link`` (the manipulator frame M of Narváez et al., eq. 1), so they do
not depend on where the mobile base is. Units: metres, radians.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pinocchio as pin

from marsupial.geometry import Vector

from .assets import asset_path
from .errors import UnknownNameError


def _urdf_file(urdf: str | Path) -> Path:
    """``urdf`` itself if it is a file, else the shipped asset of that name."""
    path = Path(urdf)
    return path if path.is_file() else asset_path(str(urdf))


class ArmKinematics:
    """Forward kinematics, frame Jacobians and joint limits of one arm chain.

    Build it with :meth:`from_urdf`. Joint vectors ``q`` are ordered as
    :attr:`joint_names` (base to tip), in radians (metres for prismatic joints).

    Attributes:
        base_link: link whose frame poses are expressed in (frame M).
        tip_link: default frame of :meth:`forward` and :meth:`jacobian`.
        joint_names: the arm joints, base to tip.
        lower, upper: position limits (rad).
        velocity_limit: joint speed limits (rad/s) from the URDF.
        effort_limit: joint torque limits (N·m) from the URDF.
        model: the reduced pinocchio model (only the arm joints move).
    """

    def __init__(self, model: pin.Model, base_link: str, tip_link: str):
        self.model = model
        self.data = model.createData()
        self.base_link = base_link
        self.tip_link = tip_link
        self.joint_names: tuple[str, ...] = tuple(model.names[1:])
        self.lower = np.array(model.lowerPositionLimit, dtype=float)
        self.upper = np.array(model.upperPositionLimit, dtype=float)
        self.velocity_limit = np.array(model.velocityLimit, dtype=float)
        self.effort_limit = np.array(model.effortLimit, dtype=float)
        self._links = {
            f.name: i for i, f in enumerate(model.frames) if f.type == pin.FrameType.BODY
        }
        self._base_id = self._frame_id(base_link)
        self._tip_id = self._frame_id(tip_link)
        # the base is fixed in the reduced model: its placement does not depend on q
        data = model.createData()
        pin.framesForwardKinematics(model, data, pin.neutral(model))
        self._M_base_root = data.oMf[self._base_id].inverse()
        self._R_base_root = self._M_base_root.rotation.copy()

    @classmethod
    def from_urdf(
        cls,
        urdf: str | Path,
        base_link: str,
        tip_link: str,
        locked: Mapping[str, float] | None = None,
    ) -> ArmKinematics:
        """Model of the chain ``base_link`` → ``tip_link`` of ``urdf``.

        Args:
            urdf: path of a URDF file, or the name of an asset under ``world/assets/``.
            base_link: link the poses are expressed in; it must not move with the arm joints
                (a link on, or fixed to, the chain from the root to ``tip_link``).
            tip_link: link at the end of the chain (e.g. ``"part_a"``).
            locked: values (rad or m) of movable joints off the chain; others lock at 0.
        """
        path = _urdf_file(urdf)
        full = pin.buildModelFromUrdf(str(path))
        links = [f.name for f in full.frames if f.type == pin.FrameType.BODY]
        for link in (base_link, tip_link):
            if link not in links:
                raise UnknownNameError(f"link of {path.name}", link, links)
        base_joint = full.frames[full.getFrameId(base_link, pin.FrameType.BODY)].parentJoint
        tip_joint = full.frames[full.getFrameId(tip_link, pin.FrameType.BODY)].parentJoint
        tip_support = list(full.supports[tip_joint])
        if base_joint not in tip_support:
            raise ValueError(f"{path.name}: '{base_link}' is not fixed to the chain from the root to '{tip_link}'")
        chain = tip_support[tip_support.index(base_joint) + 1 :]
        if not chain:
            raise ValueError(f"{path.name}: no movable joint between '{base_link}' and '{tip_link}'")
        for j in chain:
            if full.joints[j].nq != 1:
                raise ValueError(
                    f"{path.name}: arm joint '{full.names[j]}' must be revolute or prismatic with limits"
                )
        off_chain = [j for j in range(1, full.njoints) if j not in chain]
        q_ref = pin.neutral(full)
        for name, value in (locked or {}).items():
            off_names = [full.names[j] for j in off_chain]
            if name not in off_names:
                raise UnknownNameError(f"joint off the arm chain of {path.name}", name, off_names)
            joint = full.joints[full.getJointId(name)]
            if joint.nq != 1:
                raise ValueError(f"{path.name}: cannot lock joint '{name}' at a single value")
            q_ref[joint.idx_q] = float(value)
        model = pin.buildReducedModel(full, off_chain, q_ref) if off_chain else full
        return cls(model, base_link, tip_link)

    # ------------------------------------------------------------- queries
    @property
    def dof(self) -> int:
        """Number of arm joints."""
        return self.model.nq

    @property
    def links(self) -> list[str]:
        """Names of the links (frames) whose pose :meth:`forward` can compute."""
        return list(self._links)

    def _frame_id(self, frame: str | None) -> int:
        if frame is None:
            return self._tip_id
        try:
            return self._links[frame]
        except KeyError:
            raise UnknownNameError("link of the arm model", frame, self._links) from None

    def _q(self, q: Vector) -> np.ndarray:
        q = np.asarray(q, dtype=float)
        if q.shape != (self.model.nq,):
            raise ValueError(
                f"expected {self.model.nq} joint values ({', '.join(self.joint_names)}), got shape {q.shape}"
            )
        return q

    def forward(self, q: Vector, frame: str | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Position (m) and rotation matrix of ``frame`` (default: the tip) in the base frame, at ``q``."""
        M = self.transform(q, frame)
        return M[:3, 3].copy(), M[:3, :3].copy()

    def transform(self, q: Vector, frame: str | None = None) -> np.ndarray:
        """4×4 homogeneous transform ``T_base_frame`` of ``frame`` (default: the tip) at ``q``."""
        fid = self._frame_id(frame)
        pin.forwardKinematics(self.model, self.data, self._q(q))
        oMf = pin.updateFramePlacement(self.model, self.data, fid)
        return (self._M_base_root * oMf).homogeneous

    def transforms(self, q: Vector, frames: Sequence[str]) -> list[np.ndarray]:
        """4×4 transforms ``T_base_frame`` of each of ``frames`` at ``q`` (one forward-kinematics pass)."""
        ids = [self._frame_id(f) for f in frames]
        pin.framesForwardKinematics(self.model, self.data, self._q(q))
        return [(self._M_base_root * self.data.oMf[i]).homogeneous for i in ids]

    def moved_by(self, frame: str) -> int:
        """The arm joint (1 = the first from the base; 0 = none) whose motion moves ``frame`` directly."""
        return int(self.model.frames[self._frame_id(frame)].parentJoint)

    def jacobian(self, q: Vector, frame: str | None = None) -> np.ndarray:
        """6×n Jacobian of ``frame`` (default: the tip) at ``q``.

        Rows 0-2 map joint speeds to the linear velocity (m/s) of the frame
        origin, rows 3-5 to its angular velocity (rad/s), both expressed in the
        base frame's axes.
        """
        fid = self._frame_id(frame)
        J = pin.computeFrameJacobian(self.model, self.data, self._q(q), fid, pin.LOCAL_WORLD_ALIGNED)
        R = self._R_base_root
        return np.vstack((R @ J[:3], R @ J[3:]))

    def within_limits(self, q: Vector, tolerance: float = 0.0) -> bool:
        """True when every joint of ``q`` is within its limits (± ``tolerance`` rad)."""
        q = self._q(q)
        return bool(np.all(q >= self.lower - tolerance) and np.all(q <= self.upper + tolerance))

    def clip(self, q: Vector) -> np.ndarray:
        """``q`` with every joint clipped into its limits."""
        return np.clip(self._q(q), self.lower, self.upper)
