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
The UAV then climbs straight up relative to the carrier (it moves with the
carrier as it climbs, so Part A never sweeps into it) to a safe height
above Part A, and the arm folds back for driving.

Both keep their arm targets fresh every tick (one command per tick), so a
node that takes the arm over in the same tick as they stop keeps it.
"""

from __future__ import annotations

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.trees.skill import NodeParams, Skill
from marsupial.world.world import GRAVITY

from .relative_hold import CarrierFrame, HoldGains, hold_command, uav_in_M
from .team import DOCKING_FLAG, UAV_STORED, carrier_port, phase_event

ARM_TOLERANCE = 0.02  # rad: every joint this close to its target counts as arrived


class Store(Skill):
    """Carry the UAV locked on Part A to the storage pose (ground sensors clear); it charges while stored."""

    class Params(NodeParams):
        arm_pose: str = "storage"
        """Arm pose that stores the UAV (a name of the carrier's arm poses): over the rear deck, sensors clear (§IV-B)."""
        tolerance: float = Field(ARM_TOLERANCE, gt=0.0)
        """Largest joint error (rad) at which the arm has arrived."""

    robot_kinds = ("MobileManipulator",)
    writes = (f"{{robot}}/{UAV_STORED}", f"{{robot}}/{DOCKING_FLAG}")

    def start(self) -> None:
        self.q_storage = self.robot.arm_pose(self.params.arm_pose)

    def step(self) -> Status:
        uav = self.robot.docking.docked
        if uav is None:
            self.feedback_message = f"no UAV is locked on {self.robot_name}'s Part A"
            return Status.FAILURE
        self.robot.set_joint_targets(self.q_storage)
        error = float(np.max(np.abs(self.robot.joint_positions() - self.q_storage)))
        self.feedback_message = f"carrying {uav.name} to '{self.params.arm_pose}': {error:.3f} rad to go"
        if error > self.params.tolerance:
            return Status.RUNNING
        self.write(f"{self.robot_name}/{UAV_STORED}", True)
        self.write(f"{self.robot_name}/{DOCKING_FLAG}", False)
        phase_event(self, "stored", uav=uav.name, charging=bool(uav.charging))
        self.feedback_message = f"{uav.name} stored, charging: {bool(uav.charging)}"
        return Status.SUCCESS

    def finish(self, status: Status) -> None:
        if status != Status.SUCCESS:
            self.robot.hold_arm()


class Deploy(Skill):
    """Raise the stored UAV, start its motors, release it once its thrust holds its weight, climb clear of the arm."""

    class Params(NodeParams):
        carrier: str = "carrier"
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

    robot_kinds = ("Quadrotor",)
    writes = (f"{{carrier}}/{DOCKING_FLAG}", f"{{carrier}}/{UAV_STORED}")

    def start(self) -> None:
        self.carrier = carrier_port(self, self.params.carrier)
        self.q_raised = self.carrier.arm_pose(self.params.arm_pose)
        self.phase = "raise"
        self.spin_up_deadline = 0.0
        self.p_clear_M = np.zeros(3)
        self.gains = HoldGains(max_speed=self.params.climb_speed)
        self.write(f"{self.params.carrier}/{DOCKING_FLAG}", True)
        phase_event(self, "raise")

    def step(self) -> Status:
        uav = self.robot.robot
        if self.phase != "climb" and self.carrier.docking.docked is not uav:
            self.feedback_message = f"{self.robot_name} is not locked on {self.params.carrier}'s Part A"
            return Status.FAILURE
        if self.phase == "raise":
            self.carrier.set_joint_targets(self.q_raised)
            error = float(np.max(np.abs(self.carrier.joint_positions() - self.q_raised)))
            self.feedback_message = f"raising the arm: {error:.3f} rad to go"
            if error <= self.params.tolerance:
                self.robot.set_motors(True)
                self.phase, self.spin_up_deadline = "spin_up", self.world.now + self.params.spin_up_timeout
                phase_event(self, "spin_up")
            return Status.RUNNING
        if self.phase == "spin_up":
            self.carrier.set_joint_targets(self.q_raised)
            weight = uav.mass * GRAVITY
            self.feedback_message = f"motors spinning up: thrust {uav.thrust:.2f} N of {weight:.2f} N"
            if uav.thrust >= weight:
                frame = CarrierFrame.of(self.carrier)
                p_release_M, _ = uav_in_M(self.robot, frame)
                self.p_clear_M = p_release_M + np.array([0.0, 0.0, self.params.clearance])
                self.carrier.docking.release()
                self.write(f"{self.params.carrier}/{UAV_STORED}", False)
                self.phase = "climb"
                phase_event(self, "released", thrust=uav.thrust, weight=weight)
                return self.climb()
            if self.world.now >= self.spin_up_deadline:
                self.feedback_message = f"thrust {uav.thrust:.2f} N never reached the weight {weight:.2f} N"
                return Status.FAILURE
            return Status.RUNNING
        return self.climb()

    def climb(self) -> Status:
        """Climb to the clearance height above the release point, moving with the carrier."""
        frame = CarrierFrame.of(self.carrier)
        p_uav_M, yaw_uav_M = uav_in_M(self.robot, frame)
        v_W, yaw_rate = hold_command(p_uav_M, yaw_uav_M, self.p_clear_M, yaw_uav_M, frame, self.gains)
        self.robot.command_velocity(*v_W, yaw_rate, frame="world")
        error = float(np.linalg.norm(self.p_clear_M - p_uav_M))
        self.feedback_message = f"climbing clear of the arm: {error:.2f} m to go"
        if error > 0.05:
            return Status.RUNNING
        phase_event(self, "clear", height_above_release=self.params.clearance)
        return Status.SUCCESS

    def finish(self, status: Status) -> None:
        self.write(f"{self.params.carrier}/{DOCKING_FLAG}", False)
        if status == Status.SUCCESS:
            if self.params.then_arm is not None:
                self.carrier.set_joint_targets(self.params.then_arm)
            self.leave_safe()
            return
        if self.phase != "climb":
            self.robot.set_motors(False)  # still locked: stop the rotors again
        self.carrier.hold_arm()
        self.leave_safe()
