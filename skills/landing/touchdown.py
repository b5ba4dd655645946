"""The touchdown test of Palafox et al. (2019, §3.3.1): sonar low persistently, and the IMU feels the moving platform.

"Both conditions must be met, namely (1) the sonar measurement must be
smaller than a threshold persistently and (2) the IMU must indicate a
non-zero linear acceleration" in x or y, since the platform is assumed to be
moving. The paper gives neither threshold nor period; the values are ours
(:class:`TouchdownParams`).

The IMU evidence is every IMU sample of the persistence window, at the
IMU's own rate (200 Hz on the AR.Drone 2), from the sensor's sample queue
(``SensorPort.read_since``), not one sample per tick of the mission: the
moving Summit XL shakes its rider at 10–30 Hz, so samples taken at a 10 Hz
tick alias that vibration and three or four of them can all fall in its
quiet phases (an RMS below the threshold on 4–12 % of the landings), while
every 0.3 s window of the 200 Hz stream stays above 0.25 m/s². The verdict
is thus the same at every tick rate a mission allows; a slower tick only
decides later, at the first tick after the window.

Heights m (sonar range), specific force m/s² (IMU, body frame), times simulated s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class TouchdownParams:
    """Thresholds of the touchdown test (§3.3.1 names the quantities, not their values).

    Attributes:
        landed_range: sonar range (m) below which the UAV may be down (the AR.Drone 2 sonar reads ≥ 0.2 m).
        hold_s: how long (s) the sonar must stay below ``landed_range`` ("persistently").
        ride_accel: RMS horizontal specific force (m/s²) over the window from which the IMU shows a
            moving platform; at rest on the ground it is only the accelerometer noise (≈ 0.07 m/s² for
            the AR.Drone 2 model), riding the moving Summit XL ≈ 0.3–0.45 m/s².
        min_samples: fewest IMU samples the verdict may rest on (a window with fewer, e.g. IMU
            dropouts, is extended until it has them).
    """

    landed_range: float = 0.3
    hold_s: float = 0.3
    ride_accel: float = 0.2
    min_samples: int = 20

    def __post_init__(self) -> None:
        if min(self.landed_range, self.hold_s, self.ride_accel) <= 0.0 or self.min_samples < 1:
            raise ValueError(f"touchdown thresholds must be > 0 and min_samples >= 1, got {self}")


class TouchdownTest:
    """Accumulates sonar persistence and IMU evidence; :meth:`update` returns the verdict once there is one.

    Call :meth:`update` once per tick with the newest sonar range and the
    IMU samples that arrived since the previous call.
    """

    def __init__(self, params: TouchdownParams = TouchdownParams()):
        self.params = params
        self.since: float | None = None  # time (s) the sonar went below landed_range
        self._square_sum = 0.0
        self.samples = 0

    def reset(self) -> None:
        """Forget the window (the sonar rose again)."""
        self.since, self._square_sum, self.samples = None, 0.0, 0

    @property
    def ride_rms(self) -> float:
        """RMS horizontal specific force (m/s²) of the window so far (NaN before any sample)."""
        return math.sqrt(self._square_sum / self.samples) if self.samples else math.nan

    def update(self, now: float, sonar_range: float, imu: list[tuple[float, np.ndarray]]) -> str | None:
        """``"platform"`` or ``"ground"`` once decided, else ``None``.

        Args:
            now: time of this tick (s).
            sonar_range: newest sonar range (m).
            imu: ``(stamp s, specific force (3,) m/s² body frame)`` of the IMU samples since the last call.
        """
        p = self.params
        if not sonar_range < p.landed_range:
            self.reset()
            return None
        if self.since is None:
            self.since = now
        for stamp, force in imu:
            if stamp >= self.since - 1e-9:
                self._square_sum += float(force[0]) ** 2 + float(force[1]) ** 2
                self.samples += 1
        if now - self.since + 1e-9 < p.hold_s or self.samples < p.min_samples:
            return None
        return "platform" if self.ride_rms >= p.ride_accel else "ground"
