"""The UAV as the carrier's eye-in-hand camera sees it: one measurement per camera frame, shared by the skills.

Several skills look at the UAV through the same camera in the same tick
(``rendezvous`` or ``track`` on the arm, ``relative_hold`` on the UAV). The
camera samples lazily at its own rate, so they all get the same frame; the
:class:`EyeInHandObserver` of a carrier measures each frame once with
:class:`~.pose.UavPoseMeasurement` (AprilTag bundle → P_Q^{C_A} → eq. (1))
and hands the same :class:`UavObservation` to every caller.

The joint angles q of F(q) are read when the frame is read; with a relayed
video latency (``video_latency`` disturbance) the arm may have moved since
the frame was taken, an error the real system has too.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass
from typing import Any

import numpy as np

from .pose import UavPose, UavPoseMeasurement


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


class EyeInHandObserver:
    """Measures the UAV in each new frame of a carrier's eye-in-hand camera (once per frame).

    Use :meth:`of` to get the carrier's shared observer. ``carrier`` is the
    world robot (or a command port on it): ``eye_in_hand`` camera,
    ``arm_kinematics`` (frame M) and ``joint_positions()``.
    """

    _shared: weakref.WeakKeyDictionary[Any, EyeInHandObserver] = weakref.WeakKeyDictionary()

    def __init__(self, carrier: Any):
        self.carrier = carrier
        self.camera = carrier.eye_in_hand
        self.measurement = UavPoseMeasurement(carrier.arm_kinematics, self.camera.K)
        self.last: UavObservation | None = None  # the latest frame looked at
        self.last_seen: UavObservation | None = None  # the latest frame in which the UAV was measured

    @classmethod
    def of(cls, carrier: Any) -> EyeInHandObserver:
        """The observer shared by every skill looking through ``carrier``'s eye-in-hand camera."""
        robot = getattr(carrier, "robot", carrier)  # a CommandPort passes its robot
        observer = cls._shared.get(robot)
        if observer is None:
            observer = cls._shared[robot] = cls(robot)
        return observer

    def observe(self) -> UavObservation | None:
        """The observation of the camera's latest frame (measured now if it is new); ``None`` before any frame."""
        reading = self.camera.read()
        if reading is None:
            return None
        if self.last is not None and self.last.stamp == reading.stamp:
            return self.last
        pose = self.measurement.measure(reading.data.rgb, self.carrier.joint_positions())
        self.last = UavObservation(reading.stamp, pose)
        if pose is not None:
            self.last_seen = self.last
        return self.last

    def latest_seen(self, now: float, max_age: float) -> UavPose | None:
        """The most recent measured UAV pose if it is at most ``max_age`` s old at ``now``, else ``None``."""
        self.observe()
        if self.last_seen is None or now - self.last_seen.stamp > max_age + 1e-9:
            return None
        return self.last_seen.pose


def position_spread(positions: list[np.ndarray]) -> float:
    """Largest distance (m) of a set of positions from their mean (0 for fewer than two)."""
    if len(positions) < 2:
        return 0.0
    p = np.asarray(positions)
    return float(np.max(np.linalg.norm(p - p.mean(axis=0), axis=1)))
