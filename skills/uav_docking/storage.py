"""Storage and deployment of the UAV on the carrier's arm (Narváez §IV-B, §IV-C, §V-A).

``store`` (on the carrier): "after the docking process is finalized ... the
manipulator stores the aircraft chassis in a secure position for storage
and transportation" (§IV-B, Fig. 3). The arm carries the locked UAV to the
``storage`` pose, over the rear deck above the LiDAR's scan plane and behind
the front RGB-D camera, so the ground sensors keep their fields of view; the
docking device charges the UAV meanwhile (12.6 V / 3.5 A charger, §V-A).

``deploy`` (on the UAV): the reverse. The arm raises the UAV, its motors
start, and "the docking device quickly releases the Part B in the adequate
moment when the UAV motors have enough thrust to hold the flight" (§IV-C):
the levers open only once the rotor thrust has reached the UAV's weight.
At the release the carrier hands the UAV's estimator its pose, as a real
carrier sends it over its link: the carrier's own estimate ∘ the forward
kinematics of Part A (encoders) ∘ the UAV's pose on Part A
(``uav.reset_estimate``). The UAV then climbs straight up relative to the
carrier (it moves with the carrier as it climbs, so Part A never sweeps into
it) to a safe height above Part A, on the two robots' estimates re-anchored
by the eye-in-hand camera (the bundle's contact tag is in view from the
release on), and the arm folds back for driving.

Both keep their arm targets fresh every tick (one command per tick), so a
node that takes the arm over in the same tick as they stop keeps it.
"""

from __future__ import annotations

from enum import Enum
from typing import Annotated

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.api.capabilities import Carrier, Rotorcraft
from marsupial.geometry import yaw_of_rotation
from marsupial.trees.milestones import milestone
from marsupial.trees.phases import Phased, Transition, go, phase_event
from marsupial.trees.skill import NodeParams, Skill, TeamMember

from ..common.carrier_frame import CarrierFrame
from .pose import invert
from .relative_hold import PART_A_LINK, HoldGains, command_hold, part_b_transform, relative_pose_of
from .relative_pose import RelativePose, RelativeState
from .selection import rot_z
from .team import DOCKING_FLAG, PART_B_YAW, UAV_STORED, CarrierName, carrier_port

ARM_TOLERANCE = 0.02  # rad: every joint this close to its target counts as arrived
GRAVITY = 9.81  # m/s², standard gravity (the weight the rotor thrust must hold before the release)


class Store(Skill["Store.Params"]):
    """Carry the UAV locked on Part A to the storage pose (ground sensors clear); it charges while stored."""

    class Params(NodeParams):
        uav: Annotated[str, TeamMember(Rotorcraft)] = "uav"
        """The UAV being stored (named in the ``stored`` event)."""
        arm_pose: str = "storage"
        """Arm pose that stores the UAV (a name of the carrier's arm poses).

        Over the rear deck, sensors clear (§IV-B).
        """
        tolerance: float = Field(ARM_TOLERANCE, gt=0.0)
        """Largest joint error (rad) at which the arm has arrived."""

    robot_kinds = (Carrier,)
    claims = ("arm",)
    writes = (f"{{robot}}/{UAV_STORED}", f"{{robot}}/{DOCKING_FLAG}")

    def start(self) -> None:
        self.q_storage = self.robot.arm_pose(self.params.arm_pose)

    def step(self) -> Status:
        device, uav = self.robot.docking, self.params.uav
        if not device.locked:
            self.feedback_message = f"no UAV is locked on {self.robot_name}'s Part A"
            return Status.FAILURE
        self.robot.set_joint_targets(self.q_storage)
        error = float(np.max(np.abs(self.robot.joint_positions() - self.q_storage)))
        self.feedback_message = f"carrying {uav} to '{self.params.arm_pose}': {error:.3f} rad to go"
        if error > self.params.tolerance:
            return Status.RUNNING
        self.write(f"{self.robot_name}/{UAV_STORED}", True)
        self.write(f"{self.robot_name}/{DOCKING_FLAG}", False)
        phase_event(self, "stored", uav=uav, charging=device.charging)
        milestone(self, "stored", robot=uav, detail=f"on {self.robot_name}" + (", charging" if device.charging else ""))
        self.feedback_message = f"{uav} stored, charging: {device.charging}"
        return Status.SUCCESS

    def finish(self, status: Status) -> None:
        if status != Status.SUCCESS:
            self.robot.hold_arm()


class Deploy(Phased, Skill["Deploy.Params"]):
    """Raise the stored UAV, start its motors, release it once its thrust holds its weight, climb clear of the arm."""

    class Params(NodeParams):
        carrier: CarrierName = "carrier"
        """Team member whose Part A holds the UAV (a mobile_manipulator)."""
        arm_pose: str = "docking_ready"
        """Arm pose the UAV is raised to before take-off (Part A up over the base, clear of the carrier)."""
        clearance: float = Field(0.6, gt=0.0)
        """Height (m) above the release point, in M, at which the UAV is clear of the arm (chosen)."""
        climb_speed: float = Field(0.5, gt=0.0, le=1.0)
        """Climb speed relative to the carrier (m/s; ≤ 1 m/s vertical limit, §V-B)."""
        spin_up_timeout: float = Field(3.0, gt=0.0)
        """Fail if the thrust has not reached the weight this long after the motors started (s)."""
        then_arm: str | None = "stowed"
        """Arm pose once the UAV is clear (``stowed`` for driving); none: the arm stays raised."""
        tolerance: float = Field(ARM_TOLERANCE, gt=0.0)
        """Largest joint error (rad) at which the arm has arrived."""

    class Phase(Enum):
        """Deployment phases (their ``state_change`` events: ``raise``, ``spin_up``, ``released``)."""

        RAISE = "raise"
        """The arm raises the locked UAV to ``arm_pose``."""
        SPIN_UP = "spin_up"
        """The motors run; the levers open once the thrust holds the UAV's weight."""
        CLIMB = "climb"
        """Released: the UAV climbs ``clearance`` above the release point, moving with the carrier."""

    robot_kinds = (Rotorcraft,)
    sensors = ("{carrier}/eye_in_hand",)
    claims = ("rotors", "{carrier}/arm", "{carrier}/docking")
    runs_on = "carrier"  # Narváez §V-B-2: computed on the carrier, sent to the UAV over Wi-Fi
    reads = (f"{{carrier}}/{PART_B_YAW}",)
    writes = (f"{{carrier}}/{DOCKING_FLAG}", f"{{carrier}}/{UAV_STORED}", f"{{carrier}}/{PART_B_YAW}")
    phase: Phase

    def start(self) -> None:
        self.carrier = carrier_port(self, self.params.carrier)
        self.q_raised = self.carrier.arm_pose(self.params.arm_pose)
        self.spin_up_deadline = 0.0
        self.p_clear_M = np.zeros(3)
        self.yaw_clear_M = 0.0
        self.gains = HoldGains(max_speed=self.params.climb_speed)
        self.T_Q_B = part_b_transform(self.robot)
        self.relative: RelativePose | None = None  # from the hand-over on
        self.write(f"{self.params.carrier}/{DOCKING_FLAG}", True)
        self.enter(go(self.Phase.RAISE))

    def step(self) -> Status:
        uav = self.robot
        if self.phase is not self.Phase.CLIMB and not (self.carrier.docking.locked and uav.docked):
            self.feedback_message = f"{self.robot_name} is not locked on {self.params.carrier}'s Part A"
            return Status.FAILURE
        return self.step_phase()

    def _step_raise(self) -> Status | Transition:
        self.carrier.set_joint_targets(self.q_raised)
        error = float(np.max(np.abs(self.carrier.joint_positions() - self.q_raised)))
        self.feedback_message = f"raising the arm: {error:.3f} rad to go"
        if error > self.params.tolerance:
            return Status.RUNNING
        self.robot.set_motors(True)
        self.spin_up_deadline = self.now + self.params.spin_up_timeout
        return go(self.Phase.SPIN_UP)

    def _step_spin_up(self) -> Status | Transition:
        uav = self.robot
        self.carrier.set_joint_targets(self.q_raised)
        weight = uav.mass * GRAVITY
        self.feedback_message = f"motors spinning up: thrust {uav.thrust:.2f} N of {weight:.2f} N"
        if uav.thrust >= weight:
            T_M_Q = self.T_M_Q_release = self.hand_over()
            self.p_clear_M = T_M_Q[:3, 3] + np.array([0.0, 0.0, self.params.clearance])
            self.yaw_clear_M = yaw_of_rotation(T_M_Q[:3, :3])
            # the estimates after the hand-over
            self.relative = relative_pose_of(self, self.carrier, since=self.now)
            self.carrier.docking.release()
            self.write(f"{self.params.carrier}/{UAV_STORED}", False)
            self.write(f"{self.params.carrier}/{PART_B_YAW}", None)  # released: no UAV on Part A
            return go(self.Phase.CLIMB, event="released", at_once=True, thrust=uav.thrust, weight=weight)
        if self.now >= self.spin_up_deadline:
            self.feedback_message = f"thrust {uav.thrust:.2f} N never reached the weight {weight:.2f} N"
            return Status.FAILURE
        return Status.RUNNING

    def hand_over(self) -> np.ndarray:
        """Reset the UAV's estimator to its pose at release, as the carrier knows it; returns that pose in M (4×4).

        P_Q^M = F(q) of Part A (encoders) ∘ the UAV on Part A: Part B's face
        centred on Part A's (§IV-C) at the heading the contact phase caught it
        with (``<carrier>/part_b_yaw``); in the carrier's navigation frame
        through the carrier's own estimate.
        """
        T_A_B = np.eye(4)
        T_A_B[:3, :3] = rot_z(float(self.read(f"{self.params.carrier}/{PART_B_YAW}") or 0.0))
        T_M_A = self.carrier.arm_kinematics.transform(self.carrier.joint_positions(), PART_A_LINK)
        T_M_Q = T_M_A @ T_A_B @ invert(self.T_Q_B)
        frame = CarrierFrame.of(self.carrier)
        p_N = frame.to_world(T_M_Q[:3, 3])
        yaw_N = frame.yaw + yaw_of_rotation(T_M_Q[:3, :3])
        self.robot.reset_estimate(p_N, yaw_N)
        return T_M_Q

    def _step_climb(self) -> Status:
        """Climb to the clearance height above the release point, moving with the carrier (on the estimates)."""
        assert self.relative is not None, "the climb follows the hand-over"
        state = self.relative.update(self.now)
        if state.T_M_Q is None:  # no telemetry since the hand-over yet: the UAV is where it was released
            state = RelativeState(self.now, self.T_M_Q_release)
        error = command_hold(
            self.robot, state, self.p_clear_M, self.yaw_clear_M, CarrierFrame.of(self.carrier), self.gains
        )
        if error is None:
            self.feedback_message = "waiting for the UAV's estimate over the team link"
            return Status.RUNNING
        self.feedback_message = f"climbing clear of the arm: {error:.2f} m to go"
        if error > 0.05:
            return Status.RUNNING
        phase_event(self, "clear", height_above_release=self.params.clearance)
        milestone(self, "deployed", detail=f"from {self.params.carrier}")
        return Status.SUCCESS

    def finish(self, status: Status) -> None:
        self.write(f"{self.params.carrier}/{DOCKING_FLAG}", False)
        if status == Status.SUCCESS:
            if self.params.then_arm is not None:
                self.carrier.set_joint_targets(self.params.then_arm)
            self.leave_safe()
            return
        if self.phase is not self.Phase.CLIMB:
            self.robot.set_motors(False)  # still locked: stop the rotors again
        self.carrier.hold_arm()
        self.leave_safe()
