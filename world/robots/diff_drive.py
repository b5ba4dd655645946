"""Differential-drive (and skid-steer) base motion on a flat floor.

The base body is dynamic (it carries payloads, riders feel its velocity
through friction, walls stop it) and is driven through a fixed constraint
whose target pose (the reference) advances every physics step by the
unicycle model

    x' = v cos(yaw),  y' = v sin(yaw),  yaw' = omega.

When the body falls more than ``resync_m`` behind its reference (a wall
stopped it) the reference restarts from the actual pose, so a blocked base
stays blocked instead of winding up. Commands
are in the base frame (v forward in m/s, omega counter-clockwise in rad/s),
limited in magnitude and rate. Wheel slip follows a simple skid model:
the achieved speed is ``(1 - slip) * v``, the achieved yaw rate
``(1 - turn_slip) * omega`` (skid-steer wheels scrub while turning, so a
commanded circle comes out wider: Palafox et al. saw the Summit XL drive a
12 m circle for a 10 m command), and turning adds a lateral drift
``drift_per_rad * v * omega`` (m/s, positive to the left) plus seeded noise.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import pybullet

from marsupial.api.model import DiffDriveLimits

if TYPE_CHECKING:
    import numpy as np

    from ..world import World


def _yaw(q: tuple[float, ...]) -> float:
    return math.atan2(2.0 * (q[3] * q[2] + q[0] * q[1]), 1.0 - 2.0 * (q[1] * q[1] + q[2] * q[2]))


def _approach(current: float, target: float, max_delta: float) -> float:
    return current + max(-max_delta, min(max_delta, target - current))


class DiffDrive:
    """Drives ``body_id`` of ``world`` as a differential base within ``limits``.

    Call :meth:`command` any time; the owning robot calls :meth:`pre_physics`
    every physics step. ``v``/``omega`` are the speeds being executed (after
    limits), before slip.
    """

    def __init__(self, world: World, body_id: int, limits: DiffDriveLimits, rng_key: str):
        self.world = world
        self.body_id = body_id
        self.limits = limits
        self.rng = world.rng_for(rng_key)
        self.cid = world.client_id
        self.v_cmd = 0.0
        self.omega_cmd = 0.0
        self.v = 0.0
        self.omega = 0.0
        position, orientation = pybullet.getBasePositionAndOrientation(body_id, physicsClientId=self.cid)
        self.z = position[2]
        self.x, self.y = position[0], position[1]
        self.yaw = _yaw(orientation)
        self.constraint = pybullet.createConstraint(
            body_id, -1, -1, -1, pybullet.JOINT_FIXED, [0, 0, 0], [0, 0, 0], position,
            childFrameOrientation=orientation, physicsClientId=self.cid,
        )
        pybullet.changeConstraint(self.constraint, maxForce=limits.max_force, physicsClientId=self.cid)

    def command(self, v: float, omega: float) -> None:
        """Set the commanded forward speed (m/s) and yaw rate (rad/s), clipped to the limits."""
        lim = self.limits
        self.v_cmd = max(-lim.max_speed, min(lim.max_speed, float(v)))
        self.omega_cmd = max(-lim.max_omega, min(lim.max_omega, float(omega)))

    def stop(self) -> None:
        """Command zero speed (the base decelerates within its limits)."""
        self.v_cmd = self.omega_cmd = 0.0

    def teleport(self, position: np.ndarray, yaw: float) -> None:
        """Place the base at ``position`` (x, y; z kept) with heading ``yaw``, at rest."""
        quat = (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))
        pos = (float(position[0]), float(position[1]), self.z)
        pybullet.resetBasePositionAndOrientation(self.body_id, pos, quat, physicsClientId=self.cid)
        pybullet.resetBaseVelocity(self.body_id, (0, 0, 0), (0, 0, 0), physicsClientId=self.cid)
        pybullet.changeConstraint(self.constraint, pos, quat, maxForce=self.limits.max_force, physicsClientId=self.cid)
        self.x, self.y, self.yaw = pos[0], pos[1], float(yaw)
        self.v = self.omega = self.v_cmd = self.omega_cmd = 0.0

    def pre_physics(self, dt: float) -> None:
        """Ramp the speeds toward the command and move the constraint target one step ahead."""
        lim = self.limits
        self.v = _approach(self.v, self.v_cmd, lim.max_accel * dt)
        self.omega = _approach(self.omega, self.omega_cmd, lim.max_alpha * dt)
        v, omega = self.v * (1.0 - lim.slip), self.omega * (1.0 - lim.turn_slip)
        lateral = lim.drift_per_rad * self.v * self.omega
        if lim.noise_std > 0 and (self.v != 0.0 or self.omega != 0.0):
            v += self.rng.normal(0.0, lim.noise_std)
            omega += self.rng.normal(0.0, lim.noise_std)
        (x, y, _), q = pybullet.getBasePositionAndOrientation(self.body_id, physicsClientId=self.cid)
        if (x - self.x) ** 2 + (y - self.y) ** 2 > lim.resync_m**2:
            self.x, self.y, self.yaw = x, y, _yaw(q)
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        self.x += (v * c - lateral * s) * dt
        self.y += (v * s + lateral * c) * dt
        self.yaw += omega * dt
        pybullet.changeConstraint(
            self.constraint,
            (self.x, self.y, self.z),
            (0.0, 0.0, math.sin(self.yaw / 2), math.cos(self.yaw / 2)),
            maxForce=lim.max_force,
            physicsClientId=self.cid,
        )
