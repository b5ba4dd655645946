"""Barometric altimeter: altitude of a robot's base above a reference height, with noise and a drifting offset.

Error model (scaled by ``world.noise_scale``; sources in ``docs/world.md``):
white noise ``config.noise_std`` (m) per sample plus an offset that walks
randomly (``drift_std`` m/√s): the pressure at the reference changes with
the weather and the sensor's temperature, so a barometer gives relative
height over minutes, not absolute altitude.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from .base import Sensor, SensorConfig

if TYPE_CHECKING:
    from ..robots.base import Robot

BARO_DRIFT_STD = 0.005  # m/√s random walk of the offset (chosen; see docs/world.md)


class Barometer(Sensor[float]):
    """Altitude (m) of ``robot``'s base above ``reference_height`` (world z, m), plus the drifting offset.

    ``config.noise_std`` is the altitude noise in metres (MS5611-class
    MEMS barometer: ≈ 0.1 m at 25 Hz); ``drift_std`` the offset's random walk (m/√s).
    """

    def __init__(
        self,
        robot: Robot,
        name: str,
        config: SensorConfig,
        reference_height: float = 0.0,
        drift_std: float = BARO_DRIFT_STD,
    ):
        super().__init__(robot.world, f"{robot.name}/{name}", config)
        self.robot = robot
        self.reference_height = reference_height
        self.drift_std = drift_std * self.noise_scale
        self.offset = 0.0  # m, present drift of the reading
        self._t_offset = robot.world.now

    def measure(self) -> float:
        altitude = float(self.robot.base_state()[0][2]) - self.reference_height
        now = self.world.now
        n_drift, n_white = self.normals.take(2)
        if self.drift_std > 0 and now > self._t_offset:
            self.offset += self.drift_std * math.sqrt(now - self._t_offset) * n_drift
        self._t_offset = now
        return altitude + self.config.noise_std * n_white + self.offset
