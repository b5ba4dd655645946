"""The UAV pose in the manipulator frame M between camera frames.

The two robots' own estimates, re-anchored by each frame.

The eye-in-hand camera measures P_Q^M (eq. 1) at its frame rate, late by
its latency, and not at all when the bundle is out of view. Between frames
the pose is propagated with what the two robots know of their own motion:

- the carrier's onboard estimate of its base in its navigation frame N,
  composed with M's mount in the URDF: ``T_N_M(t)``. Until the first frame
  anchors the pose (the initial encounter flies on the estimates alone) N is
  the frame of the carrier's estimate (the map, localised; or ``odom``), the
  frame the UAV's estimate shares; from the first frame on it is the frame
  of the carrier's wheel odometry (``odom``), whose motion is smooth. A map
  localiser's fixes jump (AMCL-like: 1.4 cm per axis and 0.3° every 0.2 s at
  the default 5 cm / 1° / 5 s error, ``docs/world.md``), and every jump
  between a frame's stamp and now would pass straight into P_Q^M, the arm's
  target and the UAV's hold: 2–3 cm of lateral error at contact, against
  under 1 cm on odometry. Both frames are the carrier's own; the camera
  frames measure the rest;
- the UAV's onboard estimate (IMU, optical flow, sonar, barometer) of its
  base in its odometry frame O, as the carrier receives it over the team
  link (20 Hz telemetry, late and sometimes lost): ``T_O_Q(t)``, extrapolated
  from the newest message with its velocity and yaw rate.

N and O coincide at the start of a run and part by the estimators' drift,
so the pose in M is ``T_M_Q(t) = T_N_M(t)⁻¹ · C · T_O_Q(t)`` with ``C`` the
drift between the two frames (a turn about z and a translation), which each
camera frame re-anchors (:class:`RelativePoseFilter`): the prediction at
the frame's stamp is compared with the measurement and ``C`` moves toward
it by a gain; a measurement too far from the prediction is an outlier. Only
the drift since the last frame adds to the error while the marker is hidden.

External vision fix (``vision_fixes=True``, the ``track`` default): each frame
accepted by the filter is also sent to the UAV over the team link (:class:`~marsupial.api.readings.VisionFix` on
``<uav>/vision_fix``): the UAV base's pose in the frame of the carrier's
estimate, ``T_map_M(t_k) · P_Q^M(t_k)``, the camera's measurement composed
with the carrier's own estimate at the frame's stamp ``t_k`` (not the fused
pose: the UAV's own estimate is no part of it). The UAV's flight estimator
fuses it as a delayed measurement (:mod:`marsupial.world.estimation.external`),
which pulls O onto that frame, so that the UAV's velocity estimate, the one
its autopilot flies on, is the velocity in the frame of the carrier's
velocity that the relative hold feeds forward. Frames: O is the UAV's
odometry frame, equal to the carrier's estimate frame at the start of a run
and after a deploy hand-over (``reset_estimate``), anchored to it while
fixes arrive.

Frames and units: 4×4 homogeneous transforms ``T_A_B`` (B in A), metres,
radians, seconds (simulated).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from marsupial.api.readings import VisionFix, vision_fix_topic
from marsupial.geometry import quaternion_from_matrix, rot_z, rotation_matrix, transform, yaw_of_rotation
from marsupial.sensing import EstimateHistory

ESTIMATE_WINDOW = 1.0  # s of estimates kept to propagate to a late frame's stamp
MAX_FRAME_AGE_S = 0.5  # s: older frames are not fused (the estimates would be extrapolated to their stamp)


def unshifted(estimate: Any, shift0: tuple[float, float, float, float]) -> Any:
    """``estimate`` (a ``StateEstimate`` off the team link) without the frame corrections made since ``shift0``.

    ``shift0``: its ``frame_shift`` when the skill began.

    The UAV's vision fixes move its odometry frame O under it (position and
    heading, :attr:`~marsupial.api.readings.StateEstimate.frame_shift`);
    between two camera frames the drift ``C`` must see O's motion without
    those jumps, or a fix's correction of the UAV's own estimate moves P_Q^M
    by as much (a 20 cm height correction at the start of tracking sent the
    hold 20 cm down onto the end effector).
    """
    shift = estimate.frame_shift
    if shift == shift0:
        return estimate
    d = [a - b for a, b in zip(shift, shift0, strict=True)]
    position = np.asarray(estimate.position) - np.array(d[:3])
    orientation = quaternion_from_matrix(rot_z(-d[3]) @ rotation_matrix(estimate.orientation))  # back about z
    return replace(estimate, position=position, orientation=orientation, frame_shift=shift0)


def pose_at(history: EstimateHistory, t: float) -> np.ndarray | None:
    """The estimated base pose (4×4, navigation frame) at ``t`` from ``history``; ``None`` before any estimate."""
    pose = history.at(t)
    return None if pose is None else transform(*pose)


class RelativePoseFilter:
    """``C``, the drift between the carrier's frame N and the UAV's frame O, and its rate, re-anchored by each P_Q^M.

    ``C`` is a turn about z and a translation ``t_C`` that moves at the
    horizontal drift rate ``d`` (m/s, in N): the UAV's horizontal velocity
    estimate is biased (its optical flow measures the velocity over the
    surface under it, the carrier's moving deck or arm), so
    ``T_N_Q = C(t) · T_O_Q`` with ``t_C(t) = t_C(t_k) + d · (t − t_k)``; its
    height is anchored by the sonar and barometer, so ``d`` has no vertical
    part (a height step is corrected by ``gain`` alone).
    Before any measurement ``C`` is the identity and ``d`` zero (both frames
    start at the world frame the mission declares). The first measurement
    sets ``C``; every later one is compared with the prediction at its stamp:
    the innovation (position in M, heading) corrects ``t_C`` by ``gain`` and
    ``d`` by ``rate_gain`` per second since the last measurement (an α-β
    filter), the heading by ``gain``. A measurement farther from the
    prediction than ``gate + gate_rate · age`` (m; ``age``: s since the last
    accepted one; heading: the same over 0.1 m) is an outlier (a tag at the
    image border, a wrong planar-pose branch) and is dropped, unless
    ``max_rejections`` come in a row: then the prediction itself is wrong and
    the filter restarts from the measurement.

    Args:
        gain: weight (0…1] of a measurement in the pose; rate_gain: in the drift rate (0…1);
        gate: outlier threshold (m); gate_rate: its growth with the age of the last measurement (m/s);
        max_rejections: consecutive outliers that restart the filter; max_rate: bound of ``d`` (m/s);
        rate_horizon: how long (s) after the last measurement ``d`` is trusted (the surface under the UAV changes).
    """

    def __init__(
        self, gain: float = 0.8, gate: float = 0.03, max_rejections: int = 5,
        rate_gain: float = 0.15, gate_rate: float = 0.6, max_rate: float = 1.5, rate_horizon: float = 1.0,
    ):
        if not 0.0 < gain <= 1.0 or gate <= 0.0 or max_rejections < 1 or not 0.0 <= rate_gain < 1.0 or gate_rate < 0.0:
            raise ValueError(
                "RelativePoseFilter needs 0 < gain <= 1, gate > 0, max_rejections >= 1, 0 <= rate_gain < 1, "
                "gate_rate >= 0; "
                f"got {gain}, {gate}, {max_rejections}, {rate_gain}, {gate_rate}"
            )
        self.gain, self.gate, self.max_rejections = gain, gate, max_rejections
        self.rate_gain, self.gate_rate, self.max_rate, self.rate_horizon = rate_gain, gate_rate, max_rate, rate_horizon
        self.C = np.eye(4)  # T_N_O at t_ref: the UAV's odometry frame in the carrier's navigation frame
        self.rate = np.zeros(3)  # d: drift rate of C's translation (m/s, N)
        self.t_ref = 0.0
        self.measured = False
        self.rejections = 0

    def rate_at(self, t: float) -> np.ndarray:
        """The drift rate (m/s, N) at ``t``.

        Zero once the last measurement is older than ``rate_horizon`` (no longer known).
        """
        return self.rate if t - self.t_ref <= self.rate_horizon else np.zeros(3)

    def drift(self, t: float) -> np.ndarray:
        """``C`` (4×4) at ``t`` (s): its translation moved on at the drift rate, for at most ``rate_horizon`` s."""
        C = self.C.copy()
        C[:3, 3] += self.rate * min(max(t - self.t_ref, 0.0), self.rate_horizon)
        return C

    def predict(self, T_N_M: np.ndarray, T_O_Q: np.ndarray, t: float | None = None) -> np.ndarray:
        """P_Q^M (4×4) at ``t`` (s; ``None``: at the last measurement) from the two robots' estimates and the drift."""
        R_N_M, p_N_M = T_N_M[:3, :3], T_N_M[:3, 3]
        T_N_Q = (self.C if t is None else self.drift(t)) @ T_O_Q
        return transform(R_N_M.T @ (T_N_Q[:3, 3] - p_N_M), R_N_M.T @ T_N_Q[:3, :3])

    def measure(self, T_M_Q: np.ndarray, T_N_M: np.ndarray, T_O_Q: np.ndarray, t: float | None = None) -> bool:
        """Fuse P_Q^M measured at ``t`` (s) when the estimates read ``T_N_M``, ``T_O_Q``; False when it was rejected."""
        t = self.t_ref if t is None else t
        predicted = self.predict(T_N_M, T_O_Q, t)
        dp = T_M_Q[:3, 3] - predicted[:3, 3]
        dyaw = math.remainder(yaw_of_rotation(T_M_Q[:3, :3]) - yaw_of_rotation(predicted[:3, :3]), math.tau)
        age = max(t - self.t_ref, 0.0)
        gain, rate_gain = 1.0, 0.0
        if self.measured and self.rejections < self.max_rejections:
            gate = self.gate + self.gate_rate * age
            if np.linalg.norm(dp) > gate or abs(dyaw) * 0.1 > gate:
                self.rejections += 1
                return False
            gain, rate_gain = self.gain, self.rate_gain
        self.rejections = 0
        dp_N = T_N_M[:3, :3] @ dp
        if age > 1e-6 and rate_gain > 0.0:  # horizontal only: the height is anchored by the sonar and barometer
            self.rate[:2] = self.rate[:2] + rate_gain * dp_N[:2] / max(age, 0.05)
            speed = float(np.linalg.norm(self.rate))
            if speed > self.max_rate:
                self.rate *= self.max_rate / speed
        self.measured = True
        p_fused_N = T_N_M[:3, :3] @ predicted[:3, 3] + T_N_M[:3, 3] + gain * dp_N
        R_C = rot_z(gain * dyaw) @ self.C[:3, :3]  # turning C about z turns the predicted heading in M as much
        R_C = rot_z(yaw_of_rotation(R_C))  # C stays a turn about z: roll and pitch are the UAV's IMU's
        self.C = transform(p_fused_N - R_C @ T_O_Q[:3, 3], R_C)
        self.t_ref = t
        return True


@dataclass(frozen=True)
class RelativeState:
    """The UAV relative to the carrier now, from the estimates and the last frames.

    Attributes:
        t: time (s) of this state.
        T_M_Q: P_Q^M (4×4), ``None`` until both robots' estimates are known.
        v_M: the UAV's velocity relative to frame M, in M's axes (m/s).
        drift_M: the drift rate of the UAV's odometry against the carrier's frame, in M's axes (m/s):
            what the UAV's velocity estimate lacks, added to its commands (:func:`~.relative_hold.command_hold`).
        uav_speed: the UAV's ground speed (m/s), from its estimate.
        measured: True once a camera frame anchored the estimate.
        seen_at: stamp (s) of the last frame fused (−inf: none).
    """

    t: float
    T_M_Q: np.ndarray | None = field(default=None, repr=False)
    v_M: np.ndarray = field(default_factory=lambda: np.zeros(3))
    drift_M: np.ndarray = field(default_factory=lambda: np.zeros(3))
    uav_speed: float = 0.0
    measured: bool = False
    seen_at: float = -math.inf

    @property
    def yaw_M(self) -> float | None:
        """UAV heading in M (rad), ``None`` without a pose."""
        return None if self.T_M_Q is None else yaw_of_rotation(self.T_M_Q[:3, :3])


class RelativePose:
    """P_Q^M now.

    A :class:`RelativePoseFilter` over the carrier's estimate, the UAV's link telemetry and the eye-in-hand frames.

    Runs on the carrier's computer: the carrier's own estimate, the UAV's as
    the team link delivers it, the frames of the carrier's
    :class:`~.observer.EyeInHandObserver`; sends each accepted frame to the
    UAV as a vision fix (the module docstring).

    Args:
        carrier: the carrier's onboard interface (``estimate()``, ``arm_mount()``).
        link: the team link as the carrier uses it (``latest(uav)``, ``send``).
        uav: the UAV's name.
        observer: the carrier's eye-in-hand observer; ``None``: the estimates alone, no frame fused.
        gain, gate: of the :class:`RelativePoseFilter`.
        since: UAV telemetry stamped before this time (s) is ignored (e.g. before its estimator was reset).
    """

    def __init__(
        self,
        carrier,
        link,
        uav: str,
        observer,
        gain: float = 0.8,
        gate: float = 0.03,
        since: float = -math.inf,
        vision_fixes: bool = False,
    ):
        self.carrier, self.link, self.uav, self.observer = carrier, link, uav, observer
        self.vision_fixes = vision_fixes
        self.T_base_M = transform(*carrier.arm_mount())  # M in the footprint frame the carrier's estimate is of
        self.filter = RelativePoseFilter(gain, gate)
        self.carrier_history = EstimateHistory(ESTIMATE_WINDOW)  # the carrier's estimate: until the first frame
        self.odometry_history = EstimateHistory(ESTIMATE_WINDOW)  # its wheel odometry: N from the first frame on
        self.uav_history = EstimateHistory(ESTIMATE_WINDOW)
        self.fused_stamp = -math.inf
        self.seen_at = -math.inf
        self.since = since
        self.uav_shift0: tuple[float, float, float, float] | None = None  # the UAV's frame_shift at its first message

    def T_N_M(self, t: float, odometry: bool) -> np.ndarray | None:
        """Frame M in the carrier's frame at ``t``: of its wheel odometry (``odometry``) or of its estimate."""
        T_N_base = pose_at(self.odometry_history if odometry else self.carrier_history, t)
        return None if T_N_base is None else T_N_base @ self.T_base_M

    def send_fix(self, T_N_Q: np.ndarray, stamp: float) -> None:
        """Send the UAV its pose in N measured at ``stamp`` (s) over the team link (once per frame)."""
        x, y, z = (float(v) for v in T_N_Q[:3, 3])
        fix = VisionFix(stamp, (x, y, z), yaw_of_rotation(T_N_Q[:3, :3]), f"{self.carrier.name}/eye_in_hand")
        self.link.send(vision_fix_topic(self.uav), fix)

    def update(self, now: float) -> RelativeState:
        """Read the estimates, fuse a new frame in which the bundle was measured, and propagate to ``now``."""
        self.carrier_history.add(self.carrier.estimate())
        self.odometry_history.add(self.carrier.odometry())
        message = self.link.latest(self.uav)
        if message is not None and message.payload.stamp >= self.since:
            if self.uav_shift0 is None:
                self.uav_shift0 = message.payload.frame_shift
            self.uav_history.add(unshifted(message.payload, self.uav_shift0))
        observation = None if self.observer is None else self.observer.observe(now)
        pose = None if observation is None else observation.pose  # None: the bundle was not measured in it
        # not a frame from before this skill
        fresh = observation is not None and observation.stamp >= now - MAX_FRAME_AGE_S
        if observation is not None and pose is not None and fresh and observation.stamp > self.fused_stamp:
            self.fused_stamp = observation.stamp
            T_N_M, T_O_Q = self.T_N_M(observation.stamp, odometry=True), pose_at(self.uav_history, observation.stamp)
            if (
                T_N_M is not None
                and T_O_Q is not None
                and self.filter.measure(pose.T_M_Q, T_N_M, T_O_Q, observation.stamp)
            ):
                self.seen_at = observation.stamp
                T_map_M = self.T_N_M(observation.stamp, odometry=False)  # the fix is in the frame the UAV's shares
                if self.vision_fixes and T_map_M is not None:
                    self.send_fix(T_map_M @ pose.T_M_Q, observation.stamp)
        T_N_M, T_O_Q = self.T_N_M(now, odometry=self.filter.measured), pose_at(self.uav_history, now)
        if T_N_M is None or T_O_Q is None:
            return RelativeState(now, seen_at=self.seen_at)
        T_M_Q = self.filter.predict(T_N_M, T_O_Q, now)
        uav = self.uav_history.latest
        carrier = (self.odometry_history if self.filter.measured else self.carrier_history).latest
        assert uav is not None and carrier is not None, "the poses above came from them"
        drift_N = self.filter.rate_at(now)
        v_uav_N = self.filter.C[:3, :3] @ np.asarray(uav.velocity) + drift_N
        R_N_base = rotation_matrix(carrier.orientation)
        w_N = R_N_base @ np.asarray(carrier.angular_velocity)
        p_uav_N = (T_N_M @ np.append(T_M_Q[:3, 3], 1.0))[:3]
        v_frame_N = np.asarray(carrier.velocity) + np.cross(w_N, p_uav_N - carrier.position)  # M's point under the UAV
        v_M = T_N_M[:3, :3].T @ (v_uav_N - v_frame_N)
        drift_M = T_N_M[:3, :3].T @ drift_N
        speed = float(np.linalg.norm(v_uav_N))
        return RelativeState(now, T_M_Q, v_M, drift_M, speed, self.filter.measured, self.seen_at)
