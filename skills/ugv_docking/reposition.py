"""The independent docking's repositioning: onto the entry line from one view of the benchmark (Experiment III).

With the mother static (the independent docking, §4.2), nothing turns the
entrance towards the child: the child must come onto the entry line itself.
Seen obliquely the benchmark is lost long before eq. (7) can hold (the 8-px
checks of §3.1 fail at |k_h| ≳ 0.5), so steering onto the line by k_h while
matching stalls (the child keeps losing and relinking the benchmark). This
skill instead estimates the entry line once from one view —
E = (x_e, y_e) from (u_h, v_h) by eqs. (1) and (4), α from k_h by eq. (6)
(:mod:`.geometry`), with the camera's own intrinsics and its mount (θ, h of
Table 1), in a frame taken at rest — and drives blind on wheel odometry to a point of the line
``distance`` before E, then turns to face along the entry direction, where
the benchmark is back in view nearly aligned for the matching to finish.

The paper gives no law for its independent baseline; this is ours (named
among the departures in ``docs/ugv_docking.md``). Metres, radians, the
child's odometry frame.
"""

from __future__ import annotations

import math

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.trees.skill import NodeParams

from ..generic import unicycle_command
from .child import _ChildSkill
from .conditions import LOST_FRAMES
from .features import BenchmarkFeatures
from .geometry import entry_angle, ground_point
from .precision import PrecisionParams

CAMERA_TILT = PrecisionParams().theta  # θ, Table 1: the child_ugv's camera mount (rad)
BORDER_HEIGHT = PrecisionParams().h  # h, Table 1: H_GS above the camera (m)


def entry_waypoint(features: BenchmarkFeatures, K: np.ndarray, position: np.ndarray, yaw: float,
                   camera_forward: float, distance: float, h: float = BORDER_HEIGHT, theta: float = CAMERA_TILT,
                   ) -> tuple[np.ndarray, float]:
    """The point of the entry line ``distance`` (m) before E, and the entry direction (rad), in the odometry frame.

    ``position`` (m) and ``yaw`` (rad) are the child's base pose on odometry when the frame was taken, ``K``
    the camera's intrinsics, ``camera_forward`` (m) how far ahead of the base centre the camera sits. In
    {R} (X right, Y ahead, origin under the camera) E = (x_e, y_e) and the entry direction is (cos α, sin α).
    """
    x_e, y_e = ground_point(features.u_h, features.v_h, h, theta, K[0, 0], K[1, 1], K[0, 2], K[1, 2])
    alpha = entry_angle(features.k_h, x_e, y_e, h, theta, K[0, 0], K[1, 1])
    forward = np.array([math.cos(yaw), math.sin(yaw)])
    right = np.array([forward[1], -forward[0]])
    to_world = np.column_stack([right, forward])  # {R} axes in the odometry frame
    origin = np.asarray(position[:2], dtype=float) + camera_forward * forward
    e = origin + to_world @ np.array([x_e, y_e])
    direction = to_world @ np.array([math.cos(alpha), math.sin(alpha)])
    return e - distance * direction, math.atan2(direction[1], direction[0])


class ChildReposition(_ChildSkill["ChildReposition.Params"]):
    """Independent docking: drive on odometry onto the entry line estimated from the held features, facing in."""

    class Params(NodeParams):
        distance: float = Field(0.6, gt=0.2, le=2.0)
        """How far before E (m) the child stops on the entry line (the benchmark in view, aligned, for matching)."""
        speed: float = Field(0.12, gt=0.0, le=0.3)
        """Forward speed limit (m/s)."""
        turn_rate: float = Field(0.6, gt=0.0, le=1.5)
        """Turn-rate limit (rad/s)."""
        tolerance: float = Field(0.03, gt=0.0)
        """Distance (m, odometry) at which the point counts as reached."""
        heading_tolerance: float = Field(math.radians(3.0), gt=0.0)
        """Heading error (rad) at which the child counts as facing along the entry direction."""
        settle: float = Field(0.4, ge=0.0, le=5.0)
        """Stand still this long (s) first: the estimate is made from a frame taken at rest, after the turn of
        linking has stopped (a frame 0.1 s late while turning at 0.6 rad/s is 3° off: 8 cm at 1.5 m)."""
        frames: int = Field(LOST_FRAMES, ge=1)
        """Give up when this many successive frames taken at rest missed the benchmark."""

    def start(self) -> None:
        self.started = self.now
        self.waypoint: np.ndarray | None = None
        self.entry_heading = 0.0
        self.at_waypoint = False

    def plan(self) -> bool:
        """Estimate the entry line from the newest frame, taken at rest, and the odometry; False without it."""
        view = self.view()
        reading = self.robot.sensor("camera").read()
        if view.current is None or reading is None or view.stamp < self.started + self.params.settle:
            return False
        estimate = self.robot.estimate()
        camera_forward = float(self.robot.link_offset("camera_link")[0][0])
        self.waypoint, self.entry_heading = entry_waypoint(
            view.current, reading.data.K, np.asarray(estimate.position), float(estimate.yaw), camera_forward,
            self.params.distance)
        return True

    def step(self) -> Status:
        p = self.params
        if self.waypoint is None and not self.plan():
            self.robot.stop()
            view = self.view()
            if view.stamp >= self.started + p.settle and view.lost_frames >= p.frames:
                self.feedback_message = "no features to estimate the entry line from"
                return Status.FAILURE
            self.feedback_message = "standing still for a frame at rest"
            return Status.RUNNING
        assert self.waypoint is not None
        estimate = self.robot.estimate()
        position = np.asarray(estimate.position[:2])
        remaining = float(np.linalg.norm(self.waypoint - position))
        if not self.at_waypoint and remaining > p.tolerance:
            self.robot.drive(*unicycle_command(position, float(estimate.yaw), self.waypoint, p.speed, p.turn_rate,
                                               2.0))
            self.feedback_message = f"to the entry line: {remaining:.2f} m"
            return Status.RUNNING
        self.at_waypoint = True
        error = math.remainder(self.entry_heading - float(estimate.yaw), math.tau)
        if abs(error) <= p.heading_tolerance:
            self.robot.stop()
            self.feedback_message = "on the entry line, facing in"
            return Status.SUCCESS
        self.robot.drive(0.0, max(-p.turn_rate, min(p.turn_rate, 2.0 * error)))
        self.feedback_message = f"turning to the entry direction: {math.degrees(error):+.0f}°"
        return Status.RUNNING
