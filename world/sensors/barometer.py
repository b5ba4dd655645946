"""Barometric altimeter: altitude of a robot link above a reference height, with seeded noise."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .base import Sensor, SensorConfig

if TYPE_CHECKING:
    from ..robots.base import Robot


class Barometer(Sensor[float]):
    """Altitude (m) of ``robot``'s base above ``reference_height`` (world z, m).

    ``config.noise_std`` is the altitude noise in metres (a consumer MEMS
    barometer: ≈ 0.1 m at 25 Hz).
    """

    def __init__(self, robot: Robot, name: str, config: SensorConfig, reference_height: float = 0.0):
        super().__init__(robot.world, f"{robot.name}/{name}", config)
        self.robot = robot
        self.reference_height = reference_height

    def measure(self) -> float:
        altitude = float(self.robot.pose()[0][2]) - self.reference_height
        if self.config.noise_std > 0:
            altitude += float(self.rng.normal(0.0, self.config.noise_std))
        return altitude
