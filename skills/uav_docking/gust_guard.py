"""Supervision of the contact approach against a UAV that does not hold still (gusts): back off, then resume.

Narváez §IV-B: the contact phase "supervises the end-effector movement for
a slow vertical approach toward the UAV". The paper's supervision is the
operator's; in gusts (2 m/s, ``benchmarks/missions/docking_encounter.yaml``)
a hovering UAV is shoved several centimetres in a fraction of a second, and
an end effector held a few millimetres under Part B while it waits for the
alignment is struck by the UAV's adapter or body. The guard watches what the
carrier knows of the UAV relative to M (the camera-anchored estimate,
:class:`~.track.TrackingState`):

- the lateral offset of Part B from Part A's axis (m), and
- the UAV's speed relative to frame M (m/s, from its velocity estimate over
  the team link and the carrier's odometry),

and calls the UAV unsteady while either exceeds its limit. The contact skill
then lowers Part A to a safe gap and stops its contact clock; the guard
clears once both have stayed within their limits for ``calm_time``.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class GuardLimits:
    """Limits of the gust guard.

    Attributes:
        lateral: largest lateral offset (m) of Part B from Part A's axis while closing in.
        speed: largest UAV speed (m/s) relative to frame M.
        calm_time: time (s) both must stay within their limits before the approach resumes.
    """

    lateral: float = 0.025
    speed: float = 0.08
    calm_time: float = 0.5


class GustGuard:
    """Unsteady/calm state of the UAV under Part A, with hysteresis in time (seconds, simulated)."""

    def __init__(self, limits: GuardLimits):
        self.limits = limits
        self.unsteady_since: float | None = None
        self.calm_since: float | None = None
        self.reason = ""

    def update(self, now: float, lateral: float, speed: float) -> bool:
        """True while the UAV counts as unsteady at ``now`` (s).

        ``lateral``: offset (m) of Part B from Part A's axis; ``speed``: the UAV's speed relative to M (m/s).
        """
        over = lateral > self.limits.lateral or speed > self.limits.speed
        if over:
            self.calm_since = None
            if self.unsteady_since is None:
                self.unsteady_since = now
                self.reason = f"UAV unsteady: {100 * lateral:.1f} cm off axis, {100 * speed:.0f} cm/s relative to M"
            return True
        if self.unsteady_since is None:
            return False
        if self.calm_since is None:
            self.calm_since = now
        if now - self.calm_since + 1e-9 < self.limits.calm_time:
            return True
        self.unsteady_since = self.calm_since = None
        return False
