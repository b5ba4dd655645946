"""Downward range sensor (ultrasound sonar or infrared time-of-flight) cast with pybullet rays.

The sensor sits on a robot link at ``offset`` (m, link frame) and looks
along the link's -z axis. A real sonar returns the first echo inside its
beam cone, so the reading is the shortest hit of a central ray and a ring
of rays on the cone's edge (``half_angle``). Hits on the robot's own body
are ignored. Nothing within ``max_range``: the range is ``inf``.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import pybullet

from marsupial.api.readings import RangeData
from marsupial.geometry import Vector

from .base import Sensor, SensorConfig

if TYPE_CHECKING:
    from ..robots.base import Robot


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
        p_link: Vector
        q_link: Vector
        if self.link == -1:
            p_link, q_link, _, _ = self.robot.base_state()
        else:
            p_link, q_link = self.robot.link_pose(self.link)
        R = pybullet.getMatrixFromQuaternion(q_link)
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = R
        ox, oy, oz = self.offset
        o0 = p_link[0] + r00 * ox + r01 * oy + r02 * oz
        o1 = p_link[1] + r10 * ox + r11 * oy + r12 * oz
        o2 = p_link[2] + r20 * ox + r21 * oy + r22 * oz
        ends = [
            (o0 + r00 * x + r01 * y + r02 * z, o1 + r10 * x + r11 * y + r12 * z, o2 + r20 * x + r21 * y + r22 * z)
            for x, y, z in self._ends_link
        ]
        hits = pybullet.rayTestBatch([(o0, o1, o2)] * len(ends), ends, physicsClientId=self.world.client_id)
        own = self.robot.body_id
        fraction = min((h[2] for h in hits if h[0] >= 0 and h[0] != own), default=None)
        if fraction is None:
            return RangeData(math.inf, self.half_angle, self.min_range, self.max_range)
        distance = fraction * self.max_range
        if self.config.noise_std > 0:
            distance += self.config.noise_std * self.normals.take(1)[0]
        distance = min(self.max_range, max(self.min_range, distance))
        return RangeData(distance, self.half_angle, self.min_range, self.max_range)
