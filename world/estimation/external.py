"""External vision fixes of a quadrotor's pose, fused by its flight estimator as delayed measurements.

What PX4's external-vision input (EKF2 ``EV_POS``/``EV_YAW``) does, reduced
to the complementary filter of :mod:`.flight`: another robot that sees the
UAV (the carrier's eye-in-hand camera measuring its AprilTag bundle, P_Q^M
of Narváez eq. (1), composed with the carrier's own estimate) sends its pose
over the team link as a :class:`VisionFix` on the topic
:func:`vision_fix_topic`; the UAV's firmware, listening to its radio, polls
the newest one at every estimator update (:class:`VisionFixFusion`).

Frames: a fix gives the UAV base's position (m) and heading (rad) in the
*sender's* navigation frame N (the carrier's ``odom`` or ``map``). The UAV's
own navigation frame O coincides with N at the start of a run (both are
the world frame the mission declares) and after a deploy hand-over
(``reset_estimate`` puts O on N); in between they part by the two
estimators' drift. Fusing fixes pulls O onto N: while fixes arrive the UAV's
estimate is anchored to the carrier's frame, which is what the relative
hold needs (its feed-forward, the carrier's velocity, is in N).

A fix is late: it was taken at ``stamp`` (the camera frame), measured on the
carrier's next tick and carried by the link (latency, jitter, loss). It is
compared with the estimate *at its stamp*, read from a short history of the
estimate (``history`` s; a fix older than that is ignored), with every
correction applied since added back, so that two fixes in flight do not
correct the same error twice; the innovation ``e`` is applied *now*
(PX4's output-predictor scheme). Per fix, with ``Δ`` the time since the
previous fix (at most ``max_dt``)::

    p += k_p Δ e,   v += k_v Δ e,   b −= k_b Δ e,   yaw += k_yaw Δ e_yaw

a third-order complementary filter on position, velocity and the
accelerometer bias ``b`` (``k_p = 4 /s``, ``k_v = 4 /s²``: critically
damped at ω = 2 rad/s, a time constant of 0.5 s, slow against the 10–60 Hz
fixes and their 0.1–0.2 s delay, fast against the flow's drift; ``k_b =
2 /s³``). Without the bias term a constant accelerometer bias would leave a
velocity error of ``k_p/k_v`` times the bias, which the autopilot would fly
(over the carrier no floor echo and no flow corrects it). A fix farther than ``converged`` from the
estimate (e.g. the first one after a long flight), horizontally (position
or heading) or vertically, is an offset of the frame, not a velocity error:
it corrects that part's position (and heading) only, the innovation clipped
to ``innovation_limit``, so the estimate moves by at most
``k_p · innovation_limit`` m/s, with no jump for the autopilot or the
carrier's filter.

While fixes are recent (the last one at most ``timeout`` s old) the
estimate trusts the vision-anchored state over the sensors that may be
looking at the carrier rather than the floor (EKF2's innovation gates,
tightened because the fixes shrink the uncertainty):

- the fixes are the height reference (EKF2's ``EV_HGT``): sonar echoes no
  longer correct the height (over the carrier an echo off its deck,
  0.2–0.3 m high, matches a height estimate that low and would hold it
  there against the fixes) and the barometer's offset is calibrated against
  the vision-anchored height instead of correcting it;
- once the last fix was horizontally converged, optical-flow samples whose
  innovation exceeds ``flow_gate`` are rejected: the flow measures the
  velocity over the surface under the camera, and over the carrier's
  moving deck or arm that is off by about the carrier's speed;
  ``flow_gate`` (0.15 m/s) is about 3.5σ of the flow's noise at 1 m
  (0.02 + 0.02 m/s per m of range, ``docs/world.md``).

The corrections of position and heading are a shift of the navigation
frame under the vehicle, not a motion of the vehicle: the estimator
accumulates them (``shift``) and the autopilot moves its position and
heading references by as much (PX4 shifts its set-points by the estimator's
reset deltas), so a fix changes what the vehicle does only through the
velocity estimate and the skills' commands.

Plain ``math``: one dictionary look-up per update (120 Hz) and a short scan
of the history per fix.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from marsupial.api.readings import VisionFix


@dataclass(frozen=True)
class VisionFixGains:
    """Gains and limits of the vision-fix fusion (chosen; see the module docstring and ``docs/world.md``).

    Attributes:
        position: ``k_p`` (1/s), position correction per second per metre of innovation.
        velocity: ``k_v`` (1/s²), velocity correction per second per metre of innovation.
        bias: ``k_b`` (1/s³), accelerometer-bias correction per second per metre of innovation.
        yaw: ``k_yaw`` (1/s), heading correction per second per radian of innovation.
        innovation_limit: position (m) and heading (rad) innovations are clipped to this length.
        converged: a fix at most this far (m; heading: rad) from the estimate, horizontally or vertically, also
            corrects that part of the velocity (and, horizontally, gates the flow); a farther one the position only.
        history: how long (s) the estimate's history is kept; older fixes are ignored.
        timeout: fixes count as recent while the last one is at most this old (s).
        flow_gate: while fixes are recent, flow samples with a larger innovation (m/s) are rejected.
        max_dt: longest interval (s) between two fixes that a fix's correction is scaled by.
    """

    position: float = 4.0
    velocity: float = 4.0
    bias: float = 2.0
    yaw: float = 2.0
    innovation_limit: float = 0.15
    converged: float = 0.1
    history: float = 0.5
    timeout: float = 0.5
    flow_gate: float = 0.15
    max_dt: float = 0.2


class VisionFixFusion:
    """The delayed-measurement bookkeeping of the vision fixes of one flight estimator.

    Args:
        source: returns the newest vision-fix message delivered to the UAV (a
            :class:`~marsupial.api.readings.LinkMessage` whose payload is a
            :class:`VisionFix`), or ``None``.
        gains: :class:`VisionFixGains`.

    Attributes:
        shift: the position (m) and heading (rad) corrections applied so far, cumulated
            (``[x, y, z, yaw]``, navigation frame; the autopilot follows them with its references).
        fused, stale: numbers of fixes fused and of fixes ignored as older than the history.
        last_stamp: stamp (s) of the last fix fused (−inf: none).
        converged: True when the last fix was horizontally within ``gains.converged`` of the estimate (position
            and heading).
    """

    def __init__(self, source: Callable[[], Any], gains: VisionFixGains = VisionFixGains()):
        self.source = source
        self.gains = gains
        self.shift = [0.0, 0.0, 0.0, 0.0]
        self._history: deque[tuple[float, float, float, float, float]] = deque()
        self._seen: Any = None  # the last message looked at
        self.last_stamp = -math.inf
        self.converged = False
        self.fused = 0
        self.stale = 0

    def clear(self) -> None:
        """Forget the history and the last fix (the estimate restarted: older fixes no longer apply)."""
        self._history.clear()
        self.last_stamp = -math.inf
        self.converged = False

    def record(self, t: float, p: list[float], yaw: float) -> None:
        """Keep the estimate at ``t`` (s) in the history, minus the corrections applied so far."""
        s = self.shift
        history = self._history
        history.append((t, p[0] - s[0], p[1] - s[1], p[2] - s[2], yaw - s[3]))
        horizon = t - self.gains.history
        while history[0][0] < horizon:
            history.popleft()

    def recent(self, now: float) -> bool:
        """True while the last fix is at most ``timeout`` s old (the height is then vision-anchored)."""
        return now - self.last_stamp <= self.gains.timeout

    def flow_rejected(self, now: float, ex: float, ey: float) -> bool:
        """True when a flow sample of innovation ``(ex, ey)`` (m/s) is an outlier.

        The gate is against the vision-anchored velocity.
        """
        return ex * ex + ey * ey > self.gains.flow_gate**2 and self.converged and self.recent(now)

    def poll(self) -> tuple[float, ...] | None:
        """The correction of a new fix, ``(dpx, dpy, dpz, dvx, dvy, dvz, dyaw, dbx, dby, dbz)`` (m, m/s, rad, m/s²;
        ``db`` is added to the accelerometer-bias estimate), or ``None`` (no new fix, or too old).

        The position and heading parts are added to :attr:`shift`; the caller applies all of them.
        """
        message = self.source()
        if message is None or message is self._seen:
            return None
        self._seen = message
        fix = message.payload
        if not isinstance(fix, VisionFix) or fix.stamp <= self.last_stamp:
            return None
        past = self._at(fix.stamp)
        if past is None:
            self.stale += 1
            return None
        g = self.gains
        ex, ey, ez = fix.position[0] - past[0], fix.position[1] - past[1], fix.position[2] - past[2]
        eyaw = math.remainder(fix.yaw - past[3], math.tau)
        norm = math.sqrt(ex * ex + ey * ey + ez * ez)
        self.converged = math.hypot(ex, ey) <= g.converged and abs(eyaw) <= g.converged
        vertical = abs(ez) <= g.converged
        if norm > g.innovation_limit:
            k = g.innovation_limit / norm
            ex, ey, ez = ex * k, ey * k, ez * k
        eyaw = max(-g.innovation_limit, min(g.innovation_limit, eyaw))
        dt = min(fix.stamp - self.last_stamp, g.max_dt)
        self.last_stamp = fix.stamp
        self.fused += 1
        kp, kyaw = g.position * dt, g.yaw * dt
        kv = g.velocity * dt if self.converged else 0.0  # a far fix is an offset of the frame
        kvz = g.velocity * dt if vertical else 0.0
        kb = -g.bias * dt if self.converged else 0.0
        kbz = -g.bias * dt if vertical else 0.0
        correction = (kp * ex, kp * ey, kp * ez, kv * ex, kv * ey, kvz * ez, kyaw * eyaw, kb * ex, kb * ey, kbz * ez)
        s = self.shift
        s[0] += correction[0]
        s[1] += correction[1]
        s[2] += correction[2]
        s[3] += correction[6]
        return correction

    def _at(self, t: float) -> tuple[float, float, float, float] | None:
        """The estimate (position m, heading rad) at ``t`` with the corrections applied since.

        ``None`` outside the history.
        """
        history = self._history
        if not history or t < history[0][0]:
            return None
        s = self.shift
        later = history[-1]
        for sample in reversed(history):
            if sample[0] <= t:
                t0, x0, y0, z0, yaw0 = sample
                t1, x1, y1, z1, _ = later
                w = (t - t0) / (t1 - t0) if t1 > t0 else 0.0
                return (
                    x0 + w * (x1 - x0) + s[0], y0 + w * (y1 - y0) + s[1], z0 + w * (z1 - z0) + s[2], yaw0 + s[3],
                )
            later = sample
        return None  # not reached: t >= the oldest stamp
