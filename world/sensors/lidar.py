"""Planar scanning range finder (2-D LiDAR) simulated with batched pybullet ray casts.

The scan lies in the x-y plane of the sensor frame: beam angles are
counter-clockwise from the sensor's +x axis, symmetric about it. Each beam
is a ray from ``start_range`` (just outside the housing) to ``max_range``;
the robot carrying the sensor is transparent to it (for a beam whose
closest hit is its own robot, every object along the beam is enumerated and
the closest other one is kept). A beam with no echo reads
``inf`` (the ROS LaserScan convention). Ranges get seeded Gaussian noise
(``SensorConfig.noise_std``, m) and, with ``beam_dropout``, seeded lost
echoes; ``SensorConfig.dropout`` drops whole scans.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pybullet

from marsupial.api.model import LidarSpec

from .base import Sensor, SensorConfig

if TYPE_CHECKING:
    from ..robots.base import Robot

MAX_RAYS_PER_BATCH = pybullet.MAX_RAY_INTERSECTION_BATCH_SIZE
_MAX_HITS_PER_BEAM = 64  # objects enumerated along a beam that first hits its own robot


@dataclass(frozen=True)
class LidarScan:
    """One scan.

    Attributes:
        ranges: ``(n,)`` float32 distances (m) along each beam; ``inf`` where no echo.
        angles: ``(n,)`` float32 beam angles (rad) in the sensor frame.
        hit_bodies: ``(n,)`` int32 pybullet body id each beam hit (-1 for none).
        position: sensor origin in the world frame (m).
        rotation: ``R_world_sensor`` 3×3.
        max_range: farthest possible echo (m).
    """

    ranges: np.ndarray
    angles: np.ndarray
    hit_bodies: np.ndarray
    position: np.ndarray
    rotation: np.ndarray
    max_range: float

    def points_sensor(self) -> np.ndarray:
        """``(m, 2)`` x, y (m, sensor frame) of the beams that returned an echo."""
        hit = np.isfinite(self.ranges)
        r, a = self.ranges[hit], self.angles[hit]
        return np.stack((r * np.cos(a), r * np.sin(a)), axis=1)

    def points_world(self) -> np.ndarray:
        """``(m, 3)`` world positions (m) of the echoes."""
        xy = self.points_sensor()
        p_sensor = np.column_stack((xy, np.zeros(len(xy))))
        return self.position + p_sensor @ self.rotation.T


class Lidar(Sensor[LidarScan]):
    """A 2-D LiDAR on ``robot``'s ``link`` at ``offset`` (m, link frame) with ``R_link_sensor`` (identity if None).

    The scan plane is the sensor frame's x-y plane. ``config.noise_std`` is
    the range noise (m, 1σ; the LMS111 data sheet gives 12 mm); the spec's
    ``beam_dropout`` is scaled by ``world.noise_scale`` (capped at 1) like it.
    """

    def __init__(
        self,
        robot: Robot,
        name: str,
        spec: LidarSpec,
        config: SensorConfig,
        link: str | int = -1,
        offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
        R_link_sensor: np.ndarray | None = None,
    ):
        super().__init__(robot.world, f"{robot.name}/{name}", config)
        self.robot = robot
        self.spec = spec
        self.beam_dropout = min(1.0, spec.beam_dropout * self.noise_scale)
        self.link = robot.link_index(link) if isinstance(link, str) else link
        self.offset = np.asarray(offset, dtype=float)
        self.R_link_sensor = np.eye(3) if R_link_sensor is None else np.asarray(R_link_sensor, dtype=float)
        self.angles = spec.angles()
        self.angles.flags.writeable = False  # shared by every scan
        a = self.angles.astype(float)
        self._directions = np.column_stack((np.cos(a), np.sin(a), np.zeros_like(a)))  # sensor frame

    def sensor_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Position (m) and ``R_world_sensor`` of the sensor frame now."""
        return self.robot.mounted_frame(self.link, self.offset, self.R_link_sensor)

    def measure(self) -> LidarScan:
        """Cast every beam now, see through the own robot, add seeded noise and lost echoes."""
        spec = self.spec
        position, R = self.sensor_pose()
        directions = self._directions @ R.T  # world frame, unit length
        starts = position + spec.start_range * directions
        ends = position + spec.max_range * directions
        bodies, fractions = self._cast(starts, ends)
        through = np.flatnonzero(bodies == self.robot.body_id)
        if through.size:
            bodies[through], fractions[through] = self._first_other_hits(starts[through], ends[through])
        ranges = np.where(bodies >= 0, spec.start_range + fractions * (spec.max_range - spec.start_range), np.inf)
        rng, n = self.rng, len(ranges)
        if self.config.noise_std > 0:
            ranges += rng.normal(0.0, self.config.noise_std, n)
        if self.beam_dropout > 0:
            lost = rng.random(n) < self.beam_dropout
            ranges[lost] = np.inf
            bodies[lost] = -1
        ranges[ranges > spec.max_range] = np.inf
        np.maximum(ranges, 0.0, out=ranges)
        return LidarScan(ranges.astype(np.float32), self.angles, bodies, position, R, spec.max_range)

    def _cast(self, starts: np.ndarray, ends: np.ndarray, hit_number: int = -1) -> tuple[np.ndarray, np.ndarray]:
        """Body ids (-1: none) and hit fractions of rays ``starts`` → ``ends`` (world frame).

        ``hit_number`` -1: the closest hit; n >= 0: the n-th hit of the ray in
        pybullet's (unsorted) enumeration of every object it crosses.
        """
        uids: list[int] = []
        fractions: list[float] = []
        for i in range(0, len(starts), MAX_RAYS_PER_BATCH):
            results = pybullet.rayTestBatch(
                starts[i : i + MAX_RAYS_PER_BATCH].tolist(),
                ends[i : i + MAX_RAYS_PER_BATCH].tolist(),
                numThreads=0,  # rays are independent: threads change the speed, not the result
                reportHitNumber=hit_number,
                physicsClientId=self.world.client_id,
            )
            columns = list(zip(*results, strict=True))
            uids.extend(columns[0])
            fractions.extend(columns[2])
        return np.array(uids, dtype=np.int32), np.array(fractions, dtype=float)

    def _first_other_hits(self, starts: np.ndarray, ends: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Closest hit on anything but the own robot, for rays whose closest hit is the own robot."""
        own = self.robot.body_id
        bodies = np.full(len(starts), -1, dtype=np.int32)
        fractions = np.ones(len(starts))
        active = np.arange(len(starts))
        for n in range(_MAX_HITS_PER_BEAM):
            uid, fraction = self._cast(starts[active], ends[active], hit_number=n)
            closer = (uid >= 0) & (uid != own) & (fraction < fractions[active])
            bodies[active[closer]] = uid[closer]
            fractions[active[closer]] = fraction[closer]
            active = active[uid >= 0]  # rays without an n-th hit are done
            if active.size == 0:
                break
        return bodies, fractions
