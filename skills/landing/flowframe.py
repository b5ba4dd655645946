"""The frame the UAV's estimate is in, once its optical flow sees the platform (our departure from the paper).

The UAV's onboard estimator integrates the downward optical flow, which
measures the velocity relative to the surface under the camera (the
per-axis median over five rays: the centre and the corners of a square
field of half-angle ``half_angle``, a static fact of the ``flow`` sensor).
Low over the platform the flow measures the UAV's velocity relative to the
platform, and the estimate's navigation frame then moves with the
platform: the platform's velocity in that frame drops from its ground speed
to ≈0 within the estimator's response (flow gain 8 /s, ≈0.13 s), and rises
back when the flow sees the floor again (take-off climb, a drift off the
platform). The paper's AR.Drone had the same firmware effect; its
controller has no feed-forward and the authors do not discuss it. A filter
that keeps feeding forward the old velocity flies the UAV ahead of the
platform, with no detections in the last 0.7 m to correct it.

Two pieces, on onboard knowledge only:

- :func:`rays_on_platform` predicts how many of the five flow rays meet the
  platform, from the estimated attitude, the sonar height above the
  platform, the platform's position and heading (the tracker's filter and
  the detections) and its size (a static prior). Near the switch of the
  median (two or three rays) the prediction is uncertain, so
  :func:`flow_surface` asks it for a field narrowed and widened by
  :data:`FIELD_MARGIN`: the flow may change surfaces when they disagree.
- :class:`FrameShift` measures, while the flow may be changing surfaces and
  for :attr:`FrameShift.settle_s` after (the estimator's transition), the
  part of the estimate's velocity change that the flow made: the change of
  the estimated velocity minus the IMU's specific force integrated in the
  navigation frame, corrected by the mean of the same quantity outside such
  windows (the accelerometer bias and attitude error, on which the
  estimator's frame does not move). That part is the change of the frame's
  velocity over the ground, so the platform's velocity in the frame changes
  by it: the tracker adds it to its filter's velocity. The relative
  velocity of platform and UAV, the same in every frame, is kept.
- Once the transition is over with the flow on the platform, the frame
  moves with the platform, whose velocity in it is zero: the tracker holds
  its filter's velocity there (the filter's position still follows the
  detections), rather than letting the accelerometer-bias residue of the
  measured shift or the noisy velocity of the detections feed forward.

Frames: navigation frame of the UAV's estimate (m, m/s); heights m above the
platform; times simulated s.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

FIELD_MARGIN = 0.1  # fraction by which the flow field is narrowed / widened to bracket the median's switch (chosen)
MEDIAN_RAYS = 3  # the per-axis median of five rays follows the platform once three of them meet it


def rays_on_platform(
    half_angle: float,
    R_nav_body: np.ndarray,
    origin_xy: np.ndarray,
    height: float,
    platform_xy: np.ndarray,
    platform_yaw: float,
    half_side: float,
) -> int:
    """How many of the five flow rays meet the platform's top (0–5).

    Args:
        half_angle: half-angle of the square flow field (rad); rays along the body's ``-z`` and towards
            ``(±tan, ±tan, -1)``.
        R_nav_body: estimated attitude (3×3).
        origin_xy: the flow camera's estimated position (m, navigation frame).
        height: the camera's height above the platform's top (m, the sonar's range: same origin).
        platform_xy: the platform's centre (m, navigation frame).
        platform_yaw: the platform's heading in the navigation frame (rad; a square: modulo π/2).
        half_side: half the side of the (square) platform (m).
    """
    t = math.tan(half_angle)
    rays = np.array([[0.0, 0.0, -1.0]] + [[sx * t, sy * t, -1.0] for sx in (-1.0, 1.0) for sy in (-1.0, 1.0)])
    directions = rays @ np.asarray(R_nav_body, dtype=float).T  # (5, 3), navigation frame
    down = np.maximum(-directions[:, 2], 1e-3)
    footprints = np.asarray(origin_xy, dtype=float)[:2] + directions[:, :2] * (height / down)[:, None]
    c, s = math.cos(platform_yaw), math.sin(platform_yaw)
    d = footprints - np.asarray(platform_xy, dtype=float)[:2]
    local = np.stack((c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]), axis=1)  # platform frame
    return int(np.count_nonzero(np.all(np.abs(local) <= half_side, axis=1)))


def flow_surface(half_angle: float, *geometry: object) -> tuple[bool, bool]:
    """``(on_platform, switching)``: whether the flow's median follows the platform, and whether that is uncertain.

    ``on_platform``: at least :data:`MEDIAN_RAYS` of the five rays meet it;
    ``switching``: the fields narrowed and widened by :data:`FIELD_MARGIN`
    disagree, so the median may be changing surfaces. ``geometry`` are the
    arguments of :func:`rays_on_platform` after ``half_angle``.
    """
    sees = [
        rays_on_platform(half_angle * k, *geometry) >= MEDIAN_RAYS  # type: ignore[arg-type]
        for k in (1.0 - FIELD_MARGIN, 1.0, 1.0 + FIELD_MARGIN)
    ]
    return sees[1], len(set(sees)) > 1


class FrameShift:
    """Change of the estimate frame's velocity made by the flow while it changes surfaces (module docstring).

    Args:
        settle_s: how long after the last possible switch the shift is still applied (s): the
            estimator's transition, ≈3 time constants of its 8 /s flow gain.
        bias_tau_s: time constant (s) of the mean taken outside the windows (IMU bias, attitude error).
    """

    def __init__(self, settle_s: float = 0.4, bias_tau_s: float = 2.0):
        self.settle_s = settle_s
        self.bias_tau_s = bias_tau_s
        self.bias = np.zeros(2)  # mean of (Δv_est - ∫R f dt)/dt outside the windows (m/s²)
        self.until = -math.inf  # end of the present window (s)
        self.total = np.zeros(2)  # shift applied over the present window (m/s), for the record
        self._stamp: float | None = None
        self._velocity = np.zeros(2)
        self._inertial = np.zeros(2)  # ∫R f dt (m/s) since the last estimate used
        self._imu_stamp = -math.inf

    def active(self, stamp: float) -> bool:
        """Whether the frame may still be changing at ``stamp`` (s): inside a window."""
        return stamp <= self.until

    def step(
        self,
        stamp: float,
        velocity_xy: np.ndarray,
        R_nav_body: np.ndarray,
        imu: Iterable[tuple[float, np.ndarray]],
        switching: bool,
    ) -> np.ndarray:
        """The frame's velocity change (m/s, navigation frame) to add to the platform's since the last call.

        Args:
            stamp: the estimate's stamp (s); calls with the same stamp return zero.
            velocity_xy: the estimated horizontal velocity (m/s).
            R_nav_body: estimated attitude (3×3), to turn the IMU's specific force into the frame.
            imu: (stamp s, specific force m/s², body frame) samples since the last call.
            switching: the second value of :func:`flow_surface` now.
        """
        velocity = np.asarray(velocity_xy, dtype=float)[:2]
        R = np.asarray(R_nav_body, dtype=float)
        for t, f in imu:
            if t > self._imu_stamp:
                if math.isfinite(self._imu_stamp):
                    self._inertial += (R[:2] @ np.asarray(f, dtype=float)) * (t - self._imu_stamp)
                self._imu_stamp = t
        if self._stamp is None or stamp <= self._stamp:
            if self._stamp is None:
                self._stamp, self._velocity, self._inertial = stamp, velocity, np.zeros(2)
            return np.zeros(2)  # the IMU's integral waits for the next estimate
        dt = stamp - self._stamp
        flow_made = velocity - self._velocity - self._inertial  # what the flow corrections changed (+ bias)
        self._inertial = np.zeros(2)
        self._stamp, self._velocity = stamp, velocity
        if switching:
            if stamp > self.until:
                self.total = np.zeros(2)
            self.until = stamp + self.settle_s
        if self.active(stamp):
            shift = flow_made + self.bias * dt
            self.total = self.total + shift
            return shift
        k = min(1.0, dt / self.bias_tau_s)
        self.bias += k * (-flow_made / dt - self.bias)
        return np.zeros(2)
