"""The UAV as the carrier's eye-in-hand camera sees it: one measurement per camera frame, shared by the skills.

Several skills look at the UAV through the same camera in the same tick
(``rendezvous`` or ``track`` on the arm, ``relative_hold`` on the UAV). The
camera samples at its own rate, so they all get the same frame; the
:class:`EyeInHandObserver` of a carrier measures each frame once with
:class:`~.pose.UavPoseMeasurement` (AprilTag bundle → P_Q^{C_A} → eq. (1))
and hands the same :class:`UavObservation` to every caller.

F(q) of eq. (1) uses the joint encoders at the frame's stamp: the observer
keeps the encoder readings of the last second (read at every call) and
interpolates them at the stamp, so a frame that arrives late (the camera's
latency) is composed with the arm pose it was taken from, not the present
one.
"""

from __future__ import annotations

import itertools
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from .pose import UavPose, UavPoseMeasurement

CAMERA = "eye_in_hand"  # the carrier's sensor looking at the UAV's bundle
ENCODER_WINDOW = 1.0  # s of joint-encoder readings kept to compose late frames with F(q) at their stamp


@dataclass(frozen=True)
class UavObservation:
    """One eye-in-hand frame looked at: its stamp (s, simulated) and the UAV pose in M (``None``: not seen).

    Attributes:
        stamp: time the frame was taken (s).
        pose: P_Q^M and the tags used, or ``None`` when no bundle tag was found.
    """

    stamp: float
    pose: UavPose | None

    @property
    def seen(self) -> bool:
        """True when the bundle was measured in this frame."""
        return self.pose is not None


class EncoderHistory:
    """Joint-encoder readings (rad) of the last ``window`` s, interpolated at any time inside it."""

    def __init__(self, window: float = ENCODER_WINDOW):
        self.window = window
        self.samples: deque[tuple[float, np.ndarray]] = deque()

    def add(self, t: float, q: np.ndarray) -> None:
        """Record the encoders read at ``t`` (s); older readings than ``window`` are dropped."""
        if self.samples and t <= self.samples[-1][0]:
            return
        self.samples.append((t, np.asarray(q, dtype=float).copy()))
        while len(self.samples) > 2 and self.samples[1][0] < t - self.window:
            self.samples.popleft()

    def at(self, t: float) -> np.ndarray:
        """The joint angles at ``t``: linear between the two readings around it, the nearest one outside."""
        samples = self.samples
        if t >= samples[-1][0]:
            return samples[-1][1]
        if t <= samples[0][0]:
            return samples[0][1]
        for (t0, q0), (t1, q1) in itertools.pairwise(samples):
            if t0 <= t <= t1:
                return q0 + (q1 - q0) * (t - t0) / (t1 - t0)
        return samples[-1][1]  # not reached: the samples are ordered


class EyeInHandObserver:
    """Measures the UAV in each new frame of a carrier's eye-in-hand camera (once per frame).

    Use :meth:`of` to get the carrier's observer shared by the nodes of a
    run. ``carrier`` is the carrier's onboard interface (or a command port on
    it): the ``eye_in_hand`` camera, ``arm_kinematics`` (frame M) and
    ``joint_positions()`` (the encoders).
    """

    def __init__(self, carrier: Any):
        self.carrier = carrier
        self.camera = carrier.sensor(CAMERA)
        self.measurement = UavPoseMeasurement(carrier.arm_kinematics, self.camera.K)
        self.encoders = EncoderHistory()
        self.last: UavObservation | None = None  # the latest frame looked at
        self.last_seen: UavObservation | None = None  # the latest frame in which the UAV was measured

    @classmethod
    def of(cls, context: Any, carrier: Any) -> EyeInHandObserver:
        """The observer shared by every node of the run ``context`` looking through ``carrier``'s eye-in-hand camera."""
        shared: dict[str, EyeInHandObserver] = context.shared.setdefault("eye_in_hand_observers", {})
        observer = shared.get(carrier.name)
        if observer is None:
            observer = shared[carrier.name] = cls(carrier)
        return observer

    def observe(self, now: float) -> UavObservation | None:
        """The observation of the camera's latest frame (measured now if it is new); ``None`` before any frame."""
        self.encoders.add(now, self.carrier.joint_positions())
        reading = self.camera.read()
        if reading is None:
            return None
        if self.last is not None and self.last.stamp == reading.stamp:
            return self.last
        pose = self.measurement.measure(reading.data.rgb, self.encoders.at(reading.stamp))
        self.last = UavObservation(reading.stamp, pose)
        if pose is not None:
            self.last_seen = self.last
        return self.last

    def latest_seen(self, now: float, max_age: float) -> UavObservation | None:
        """The most recent frame with the UAV measured if it is at most ``max_age`` s old at ``now``, else ``None``."""
        self.observe(now)
        if self.last_seen is None or now - self.last_seen.stamp > max_age + 1e-9:
            return None
        return self.last_seen


def position_spread(positions: list[np.ndarray]) -> float:
    """Largest distance (m) of a set of positions from their mean (0 for fewer than two)."""
    if len(positions) < 2:
        return 0.0
    p = np.asarray(positions)
    return float(np.max(np.linalg.norm(p - p.mean(axis=0), axis=1)))
