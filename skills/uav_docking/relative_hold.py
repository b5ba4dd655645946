"""UAV pose control in the manipulator frame M (Narváez §IV-A, Fig. 4): the UAV holds a pose relative to the carrier.

"The UAV pose is being controlled within M coordinates, which allows it to
be in a constant pose with respect to the mobile manipulator" (§IV-A): while
the arm tracks the UAV and closes in during contact, the UAV keeps a pose
above Part A that the arm can reach, whatever the carrier does.

Control law: the target point of M moves with the carrier as a rigid body,
so its velocity ``v_target = v_base + ω × (p_target − p_base)`` (from the
carrier's own estimate, :class:`~..common.carrier_frame.CarrierFrame`) is fed forward, and the
position error measured in M is fed back::

    v = v_target + R_N_M · sat(k_p · (p_target_M − p_uav_M), v_max)
    yaw_rate = ω_z + k_yaw · wrap(yaw_target_M − yaw_uav_M)

The velocity is sent in the UAV's body (heading) frame, rotated by the UAV's
heading relative to M (:func:`body_velocity`): a frame the UAV knows,
whatever the drift between its odometry frame and the carrier's navigation
frame. ``p_uav_M`` is the UAV pose in M of :mod:`.relative_pose` (the two
robots' estimates over the team link, re-anchored by the eye-in-hand
measurement P_Q^M of eq. (1)). The autopilot flies the command on the UAV's
velocity estimate, which the carrier's vision fixes (:mod:`.relative_pose`)
hold in the carrier's navigation frame, the frame of the feed-forward.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.api.capabilities import Rotorcraft
from marsupial.geometry import rot_z, transform, yaw_of_rotation
from marsupial.trees.metrics import MetricSpec
from marsupial.trees.skill import NodeParams, Skill

from ..common.carrier_frame import CarrierFrame
from .observer import EyeInHandObserver
from .relative_pose import RelativePose, RelativeState
from .team import CarrierName, carrier_port

PART_A_LINK = "part_a"
PART_B_LINK = "part_b"
HOLD_HEIGHT = 0.30  # m: Part B above Part A of docking_ready; within its 0.35 m upward range (contact, §IV-B)


@dataclass(frozen=True)
class HoldGains:
    """Gains of the hold law.

    ``kp`` (1/s) on the position error, relative speed cap ``max_speed`` (m/s), ``k_yaw`` (1/s).
    """

    kp: float = 1.5
    max_speed: float = 0.5
    k_yaw: float = 1.5


def hold_command(
    p_uav_M: np.ndarray | None,
    yaw_uav_M: float | None,
    p_target_M: np.ndarray,
    yaw_target_M: float,
    frame: CarrierFrame,
    gains: HoldGains = HoldGains(),
) -> tuple[np.ndarray, float]:
    """Velocity (m/s, in M's axes) and yaw rate (rad/s) that bring the UAV to ``p_target_M``, ``yaw_target_M`` in M.

    ``p_uav_M``/``yaw_uav_M`` ``None`` (no estimate): feed-forward of the
    carrier's motion only.
    """
    v_M = frame.R_W_M.T @ frame.velocity_of(frame.to_world(p_target_M))
    yaw_rate = float(frame.w_base_W[2])
    if p_uav_M is not None:
        correction = gains.kp * (np.asarray(p_target_M) - p_uav_M)
        speed = float(np.linalg.norm(correction))
        if speed > gains.max_speed:
            correction *= gains.max_speed / speed
        v_M = v_M + correction
    if yaw_uav_M is not None:
        yaw_rate += gains.k_yaw * math.remainder(yaw_target_M - yaw_uav_M, math.tau)
    return v_M, yaw_rate


def body_velocity(v_M: np.ndarray, yaw_uav_M: float) -> np.ndarray:
    """A velocity in M's axes in the UAV's heading frame (M level: a turn by the UAV's heading in M)."""
    return rot_z(-yaw_uav_M) @ np.asarray(v_M)


def part_b_offset(uav: Any) -> np.ndarray:
    """Position (m) of the UAV's Part B mating face in its base frame Q (the UAV's URDF)."""
    return uav.link_offset(PART_B_LINK)[0]


def part_b_transform(uav: Any) -> np.ndarray:
    """T_Q_B: Part B's mating-face frame in the UAV base frame Q (4×4, the UAV's URDF)."""
    return transform(*uav.link_offset(PART_B_LINK))


def target_above_part_a(carrier: Any, uav: Any, height: float, arm_pose: str, yaw_M: float = 0.0) -> np.ndarray:
    """UAV base position in M (m) that puts its Part B ``height`` m above Part A, the arm in ``arm_pose``.

    The UAV is level with heading ``yaw_M`` in M (0: facing the carrier's
    forward axis); Part A's pose comes from the arm's forward kinematics.
    """
    p_A_M, R_M_A = carrier.arm_kinematics.forward(carrier.arm_pose(arm_pose), PART_A_LINK)
    return p_A_M + height * R_M_A[:, 2] - rot_z(yaw_M) @ part_b_offset(uav)


def command_hold(
    uav: Any, state: RelativeState, p_target_M: np.ndarray, yaw_target_M: float, frame: CarrierFrame, gains: HoldGains
) -> float | None:
    """Send the hold command to ``uav`` (body frame) from the relative state.

    Returns the distance (m) to the target, ``None`` without a pose.

    The estimated drift rate of the UAV's odometry (``state.drift_M``) is
    taken off the command: the autopilot tracks the command on its own,
    biased velocity estimate. Without a pose the UAV hovers (its autopilot
    holds its own estimate).
    """
    if state.T_M_Q is None:
        uav.hover()
        return None
    p_uav_M, yaw_uav_M = state.T_M_Q[:3, 3], yaw_of_rotation(state.T_M_Q[:3, :3])
    v_M, yaw_rate = hold_command(p_uav_M, yaw_uav_M, p_target_M, yaw_target_M, frame, gains)
    v_M = v_M - state.drift_M  # the autopilot flies its velocity estimate, biased by the drift rate
    uav.command_velocity(*body_velocity(v_M, yaw_uav_M), yaw_rate, frame="body")
    return float(np.linalg.norm(np.asarray(p_target_M) - p_uav_M))


def relative_pose_of(
    skill: Skill,
    carrier: Any,
    gain: float = 0.8,
    gate: float = 0.03,
    fuse: bool = True,
    since: float = -math.inf,
    vision_fixes: bool = False,
) -> RelativePose:
    """The :class:`~.relative_pose.RelativePose` of ``skill``'s UAV relative to ``carrier``, computed on the carrier.

    ``fuse`` False: the estimates alone (no frame); ``since``: ignore UAV telemetry stamped earlier (s);
    ``vision_fixes``: also send each accepted frame to the UAV's estimator as an external fix.
    """
    observer = EyeInHandObserver.of(skill.context, carrier) if fuse else None
    uav = str(skill.robot_name)  # a UAV skill always has its robot
    return RelativePose(carrier, skill.link_of(carrier.name), uav, observer, gain, gate, since, vision_fixes)


class RelativeHold(Skill["RelativeHold.Params"]):
    """Hold the UAV at a pose in the carrier's manipulator frame M (above Part A).

    The hold acts on the camera-anchored estimate of P_Q^M.
    """

    metrics: ClassVar[tuple[MetricSpec, ...]] = (
        MetricSpec("hold_error", "m", "distance of the UAV from its hold pose in M (estimate)", "max"),
    )

    class Params(NodeParams):
        carrier: CarrierName = "carrier"
        """Team member carrying the arm (a mobile_manipulator); M is its ``arm_base`` frame."""
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
        seconds: float | None = Field(None, gt=0.0)
        """Succeed after holding this long (simulated s); none: hold until stopped."""

    robot_kinds = (Rotorcraft,)
    sensors = ("{carrier}/eye_in_hand",)
    claims = ("rotors",)
    runs_on = "carrier"  # Narváez §V-B-2: computed on the carrier, sent to the UAV over Wi-Fi
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
        self.relative = relative_pose_of(self, self.carrier)
        self.until = None if self.params.seconds is None else self.now + self.params.seconds

    def step(self) -> Status:
        if self.robot.docked or not self.robot.motors_on:
            self.feedback_message = f"{self.robot_name} is not flying"
            return Status.FAILURE
        state = self.relative.update(self.now)
        error = command_hold(
            self.robot, state, self.p_target_M, self.params.yaw_M, CarrierFrame.of(self.carrier), self.gains
        )
        if error is None:
            self.feedback_message = "no estimate of the UAV yet: hovering"
        else:
            self.write(f"{self.robot_name}/hold_error", error)
            self.context.metric("hold_error", error, robot=self.robot_name)
            self.feedback_message = f"{error:.3f} m from the hold pose in M (estimate)"
        if self.until is not None and self.now + 1e-9 >= self.until:
            return Status.SUCCESS
        return Status.RUNNING
