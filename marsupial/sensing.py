"""Where a robot's sensors are, from its own model and estimate: mounts, scan echoes, camera poses (numpy only).

Skills and conditions know a sensor's pose only as a robot's computer does:
the mount its URDF declares (:meth:`~marsupial.api.views.RobotView.link_offset`
plus the sensor's ``offset`` and optical/sensor rotation), composed with the
robot's onboard estimate. Frames:

- *body*: the frame the robot's estimate describes — ``base_footprint`` for
  a ground robot (:class:`~marsupial.api.views.WheeledView`), the
  base link for a quadrotor;
- *nav*: the estimate's navigation frame (``odom`` / ``map``).

Positions m, rotations 3×3 (columns: the mounted frame's axes).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from typing import Any

import numpy as np

from marsupial.api.capabilities import HasBase


def sensor_mount(
    robot: Any, link: str, offset: Sequence[float] = (0.0, 0.0, 0.0), R_link_sensor: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Position (m) and rotation of a sensor frame in ``robot``'s body frame, from its URDF.

    ``link`` is the URDF link carrying the sensor, ``offset`` (m, link frame)
    and ``R_link_sensor`` the sensor's fixed mount on it (a camera's
    ``R_link_optical``). Ground robots' estimates describe ``base_footprint``,
    so the mount is re-expressed there.
    """
    p_link, R_link = robot.link_offset(link)
    R_ls = np.eye(3) if R_link_sensor is None else np.asarray(R_link_sensor, dtype=float)
    p = p_link + R_link @ np.asarray(offset, dtype=float)
    R = R_link @ R_ls
    if robot.provides(HasBase):  # a wheeled robot: its estimate is of base_footprint
        p_fp, R_fp = robot.link_offset("base_footprint")
        p, R = R_fp.T @ (p - p_fp), R_fp.T @ R
    return p, R


def body_pose(estimate: Any, t: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The estimated body position (m) and ``R_nav_body`` at ``t`` (s; default: the estimate's stamp).

    Propagated from the estimate with its velocity and yaw rate (constant
    over ``t − stamp``), e.g. back to the stamp of a late camera frame.
    """
    R = estimate.rotation
    p = np.asarray(estimate.position, dtype=float)
    dt = 0.0 if t is None else t - estimate.stamp
    if dt == 0.0:
        return p, R
    yaw = float((R @ np.asarray(estimate.angular_velocity, dtype=float))[2]) * dt  # body rates → about nav z
    c, s = math.cos(yaw), math.sin(yaw)
    R_yaw = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return p + np.asarray(estimate.velocity, dtype=float) * dt, R_yaw @ R


class EstimateHistory:
    """A robot's own recent estimates (the last ``window`` s), to place a late sample with the estimate of its stamp.

    Sensors deliver samples late (a camera's video latency; a sample taken
    at an earlier read; a team member's telemetry over the link): :meth:`at`
    gives the body pose at such a stamp, propagated (:func:`body_pose`) from
    the newest kept estimate not later than it (the oldest one for a stamp
    before the window).
    """

    def __init__(self, window: float = 2.0):
        self.window = window
        self.samples: deque[Any] = deque()

    def add(self, estimate: Any | None) -> None:
        """Keep ``estimate`` (ignored if ``None`` or not newer than the last one).

        Forget those older than the window.
        """
        if estimate is None or (self.samples and estimate.stamp <= self.samples[-1].stamp):
            return
        self.samples.append(estimate)
        while len(self.samples) > 1 and self.samples[1].stamp <= estimate.stamp - self.window:
            self.samples.popleft()

    @property
    def latest(self) -> Any | None:
        """The newest estimate kept (``None``: none yet)."""
        return self.samples[-1] if self.samples else None

    def at(self, t: float) -> tuple[np.ndarray, np.ndarray] | None:
        """The estimated body position (m) and ``R_nav_body`` at ``t`` (s); ``None`` before any estimate."""
        if not self.samples:
            return None
        chosen = self.samples[0]
        for estimate in reversed(self.samples):
            if estimate.stamp <= t:
                chosen = estimate
                break
        return body_pose(chosen, t)


def in_nav_frame(
    body: tuple[np.ndarray, np.ndarray], mount: tuple[np.ndarray, np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """Position (m) and rotation in the navigation frame of a frame mounted on a body.

    ``body`` is the body's pose in the navigation frame, ``mount`` the frame's pose in the body frame.
    """
    p_nav_body, R_nav_body = body
    return p_nav_body + R_nav_body @ mount[0], R_nav_body @ mount[1]


def scan_in_body(scan: Any, mount: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """``(m, 3)`` echoes (m, body frame) of a planar LiDAR scan (its ranges and beam angles) mounted at ``mount``."""
    hit = np.isfinite(scan.ranges)
    r, a = scan.ranges[hit].astype(float), scan.angles[hit].astype(float)
    p_sensor = np.column_stack((r * np.cos(a), r * np.sin(a), np.zeros(len(r))))
    return mount[0] + p_sensor @ mount[1].T
