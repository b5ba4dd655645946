"""The touchdown test of Palafox et al. (2019, §3.3.1): sonar low persistently, and the IMU feels the moving platform.

"Both conditions must be met, namely (1) the sonar measurement must be
smaller than a threshold persistently and (2) the IMU must indicate a
non-zero linear acceleration" in x or y, since the platform is assumed to be
moving. The paper gives neither threshold nor period; the values are ours
(:class:`TouchdownParams`).

The IMU evidence is every IMU sample at the IMU's own rate (200 Hz on the
AR.Drone 2), from the sensor's sample queue (``SensorPort.read_since``), not
one sample per tick of the mission: the moving Summit XL shakes its rider at
10–30 Hz, so samples taken at a 10 Hz tick alias that vibration and three or
four of them can all fall in its quiet phases (an RMS below the threshold on
4–12 % of the landings), while every 0.3 s window of the 200 Hz stream stays
above 0.25 m/s². The verdict is thus the same at every tick rate a mission
allows; a slower tick only decides later, at the first tick after the window.

The evidence is taken on the platform, not in the air above it: the sonar
reads below 0.3 m (and clamps at its 0.2 m minimum) while the UAV still has
about 0.27 m to descend, a quarter of a second at the 1 m/s vertical limit,
and the touchdown itself rocks the vehicle (≈2 m/s² sideways for a few
samples, whatever it lands on). Samples count from ``settle_s`` after the
last impact the IMU felt (vertical specific force more than ``impact_accel``
from gravity; the sonar-low instant if there was none), and the statistic
is the RMS fluctuation of the horizontal specific force about its mean over
the evidence, so that a constant accelerometer bias or a tilted rest does
not read as motion.

Heights m (sonar range), specific force m/s² (IMU, body frame), times simulated s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

GRAVITY = 9.81  # m/s², what a resting accelerometer reads along the vertical


@dataclass(frozen=True)
class TouchdownParams:
    """Thresholds of the touchdown test (§3.3.1 names the quantities, not their values).

    Attributes:
        landed_range: sonar range (m) below which the UAV may be down (the AR.Drone 2 sonar reads ≥ 0.2 m).
        hold_s: how long (s) the sonar must stay below ``landed_range`` ("persistently").
        ride_accel: RMS fluctuation of the horizontal specific force (m/s²) over the evidence from which the
            IMU shows a moving platform; at rest on the ground it is only the accelerometer noise
            (≈ 0.07 m/s² for the AR.Drone 2 model), riding the moving Summit XL ≈ 0.3–0.45 m/s².
        evidence_s: how much IMU stream (s) on the platform the verdict rests on.
        impact_accel: departure of the vertical specific force from gravity (m/s²) that marks an impact.
        settle_s: samples this long (s) after the last impact are not evidence (the vehicle rocks).
        min_samples: fewest IMU samples the verdict may rest on (dropouts extend the evidence window).
    """

    landed_range: float = 0.3
    hold_s: float = 0.3
    ride_accel: float = 0.2
    evidence_s: float = 0.2
    impact_accel: float = 9.81
    settle_s: float = 0.1
    min_samples: int = 20

    def __post_init__(self) -> None:
        values = (self.landed_range, self.hold_s, self.ride_accel, self.evidence_s, self.impact_accel)
        if min(values) <= 0.0 or self.settle_s < 0.0 or self.min_samples < 1:
            raise ValueError(f"touchdown thresholds must be > 0 (settle_s >= 0) and min_samples >= 1, got {self}")


class TouchdownTest:
    """Accumulates sonar persistence and IMU evidence; :meth:`update` returns the verdict once there is one.

    Call :meth:`update` once per tick with the newest sonar range and the
    IMU samples that arrived since the previous call.
    """

    def __init__(self, params: TouchdownParams = TouchdownParams()):
        self.params = params
        self.reset()

    def reset(self) -> None:
        """Forget the window (the sonar rose again)."""
        self.since: float | None = None  # time (s) the sonar went below landed_range
        self.contact: float | None = None  # stamp (s) of the last impact felt since
        self._evidence: list[tuple[float, float, float]] = []  # (stamp, f_x, f_y) after the settle time

    @property
    def samples(self) -> int:
        """IMU samples of the evidence so far."""
        return len(self._evidence)

    @property
    def ride_rms(self) -> float:
        """RMS fluctuation (m/s²) of the horizontal specific force over the evidence (NaN before any sample)."""
        if not self._evidence:
            return math.nan
        f = np.asarray(self._evidence)[:, 1:]
        return float(np.sqrt(np.sum(f.var(axis=0))))

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
            if stamp < self.since - 1e-9:
                continue
            if abs(float(force[2]) - GRAVITY) > p.impact_accel:
                self.contact, self._evidence = stamp, []  # the vehicle hit something: evidence starts after it
            elif stamp > (self.since if self.contact is None else self.contact) + p.settle_s:
                self._evidence.append((stamp, float(force[0]), float(force[1])))
        enough = self.samples >= p.min_samples and self._evidence[-1][0] - self._evidence[0][0] + 1e-9 >= p.evidence_s
        if now - self.since + 1e-9 < p.hold_s or not enough:
            return None
        return "platform" if self.ride_rms >= p.ride_accel else "ground"
