"""Onboard estimators of the ground robots: wheel odometry, and map-based localisation.

:class:`WheelOdometry` (frame ``"odom"``) dead-reckons ``base_footprint``
from the wheel encoders and a yaw-rate gyro, the way a Pioneer or a Summit
XL's controller does: forward speed from the encoders (what the wheels
turn: the drive's speed before slip, with a per-run scale error and white
noise), heading from the gyro (per-run bias, scale error, white noise),
integrated at ``rate_hz`` with the midpoint rule

    yaw_m = yaw + ω T / 2,  x += v T cos(yaw_m),  y += v T sin(yaw_m),  yaw += ω T.

Slip, scrub in turns and lateral drift move the body but not the wheels,
so the estimate drifts with distance (UMBmark, Borenstein & Feng 1996:
systematic errors from wheel-diameter and wheelbase uncertainty, non-
systematic ones from slip). It is planar: z stays at the start height.
While the wheels stand (the drive's speed and yaw rate both zero) nothing
is integrated: the controller trusts its encoders at rest.

:class:`MapLocalization` (frame ``"map"``) is an AMCL-like localiser against
the mission's declared map: at ``fix_hz`` it outputs the true footprint pose
plus a bounded, correlated error (an Ornstein–Uhlenbeck process per x, y,
yaw with stationary σ ``sigma_xy`` / ``sigma_yaw`` and time constant
``tau``: e ← e φ + σ √(1 - φ²) n, φ = exp(-T / τ)), and between fixes it
composes the odometry increment since the last fix. Every figure is
scaled by ``world.noise_scale`` (sources in ``docs/world.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from marsupial.api.readings import StateEstimate
from marsupial.geometry import yaw_of

from .base import Estimator

if TYPE_CHECKING:
    from ..robots.wheeled import WheeledRobot

LOCALIZATIONS = ("odometry", "map")


@dataclass(frozen=True)
class OdometryErrors:
    """Nominal error figures of a base's wheel odometry (before ``noise_scale``).

    Attributes:
        rate_hz: integration rate (Hz).
        encoder_scale_std: 1σ per-run scale error of the encoder speed (fraction).
        encoder_noise_std: white noise of the encoder speed per sample (m/s).
        gyro_scale_std: 1σ per-run scale error of the gyro (fraction).
        gyro_bias_std: 1σ per-run gyro bias (rad/s).
        gyro_noise_std: white gyro noise per sample (rad/s).
    """

    rate_hz: float = 50.0
    encoder_scale_std: float = 0.01
    encoder_noise_std: float = 0.005
    gyro_scale_std: float = 0.005
    gyro_bias_std: float = 0.0005
    gyro_noise_std: float = 0.005


SKID_STEER_ODOMETRY = OdometryErrors(encoder_scale_std=0.03, encoder_noise_std=0.02)
"""Skid-steer bases (Summit XL, Husky class): their wheels scrub, so the encoders over-read distance
by an uncertain amount that depends on the floor; three times the differential base's scale error and
four times its noise (chosen, see ``docs/world.md``)."""


@dataclass(frozen=True)
class MapErrors:
    """Nominal error figures of the map localiser (before ``noise_scale``).

    Attributes:
        fix_hz: rate of map fixes (Hz).
        sigma_xy: stationary 1σ position error per axis (m).
        sigma_yaw: stationary 1σ heading error (rad).
        tau: correlation time of the errors (s).
    """

    fix_hz: float = 5.0
    sigma_xy: float = 0.05
    sigma_yaw: float = math.radians(1.0)
    tau: float = 5.0


class WheelOdometry(Estimator):
    """Encoder + gyro dead reckoning of ``robot``'s ``base_footprint`` from the start pose (module docstring).

    Attributes:
        speed: last encoder forward speed (m/s), what :meth:`WheeledRobot.wheel_speed` reports.
        yaw_rate: last gyro yaw rate (rad/s).
    """

    frame = "odom"
    source = "wheel_odometry"

    def __init__(self, robot: WheeledRobot, position: np.ndarray, yaw: float, errors: OdometryErrors):
        world = robot.world
        self.robot = robot
        self.clock = world.clock
        k = world.noise_scale
        rng = self.rng = world.rng_for(f"estimator/{robot.name}/odometry")
        e = errors
        draw = rng.standard_normal(3).tolist()
        self.encoder_scale = 1.0 + e.encoder_scale_std * k * draw[0]
        self.gyro_scale = 1.0 + e.gyro_scale_std * k * draw[1]
        self.gyro_bias = e.gyro_bias_std * k * draw[2]
        self.encoder_noise, self.gyro_noise = e.encoder_noise_std * k, e.gyro_noise_std * k
        self._steps = max(1, self.clock.steps_for(1.0 / e.rate_hz))
        self.period = self._steps * self.clock.dt
        self._phase = 0
        self.speed = 0.0
        self.yaw_rate = 0.0
        self.z = float(position[2])
        self.reset(position, yaw)

    def reset(self, position: np.ndarray, yaw: float) -> None:
        """Restart at ``position`` (x, y used; m) with heading ``yaw`` (rad)."""
        self.x, self.y, self.yaw = float(position[0]), float(position[1]), float(yaw)
        self.stamp = self.clock.now
        self._cache: StateEstimate | None = None

    def update(self, dt: float) -> None:
        """Called every physics step; integrates one encoder/gyro sample every ``1 / rate_hz`` s."""
        self._phase += 1
        if self._phase < self._steps:
            return
        self._phase = 0
        r = self.robot
        self.stamp = self.clock.now
        self._cache = None
        if r.diff_drive.v == 0.0 and r.diff_drive.omega == 0.0:  # the wheels stand: no encoder ticks, no motion
            self.speed = self.yaw_rate = 0.0
            return
        v = r.diff_drive.v * self.encoder_scale  # what the wheels turn (before slip)
        w = r.true_yaw_rate() * self.gyro_scale + self.gyro_bias
        if self.encoder_noise > 0.0 or self.gyro_noise > 0.0:
            n = self.rng.standard_normal(2).tolist()
            v += self.encoder_noise * n[0]
            w += self.gyro_noise * n[1]
        T = self.period
        yaw_mid = self.yaw + 0.5 * w * T
        self.x += v * T * math.cos(yaw_mid)
        self.y += v * T * math.sin(yaw_mid)
        self.yaw += w * T
        self.speed, self.yaw_rate = v, w

    def estimate(self) -> StateEstimate:
        """The dead-reckoned footprint pose (frame ``"odom"``)."""
        if self._cache is None:
            self._cache = _planar_estimate(
                self.stamp, self.frame, self.x, self.y, self.z, self.yaw, self.speed, self.yaw_rate, self.source
            )
        return self._cache


class MapLocalization(Estimator):
    """AMCL-like localisation of ``robot``'s footprint in the declared map, with bounded error (module docstring)."""

    frame = "map"
    source = "map_localization"

    def __init__(self, robot: WheeledRobot, odometry: WheelOdometry, errors: MapErrors):
        world = robot.world
        self.robot, self.odometry, self.clock = robot, odometry, world.clock
        k = world.noise_scale
        self.rng = world.rng_for(f"estimator/{robot.name}/map")
        self._sigma = (errors.sigma_xy * k, errors.sigma_xy * k, errors.sigma_yaw * k)
        self._steps = max(1, self.clock.steps_for(1.0 / errors.fix_hz))
        T = self._steps * self.clock.dt
        self._phi = math.exp(-T / errors.tau)
        self._error = [s * n for s, n in zip(self._sigma, self.rng.standard_normal(3).tolist(), strict=True)]
        self._phase = 0
        self._cache: StateEstimate | None = None
        self._fix()

    def _fix(self) -> None:
        """A new map fix: true footprint pose plus the advanced OU error; remember the odometry pose at the fix."""
        phi = self._phi
        noise = self.rng.standard_normal(3).tolist()
        self._error = [
            e * phi + s * math.sqrt(1.0 - phi * phi) * n
            for e, s, n in zip(self._error, self._sigma, noise, strict=True)
        ]
        p, q = self.robot.footprint_pose()
        ex, ey, eyaw = self._error
        self._fix_pose = (float(p[0]) + ex, float(p[1]) + ey, float(p[2]), yaw_of(q) + eyaw)
        o = self.odometry
        self._odom_at_fix = (o.x, o.y, o.yaw)
        self._fix_stamp = self.clock.now

    def reset(self, position: np.ndarray, yaw: float) -> None:
        """Take ``position``/``yaw`` as the pose until the next map fix (the map frame itself stays)."""
        o = self.odometry
        self._fix_pose = (float(position[0]), float(position[1]), float(position[2]), float(yaw))
        self._odom_at_fix = (o.x, o.y, o.yaw)
        self._fix_stamp = self.clock.now
        self._cache = None

    def update(self, dt: float) -> None:
        """Advance the odometry every physics step and take a map fix every ``1 / fix_hz`` s."""
        self.odometry.update(dt)
        self._cache = None
        self._phase += 1
        if self._phase >= self._steps:
            self._phase = 0
            self._fix()

    def estimate(self) -> StateEstimate:
        """Last map fix composed with the odometry increment since (frame ``"map"``)."""
        if self._cache is None:
            o = self.odometry
            fx, fy, fz, fyaw = self._fix_pose
            ox, oy, oyaw = self._odom_at_fix
            c0, s0 = math.cos(oyaw), math.sin(oyaw)
            dx, dy = o.x - ox, o.y - oy
            lx, ly = c0 * dx + s0 * dy, -s0 * dx + c0 * dy  # increment in the odometry frame at the fix
            c, s = math.cos(fyaw), math.sin(fyaw)
            yaw = fyaw + o.yaw - oyaw
            x, y = fx + c * lx - s * ly, fy + s * lx + c * ly
            stamp = max(o.stamp, self._fix_stamp)
            self._cache = _planar_estimate(stamp, self.frame, x, y, fz, yaw, o.speed, o.yaw_rate, self.source)
        return self._cache


def _planar_estimate(
    stamp: float, frame: str, x: float, y: float, z: float, yaw: float, speed: float, yaw_rate: float, source: str
) -> StateEstimate:
    c, s = math.cos(yaw), math.sin(yaw)
    return StateEstimate(
        stamp,
        frame,
        np.array([x, y, z]),
        np.array([0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0)]),
        np.array([speed * c, speed * s, 0.0]),
        np.array([0.0, 0.0, yaw_rate]),
        source,
    )
