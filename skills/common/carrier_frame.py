"""The carrier's arm frame M in its navigation frame N, and how it moves, from the carrier's own estimate.

The UAV-docking skills feed its motion forward to the UAV held in M
(:mod:`marsupial.skills.uav_docking.relative_hold`); the aperture skills pose
the launching apparatus in N through it (:mod:`marsupial.skills.aperture.insertion`).

Frames: M the arm frame (``arm_base``), N the carrier's navigation frame; metres, radians.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from marsupial.api.readings import StateEstimate
from marsupial.geometry import rotation_matrix, yaw_of_rotation


@dataclass(frozen=True)
class CarrierFrame:
    """Frame M of the carrier now and how it moves, from the carrier's own estimate (its navigation frame N).

    Attributes:
        p_M_W: origin of M (m); R_W_M: rotation of M in N.
        p_base_W, v_base_W, w_base_W: the carrier base's position (m), linear (m/s) and angular (rad/s) velocity in N.
    """

    p_M_W: np.ndarray
    R_W_M: np.ndarray
    p_base_W: np.ndarray
    v_base_W: np.ndarray
    w_base_W: np.ndarray

    @classmethod
    def from_estimate(cls, estimate: StateEstimate, mount: tuple[np.ndarray, np.ndarray]) -> CarrierFrame:
        """Frame M from the carrier's estimate (of its ``base_footprint``) and M's ``mount`` in that frame.

        The mount is a position (m) and a rotation, from the URDF.
        """
        R = rotation_matrix(estimate.orientation)
        p_base = np.asarray(estimate.position, dtype=float)
        p_M_base, R_base_M = mount
        return cls(
            p_base + R @ p_M_base,
            R @ R_base_M,
            p_base,
            np.asarray(estimate.velocity),
            R @ np.asarray(estimate.angular_velocity),
        )

    @classmethod
    def of(cls, carrier: Any) -> CarrierFrame:
        """Frame M of ``carrier`` (onboard interface or command port) from its onboard estimate."""
        return cls.from_estimate(carrier.estimate(), carrier.arm_mount())

    @property
    def yaw(self) -> float:
        """Heading of M about N's z (rad)."""
        return yaw_of_rotation(self.R_W_M)

    def to_world(self, p_M: np.ndarray) -> np.ndarray:
        """A point of M in N (m)."""
        return self.p_M_W + self.R_W_M @ p_M

    def to_M(self, p_W: np.ndarray) -> np.ndarray:
        """A point of N in frame M (m)."""
        return self.R_W_M.T @ (np.asarray(p_W) - self.p_M_W)

    def velocity_of(self, p_W: np.ndarray) -> np.ndarray:
        """Velocity (m/s, N) of the point ``p_W`` carried rigidly by the carrier."""
        return self.v_base_W + np.cross(self.w_base_W, np.asarray(p_W) - self.p_base_W)
