"""UAV pose control in the manipulator frame M (Narváez §IV-A, Fig. 4): the UAV holds a pose relative to the carrier.

"The UAV pose is being controlled within M coordinates, which allows it to
be in a constant pose with respect to the mobile manipulator" (§IV-A): while
the arm tracks the UAV and closes in during contact, the UAV keeps a pose
above Part A that the arm can reach, whatever the carrier does.

Control law (world frame, velocity commands to the UAV's autopilot): the
target point of M moves with the carrier as a rigid body, so its velocity
``v_target_W = v_base + ω × (p_target_W − p_base)`` is fed forward, and the
position error measured in M is fed back::

    v_W = v_target_W + R_W_M · sat(k_p · (p_target_M − p_uav_M), v_max)
    yaw_rate = ω_z + k_yaw · wrap(yaw_target_M − yaw_uav_M)

``p_uav_M`` comes either from the world (``source: ground_truth``: the UAV's
and the carrier's own state) or from the eye-in-hand measurement P_Q^M of
eq. (1) (``source: measured``); without a fresh measurement only the feed-
forward acts, so the UAV keeps moving with the carrier until the marker is
seen again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.trees.skill import NodeParams, Skill
from marsupial.world.robots.base import rotation_matrix, yaw_of

from .observer import EyeInHandObserver
from .team import carrier_port

PART_A_LINK = "part_a"
PART_B_LINK = "part_b"
HOLD_HEIGHT = 0.30  # m: Part B above Part A of docking_ready; within its 0.35 m upward range (contact, §IV-B)


@dataclass(frozen=True)
class HoldGains:
    """Gains of the hold law: ``kp`` (1/s) on the position error, relative speed cap ``max_speed`` (m/s), ``k_yaw`` (1/s)."""

    kp: float = 1.5
    max_speed: float = 0.5
    k_yaw: float = 1.5


@dataclass(frozen=True)
class CarrierFrame:
    """Frame M of the carrier now, and how it moves (world frame).

    Attributes:
        p_M_W: origin of M (m); R_W_M: rotation of M in the world.
        p_base_W, v_base_W, w_base_W: the carrier base's position (m), linear (m/s) and angular (rad/s) velocity.
    """

    p_M_W: np.ndarray
    R_W_M: np.ndarray
    p_base_W: np.ndarray
    v_base_W: np.ndarray
    w_base_W: np.ndarray

    @classmethod
    def of(cls, carrier: Any) -> CarrierFrame:
        """Frame M (``arm_base``) and base motion of ``carrier`` (robot or command port) now."""
        p_M, q_M = carrier.arm_base_pose()
        p_base, _ = carrier.pose()
        v, w = carrier.velocity()
        return cls(np.asarray(p_M), rotation_matrix(q_M), np.asarray(p_base), np.asarray(v), np.asarray(w))

    @property
    def yaw(self) -> float:
        """Heading of M about world z (rad)."""
        return math.atan2(self.R_W_M[1, 0], self.R_W_M[0, 0])

    def to_world(self, p_M: np.ndarray) -> np.ndarray:
        """A point of M in the world frame (m)."""
        return self.p_M_W + self.R_W_M @ p_M

    def to_M(self, p_W: np.ndarray) -> np.ndarray:
        """A world point in frame M (m)."""
        return self.R_W_M.T @ (np.asarray(p_W) - self.p_M_W)

    def velocity_of(self, p_W: np.ndarray) -> np.ndarray:
        """World velocity (m/s) of the point ``p_W`` carried rigidly by the carrier."""
        return self.v_base_W + np.cross(self.w_base_W, np.asarray(p_W) - self.p_base_W)


def hold_command(
    p_uav_M: np.ndarray | None,
    yaw_uav_M: float | None,
    p_target_M: np.ndarray,
    yaw_target_M: float,
    frame: CarrierFrame,
    gains: HoldGains = HoldGains(),
) -> tuple[np.ndarray, float]:
    """World velocity (m/s) and yaw rate (rad/s) that bring the UAV to ``p_target_M``, ``yaw_target_M`` in M.

    ``p_uav_M``/``yaw_uav_M`` ``None`` (no measurement): feed-forward of the
    carrier's motion only.
    """
    v_W = frame.velocity_of(frame.to_world(p_target_M))
    yaw_rate = float(frame.w_base_W[2])
    if p_uav_M is not None:
        correction = gains.kp * (np.asarray(p_target_M) - p_uav_M)
        speed = float(np.linalg.norm(correction))
        if speed > gains.max_speed:
            correction *= gains.max_speed / speed
        v_W = v_W + frame.R_W_M @ correction
    if yaw_uav_M is not None:
        yaw_rate += gains.k_yaw * math.remainder(yaw_target_M - yaw_uav_M, math.tau)
    return v_W, yaw_rate


def part_b_offset(uav: Any) -> np.ndarray:
    """Position (m) of the UAV's Part B mating face in its base frame Q."""
    p_Q, q_Q = uav.pose()
    p_B, _ = uav.link_pose(PART_B_LINK)
    return rotation_matrix(q_Q).T @ (np.asarray(p_B) - p_Q)


def target_above_part_a(carrier: Any, uav: Any, height: float, arm_pose: str, yaw_M: float = 0.0) -> np.ndarray:
    """UAV base position in M (m) that puts its Part B ``height`` m above Part A, the arm in ``arm_pose``.

    The UAV is level with heading ``yaw_M`` in M (0: facing the carrier's
    forward axis); Part A's pose comes from the arm's forward kinematics.
    """
    p_A_M, R_M_A = carrier.arm_kinematics.forward(carrier.arm_pose(arm_pose), PART_A_LINK)
    R_M_Q = np.array([[math.cos(yaw_M), -math.sin(yaw_M), 0.0], [math.sin(yaw_M), math.cos(yaw_M), 0.0], [0.0, 0.0, 1.0]])
    return p_A_M + height * R_M_A[:, 2] - R_M_Q @ part_b_offset(uav)


def uav_in_M(uav: Any, frame: CarrierFrame) -> tuple[np.ndarray, float]:
    """The UAV's own state estimate expressed in M: base position (m) and heading (rad)."""
    p_W, q_W = uav.pose()
    return frame.to_M(p_W), math.remainder(yaw_of(q_W) - frame.yaw, math.tau)


class RelativeHold(Skill):
    """Hold the UAV at a pose in the carrier's manipulator frame M (above Part A), from true or measured poses."""

    class Params(NodeParams):
        carrier: str = "carrier"
        """Team member carrying the arm (a mobile_manipulator); M is its ``arm_base`` frame."""
        source: Literal["measured", "ground_truth"] = "measured"
        """``measured``: P_Q^M from the eye-in-hand camera, eq. (1) (§IV-A); ``ground_truth``: the robots' own state."""
        height: float = Field(HOLD_HEIGHT, gt=0.0)
        """Height (m) of Part B above Part A of ``arm_pose`` (0.30 m: within the arm's upward range for contact)."""
        arm_pose: str = "docking_ready"
        """Arm pose whose Part A the target is above (a name of the carrier's arm poses)."""
        target_M: tuple[float, float, float] | None = None
        """UAV base position in M (m), instead of ``height`` above Part A."""
        yaw_M: float = 0.0
        """UAV heading in M (rad); 0 aligns Part B with Part A's approach."""
        kp: float = Field(HoldGains.kp, gt=0.0)
        """Position gain (1/s)."""
        max_speed: float = Field(HoldGains.max_speed, gt=0.0)
        """Largest speed relative to the carrier (m/s)."""
        max_age: float = Field(0.3, gt=0.0)
        """Oldest measurement used (s); older: feed-forward only."""
        seconds: float | None = Field(None, gt=0.0)
        """Succeed after holding this long (simulated s); none: hold until stopped."""

    robot_kinds = ("Quadrotor",)
    writes = ("{robot}/hold_error",)

    def start(self) -> None:
        self.carrier = carrier_port(self, self.params.carrier)
        if self.params.target_M is not None:
            self.p_target_M = np.asarray(self.params.target_M, dtype=float)
        else:
            self.p_target_M = target_above_part_a(
                self.carrier, self.robot, self.params.height, self.params.arm_pose, self.params.yaw_M
            )
        self.gains = HoldGains(self.params.kp, self.params.max_speed)
        self.observer = EyeInHandObserver.of(self.carrier) if self.params.source == "measured" else None
        self.until = None if self.params.seconds is None else self.world.now + self.params.seconds

    def step(self) -> Status:
        if self.robot.docked or not self.robot.motors_on:
            self.feedback_message = f"{self.robot_name} is not flying"
            return Status.FAILURE
        frame = CarrierFrame.of(self.carrier)
        if self.observer is None:
            p_uav_M, yaw_uav_M = uav_in_M(self.robot, frame)
        else:
            pose = self.observer.latest_seen(self.world.now, self.params.max_age)
            p_uav_M = None if pose is None else pose.p_uav_M
            yaw_uav_M = None if pose is None else math.atan2(pose.T_M_Q[1, 0], pose.T_M_Q[0, 0])
        v_W, yaw_rate = hold_command(p_uav_M, yaw_uav_M, self.p_target_M, self.params.yaw_M, frame, self.gains)
        self.robot.command_velocity(*v_W, yaw_rate, frame="world")
        if p_uav_M is None:
            self.feedback_message = "no fresh measurement: moving with the carrier"
        else:
            error = float(np.linalg.norm(self.p_target_M - p_uav_M))
            self.write(f"{self.robot_name}/hold_error", error)
            self.context.metric("hold_error", error, robot=self.robot_name)
            self.feedback_message = f"{error:.3f} m from the hold pose in M"
        if self.until is not None and self.world.now + 1e-9 >= self.until:
            return Status.SUCCESS
        return Status.RUNNING
