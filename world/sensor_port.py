"""Sensor ports: one sensor as a robot's computer reads it (:class:`SensorPort`), and the frames it delivers.

Part of the onboard interfaces (:mod:`marsupial.world.onboard`): camera
frames come without their true pose or segmentation (:class:`CameraImage`),
LiDAR scans without pose or body ids (:class:`RangeScan`); a skill may read
a sensor's static facts (:data:`SENSOR_FACTS`: datasheet and mount) and
nothing else of it.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from .sensors.base import Reading
from .sensors.lidar import Lidar

if TYPE_CHECKING:
    from .sensors.base import Sensor


@dataclass(frozen=True)
class CameraImage:
    """A camera frame as the robot receives it: pixels and intrinsics, no pose.

    Attributes:
        rgb: ``(h, w, 3)`` uint8.
        depth: ``(h, w)`` float32 metres along the optical axis (RGB-D cameras; rendered depth with the
            sensor's noise), ``None`` for a camera that measures no depth.
        K: 3×3 intrinsics (pixels).
    """

    rgb: np.ndarray
    depth: np.ndarray | None
    K: np.ndarray


@dataclass(frozen=True)
class RangeScan:
    """A 2-D LiDAR scan as the robot receives it: ranges and beam angles in the sensor frame, no pose.

    Attributes:
        ranges: ``(n,)`` float32 distances (m) along each beam; ``inf`` where no echo.
        angles: ``(n,)`` float32 beam angles (rad), counter-clockwise from the sensor's +x axis.
        max_range: farthest possible echo (m).

    World points need the robot's estimate composed with the sensor's mount
    (``Onboard.link_offset("lidar")``), not the simulator's sensor pose.
    """

    ranges: np.ndarray
    angles: np.ndarray
    max_range: float

    def points_sensor(self) -> np.ndarray:
        """``(m, 2)`` x, y (m, sensor frame) of the beams that returned an echo."""
        hit = np.isfinite(self.ranges)
        r, a = self.ranges[hit], self.angles[hit]
        return np.stack((r * np.cos(a), r * np.sin(a)), axis=1)


#: static facts of a sensor that a skill may read (its datasheet and mount), by attribute name
SENSOR_FACTS = frozenset(
    {
        "K", "intrinsics", "offset", "R_link_optical", "half_angle", "min_range", "max_range", "spec", "rate_hz",
    }
)


class SensorPort:
    """One sensor as the robot's computer reads it: :meth:`read` and its static facts (:data:`SENSOR_FACTS`).

    Camera readings come as :class:`CameraImage` (no true pose, no
    segmentation, depth only from a camera that ``measures_depth``), LiDAR
    scans as :class:`RangeScan` (no true pose, no body ids); the others as
    the sensor's own data type.
    """

    __slots__ = ("name", "__sensor", "__image", "__scan", "__depth", "__queue")

    #: how long (s) :meth:`read_since` keeps the samples of its queue
    QUEUE_S: ClassVar[float] = 2.0

    def __init__(self, name: str, sensor: Sensor[Any], depth: bool = True):
        self.name = name
        self.__sensor = sensor
        self.__image = hasattr(sensor, "intrinsics")
        self.__scan = isinstance(sensor, Lidar)
        self.__depth = depth
        self.__queue: deque[Reading[Any]] | None = None

    def read(self) -> Reading[Any] | None:
        """The newest readable sample (``None`` before the first); its ``stamp`` is the sample's sim time (s)."""
        reading = self.__sensor.read()
        if reading is None:
            return None
        if self.__image:
            frame = reading.data
            return Reading(reading.stamp, CameraImage(frame.rgb, frame.depth if self.__depth else None, frame.K))
        if self.__scan:
            scan = reading.data
            return Reading(reading.stamp, RangeScan(scan.ranges, scan.angles, scan.max_range))
        return reading

    def read_since(self, stamp: float) -> list[Reading[Any]]:
        """Every sample stamped after ``stamp`` (s), oldest first, as the driver's queue delivers them.

        A robot's computer receives a sensor's samples as a stream at the
        sensor's rate (e.g. the 200 Hz IMU), not only the newest at the
        moment it looks; this is that queue, for the sensors other than
        cameras and LiDARs (their readings are wrapped by :meth:`read`). The
        first call starts it (nothing older is returned); it keeps the last
        :attr:`QUEUE_S` seconds. Latency and dropouts apply as for :meth:`read`.
        """
        if self.__image or self.__scan:
            raise TypeError(f"sensor '{self.name}' is a camera or a LiDAR: read() its newest frame or scan")
        if self.__queue is None:
            sensor = self.__sensor
            self.__queue = deque(maxlen=max(1, int(sensor.config.rate_hz * self.QUEUE_S)))
            sensor.world.add_step_hook(self.__enqueue)
            self.__enqueue(0.0)
        return [reading for reading in self.__queue if reading.stamp > stamp]

    def __enqueue(self, dt: float) -> None:
        """Step hook: append the sensor's newest sample when it is new (the sensor samples at its rate)."""
        reading = self.__sensor.read()
        queue = self.__queue
        if reading is not None and queue is not None and (not queue or reading.stamp > queue[-1].stamp):
            queue.append(reading)

    def __getattr__(self, name: str) -> Any:
        if name in SENSOR_FACTS:
            if name == "rate_hz":
                return self.__sensor.config.rate_hz
            return getattr(self.__sensor, name)
        raise AttributeError(f"sensor '{self.name}' exposes read() and {', '.join(sorted(SENSOR_FACTS))}; not '{name}'")

    def __repr__(self) -> str:
        return f"SensorPort({self.name!r})"
