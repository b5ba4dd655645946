"""Downward range sensor (ultrasound sonar or infrared time-of-flight) cast with pybullet rays.

The sensor sits on a robot link at ``offset`` (m, link frame) and looks
along the link's -z axis. A real sonar returns the first echo inside its
beam cone, so the reading is the shortest hit of a central ray and a ring
of rays on the cone's edge (``half_angle``). Hits on the robot's own body
are ignored. Nothing within ``max_range``: the range is ``inf``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import pybullet

from .base import Sensor, SensorConfig

if TYPE_CHECKING:
    from ..robots.base import Robot


@dataclass(frozen=True)
class RangeData:
    """One range sample: distance to the first echo (m, ``inf`` if none) and the beam's geometry."""

    range: float
    half_angle: float  # rad, beam cone half-angle
    min_range: float  # m, shorter echoes read as min_range
    max_range: float  # m


class Sonar(Sensor[RangeData]):
    """Downward range finder on ``robot``'s ``link``; ``config.noise_std`` in metres.

    Args:
        half_angle: beam cone half-angle (rad).
        min_range, max_range: measurable interval (m).
        ring_rays: rays on the cone's edge besides the central one.
    """

    def __init__(
        self,
        robot: Robot,
        name: str,
        config: SensorConfig,
        half_angle: float,
        max_range: float,
        min_range: float = 0.0,
        ring_rays: int = 6,
        link: str | int = -1,
        offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ):
        super().__init__(robot.world, f"{robot.name}/{name}", config)
        if not 0.0 <= half_angle < math.pi / 2 or max_range <= min_range:
            raise ValueError(
                f"sonar needs 0 <= half_angle < pi/2 and max_range > min_range; "
                f"got {half_angle}, {min_range}..{max_range}"
            )
        self.robot = robot
        self.link = robot.link_index(link) if isinstance(link, str) else link
        self.offset = tuple(float(v) for v in offset)
        self.half_angle = half_angle
        self.min_range = min_range
        self.max_range = max_range
        # ray ends in the link frame (beam along -z), length max_range
        s, c = max_range * math.sin(half_angle), max_range * math.cos(half_angle)
        angles = [2 * math.pi * k / ring_rays for k in range(ring_rays if half_angle > 0 else 0)]
        self._ends_link = [(0.0, 0.0, -max_range)] + [(s * math.cos(a), s * math.sin(a), -c) for a in angles]

    def measure(self) -> RangeData:
        """Cast the beam now: shortest hit (m) of the rays not on the robot itself, with noise."""
        p_link, q_link = self.robot.link_pose(self.link)
        R = pybullet.getMatrixFromQuaternion(q_link)
        ox, oy, oz = self.offset
        origin = [p_link[i] + R[3 * i] * ox + R[3 * i + 1] * oy + R[3 * i + 2] * oz for i in range(3)]
        ends = [
            [origin[i] + R[3 * i] * x + R[3 * i + 1] * y + R[3 * i + 2] * z for i in range(3)]
            for x, y, z in self._ends_link
        ]
        hits = pybullet.rayTestBatch([origin] * len(ends), ends, physicsClientId=self.world.client_id)
        own = self.robot.body_id
        fractions = [h[2] for h in hits if h[0] >= 0 and h[0] != own]
        if not fractions:
            return RangeData(math.inf, self.half_angle, self.min_range, self.max_range)
        distance = min(fractions) * self.max_range
        if self.config.noise_std > 0:
            distance += self.rng.normal(0.0, self.config.noise_std)
        distance = min(self.max_range, max(self.min_range, distance))
        return RangeData(distance, self.half_angle, self.min_range, self.max_range)
