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

import numpy as np

from marsupial.api.readings import StateEstimate


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
