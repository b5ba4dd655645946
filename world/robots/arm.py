"""Per-joint PID position control of a serial arm, as on Dynamixel-driven arms.

Each joint runs a PID on its position error (rad) whose output is a joint
velocity (rad/s), clipped to the joint speed limit and sent to pybullet's
velocity motor with a torque limit. This reproduces the "angle correction"
PID loop of Narváez et al. (§IV-B) with the 15 rpm joint limit (§V-B).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pybullet

from marsupial.geometry import Vector

if TYPE_CHECKING:
    from ..world import World

RPM = 2.0 * math.pi / 60.0  # rad/s per rpm


@dataclass(frozen=True)
class JointPID:
    """PID gains of one joint: velocity command (rad/s) per rad of error (and its integral/derivative)."""

    kp: float = 8.0
    ki: float = 0.5
    kd: float = 0.05


class ArmController:
    """Drives the revolute ``joint_indices`` of ``body_id`` toward position targets.

    Args:
        max_speed: joint speed limit (rad/s); 15 rpm by default.
        max_torque: motor torque limit (N·m): one value for every joint, or one per joint.
        limits: ``(lower, upper)`` per joint (rad); targets are clipped into them.
    """

    def __init__(
        self,
        world: World,
        body_id: int,
        joint_indices: Sequence[int],
        limits: Sequence[tuple[float, float]],
        max_speed: float = 15.0 * RPM,
        max_torque: float | Vector = 60.0,
        gains: JointPID = JointPID(),
    ):
        self.cid = world.client_id
        self.body_id = body_id
        self.joints = list(joint_indices)
        self.lower = np.array([lo for lo, _ in limits])
        self.upper = np.array([hi for _, hi in limits])
        self.max_speed = max_speed
        self.max_torque = max_torque
        self.gains = gains
        self.targets = self.positions()
        self._integral = np.zeros(len(self.joints))
        self._previous_error = np.zeros(len(self.joints))
        self._forces = np.broadcast_to(np.asarray(max_torque, dtype=float), (len(self.joints),)).tolist()

    def positions(self) -> np.ndarray:
        """Joint angles now (rad)."""
        states = pybullet.getJointStates(self.body_id, self.joints, physicsClientId=self.cid)
        return np.array([s[0] for s in states])

    def velocities(self) -> np.ndarray:
        """Joint speeds now (rad/s)."""
        states = pybullet.getJointStates(self.body_id, self.joints, physicsClientId=self.cid)
        return np.array([s[1] for s in states])

    def set_targets(self, q: Vector) -> None:
        """New joint position targets (rad), clipped into the joint ranges."""
        q = np.asarray(q, dtype=float)
        if q.shape != self.lower.shape:
            raise ValueError(f"expected {len(self.joints)} joint targets, got {q.shape}")
        self.targets = np.clip(q, self.lower, self.upper)

    def hold(self) -> None:
        """Hold the joints where they are now."""
        self.targets = self.positions()
        self._integral[:] = 0.0

    def reset(self, q: Vector) -> None:
        """Teleport the joints to ``q`` (rad) at rest and hold there (for setting up scenes)."""
        for j, angle in zip(self.joints, q, strict=True):
            pybullet.resetJointState(self.body_id, j, float(angle), 0.0, physicsClientId=self.cid)
        self.targets = np.clip(np.asarray(q, dtype=float), self.lower, self.upper)
        self._integral[:] = 0.0
        self._previous_error[:] = 0.0

    def pre_physics(self, dt: float) -> None:
        """One PID step: position error -> clipped joint velocity command.

        The integral accumulates only while a joint's command is below the
        speed limit (conditional anti-windup), so a long slew at the limit
        does not wind it up into an overshoot. Plain floats: this runs every
        physics step.
        """
        g = self.gains
        vmax = self.max_speed
        states = pybullet.getJointStates(self.body_id, self.joints, physicsClientId=self.cid)
        targets = self.targets.tolist()
        integral = self._integral.tolist()
        previous = self._previous_error.tolist()
        speeds = []
        for i, state in enumerate(states):
            error = targets[i] - state[0]
            derivative = (error - previous[i]) / dt
            previous[i] = error
            command = g.kp * error + g.ki * integral[i] + g.kd * derivative
            if -vmax < command < vmax:
                integral[i] = min(0.2, max(-0.2, integral[i] + error * dt))
                command = g.kp * error + g.ki * integral[i] + g.kd * derivative
            speeds.append(min(vmax, max(-vmax, command)))
        self._integral[:] = integral
        self._previous_error[:] = previous
        pybullet.setJointMotorControlArray(
            self.body_id,
            self.joints,
            pybullet.VELOCITY_CONTROL,
            targetVelocities=speeds,
            forces=self._forces,
            physicsClientId=self.cid,
        )
