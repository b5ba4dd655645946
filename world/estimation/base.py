"""The state estimate a robot publishes onboard, and the base of every estimator.

Frames: an estimate is expressed in its estimator's navigation frame,
``frame`` (``"odom"``: dead-reckoned from the start pose the mission
declares, drifting; ``"map"``: localised against the mission's declared
map, bounded error). Both coincide with the world frame at the start, so a
log can put truth and estimate side by side. Positions m, velocities m/s in
the navigation frame, angular velocity rad/s in the body frame, quaternions
``[x, y, z, w]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from marsupial.geometry import rotation_matrix, yaw_of


@dataclass(frozen=True)
class StateEstimate:
    """One onboard estimate of a robot's base (ground robots: its ``base_footprint``).

    Attributes:
        stamp: simulated time (s) of the estimate.
        frame: navigation frame (``"odom"`` or ``"map"``).
        position: position (m) in ``frame``.
        orientation: ``[x, y, z, w]`` quaternion of the body in ``frame``.
        velocity: linear velocity (m/s) in ``frame``.
        angular_velocity: body rates (rad/s, body frame).
        source: what produced it (e.g. ``"imu+flow+sonar+baro"``, ``"wheel_odometry"``, ``"map_localization"``).
        frame_shift: corrections by which external fixes have moved ``frame`` under the body so far,
            ``(x, y, z (m), yaw (rad))``, cumulated (PX4 publishes its estimator's resets likewise); a consumer
            that propagates with the estimate subtracts their change to get a smooth trajectory.
    """

    stamp: float
    frame: str
    position: np.ndarray
    orientation: np.ndarray
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    angular_velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    source: str = ""
    frame_shift: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)

    @property
    def yaw(self) -> float:
        """Heading (rad) about the frame's z axis."""
        return yaw_of(self.orientation)

    @property
    def rotation(self) -> np.ndarray:
        """``R_frame_body`` (3×3)."""
        return rotation_matrix(self.orientation)

    @property
    def speed(self) -> float:
        """Horizontal speed (m/s)."""
        return math.hypot(float(self.velocity[0]), float(self.velocity[1]))

    def to_dict(self) -> dict[str, object]:
        """JSON-ready form (for logs and the team link)."""
        return {
            "stamp": self.stamp,
            "frame": self.frame,
            "position": [float(v) for v in self.position],
            "orientation": [float(v) for v in self.orientation],
            "velocity": [float(v) for v in self.velocity],
            "angular_velocity": [float(v) for v in self.angular_velocity],
            "source": self.source,
            "frame_shift": [float(v) for v in self.frame_shift],
        }


class Estimator:
    """Base of onboard estimators: updated by their robot (world side), read as :meth:`estimate`.

    Subclasses implement :meth:`update` (read sensors, propagate, correct)
    and :meth:`reset` (restart from a pose, e.g. a hand-over from a carrier).
    """

    frame: str = "odom"

    def update(self, dt: float) -> None:
        """Advance the estimate by ``dt`` s (called by the robot at the estimator's rate, world side)."""
        raise NotImplementedError

    def estimate(self) -> StateEstimate:
        """The latest estimate (never computed from truth at call time)."""
        raise NotImplementedError

    def reset(self, position: np.ndarray, yaw: float) -> None:
        """Restart the estimate at ``position`` (m) with heading ``yaw`` (rad) in :attr:`frame`, at rest."""
        raise NotImplementedError
