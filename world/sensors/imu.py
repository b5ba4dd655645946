"""Inertial measurement unit: specific force and angular rate in the body frame, plus orientation.

The body frame is the robot's base frame (x forward, y left, z up). An
accelerometer at rest reads the reaction to gravity, ``+g`` along world z
expressed in the body frame; in free fall it reads zero.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np

from ..robots.base import rotation_matrix
from ..world import GRAVITY
from .base import Sensor, SensorConfig

if TYPE_CHECKING:
    from ..world import World


class Inertial(Protocol):
    """What an IMU needs from its robot: world-frame pose, velocity and acceleration."""

    name: str
    world: World

    def pose(self) -> tuple[np.ndarray, np.ndarray]: ...

    def velocity(self) -> tuple[np.ndarray, np.ndarray]: ...

    def acceleration(self) -> np.ndarray: ...


@dataclass(frozen=True)
class ImuData:
    """One IMU sample.

    Attributes:
        linear_acceleration: specific force (m/s², body frame), includes the gravity reaction.
        angular_velocity: body rates (rad/s, body frame).
        orientation: ``[x, y, z, w]`` quaternion of the body in the world frame.
    """

    linear_acceleration: np.ndarray
    angular_velocity: np.ndarray
    orientation: np.ndarray


class Imu(Sensor[ImuData]):
    """IMU of ``robot``: ``config.noise_std`` on accelerations (m/s²), ``gyro_noise_std`` on rates (rad/s)."""

    def __init__(self, robot: Inertial, name: str, config: SensorConfig, gyro_noise_std: float = 0.0):
        super().__init__(robot.world, f"{robot.name}/{name}", config)
        self.robot = robot
        self.gyro_noise_std = gyro_noise_std

    def measure(self) -> ImuData:
        _, q_world_body = self.robot.pose()
        R_world_body = rotation_matrix(q_world_body)
        a_world = self.robot.acceleration() + np.array([0.0, 0.0, GRAVITY])
        omega_world = self.robot.velocity()[1]
        f_body = R_world_body.T @ a_world
        omega_body = R_world_body.T @ omega_world
        if self.config.noise_std > 0:
            f_body += self.rng.normal(0.0, self.config.noise_std, 3)
        if self.gyro_noise_std > 0:
            omega_body += self.rng.normal(0.0, self.gyro_noise_std, 3)
        return ImuData(f_body, omega_body, q_world_body)
