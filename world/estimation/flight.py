"""Onboard flight estimator of the quadrotors: IMU + optical flow + sonar + barometer, dead-reckoned.

What the Bebop 2, AR.Drone 2 and Tello firmwares do, reduced to a cheap
complementary filter (plain ``math``; it runs at the autopilot rate,
120 Hz, and the autopilot flies on its output):

- attitude: the IMU's attitude output (with its own error process,
  :class:`~marsupial.world.sensors.imu.ImuErrors`) rotated by a heading
  offset that puts the start (or a hand-over) heading at the declared one;
- horizontal velocity: the accelerometer's specific force rotated into the
  navigation frame minus gravity and a bias estimate is integrated, and each
  optical-flow sample (velocity over the surface below, heading frame)
  corrects it, ``v += L_v e`` and ``b -= L_b e`` with ``e = v_flow - v``
  (a second-order complementary filter whose integral state absorbs the
  accelerometer bias and slow attitude errors). No flow update while the
  height is invalid (no range echo within ``height_timeout``).
- horizontal position: the integral of the velocity estimate, so it drifts
  (flow noise, the flow's scale error, the heading error), as the vendors'
  own estimates do;
- height: vertical specific force integrated and corrected by the sonar's
  height above the expected floor (the scene floor the mission declares),
  each echo gated: an echo more than ``sonar_gate`` off the predicted height
  (a platform, an arm, a carrier under the vehicle) is ignored; without a
  recent floor echo the barometer (whose drifting offset is re-calibrated
  against the sonar while both are valid) corrects it.
- external vision fixes (:mod:`.external`): when another robot sends the
  UAV's pose over the team link (the carrier's eye-in-hand camera), each fix
  is compared with the estimate at its stamp (a short history) and corrects
  position, velocity and heading now; while fixes are recent, flow samples
  that disagree with the vision-anchored velocity by more than a gate (the
  flow over a moving deck) are rejected, the sonar echoes no longer correct
  the height (they still make it valid for the flow: an echo off the
  carrier's deck would otherwise be taken for the floor) and the barometer
  is calibrated against the anchored height. The position and heading
  corrections are cumulated in :attr:`FlightEstimator.shift`, which the
  autopilot follows with its references (the frame moved, not the vehicle).
- at rest (motors off, or held by a docking device) the estimate is held:
  zero velocity, position kept (zero-velocity update); the attitude keeps
  following the IMU.

Frame ``"odom"``: starts at the mission's spawn pose; :meth:`reset` restarts
it (a carrier's hand-over). Units: m, m/s, rad.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from marsupial.api.readings import StateEstimate

from ..sensors.imu import quat_multiply, quat_yaw, rotation_rows
from ..world import GRAVITY
from .base import Estimator
from .external import VisionFixFusion, VisionFixGains

if TYPE_CHECKING:
    from ..sensors.barometer import Barometer
    from ..sensors.flow import OpticalFlow
    from ..sensors.imu import Imu
    from ..sensors.sonar import Sonar
    from ..world import World


REST_DECIMATION = 4  # at rest the filter runs every 4th autopilot update (30 Hz)


@dataclass(frozen=True)
class FlightEstimatorGains:
    """Gains of the complementary filter (chosen; see ``docs/world.md``).

    Attributes:
        flow_velocity: velocity correction per second by the flow innovation (1/s).
        flow_bias: accelerometer-bias correction per second per (m/s) of innovation (1/s²).
        sonar_omega: natural frequency of the height loop on sonar echoes (rad/s).
        baro_omega: natural frequency of the height loop on the barometer (rad/s).
        baro_calibration_tau: time constant (s) of the barometer offset's calibration against the sonar.
        sonar_gate: largest accepted difference (m) between an echo's height and the predicted height.
        sonar_rate_gate: largest accepted difference (m/s) between the echo's rate of change and the
            estimated climb rate (an echo sliding along the side of an obstacle changes fast).
        sonar_soft: innovation (m) beyond which an accepted echo's weight falls as ``sonar_soft / |e|``.
        height_timeout: age (s) beyond which the last valid echo no longer makes the height valid.
    """

    flow_velocity: float = 8.0
    flow_bias: float = 2.0
    sonar_omega: float = 3.0
    baro_omega: float = 0.7
    baro_calibration_tau: float = 20.0
    sonar_gate: float = 0.25
    sonar_rate_gate: float = 1.5
    sonar_soft: float = 0.05
    height_timeout: float = 0.2


class FlightEstimator(Estimator):
    """IMU + optical flow + sonar + barometer estimate of a quadrotor's base (see the module docstring).

    Args:
        world: the world (for the simulated clock only).
        imu, flow, sonar, barometer: the vehicle's sensors.
        floor_height: height (m) of the floor the mission declares (world z).
        landed_height: height (m) of the base above a surface it stands on (model): the estimate
            never goes below ``floor_height + landed_height``.
        sonar_offset_z: z (m) of the sonar's origin in the base frame (negative: below the base).
        position, yaw: start pose (m, rad) in the navigation frame.
        vision_fixes: returns the newest :class:`~.external.VisionFix` message the team link delivered to
            this UAV (or ``None``); ``None``: no external fixes.
        fix_gains: gains of their fusion (:class:`~.external.VisionFixGains`; its defaults if None).

    Attributes (read by the autopilot every update, plain floats):
        p, v: position (m) and velocity (m/s) in the navigation frame.
        yaw: heading (rad); R: row-major ``R_nav_body``; resets: number of :meth:`reset` calls.
        height_valid: True while a recent range echo exists (flow updates only then).
        shift: cumulated position (m) and heading (rad) corrections of the vision fixes, ``[x, y, z, yaw]``.
        fixes: the vision-fix fusion (``None`` without a source); flow_rejected: flow samples gated out.
    """

    frame = "odom"
    source = "imu+flow+sonar+baro"

    def __init__(
        self,
        world: World,
        imu: Imu,
        flow: OpticalFlow,
        sonar: Sonar,
        barometer: Barometer,
        floor_height: float,
        landed_height: float,
        sonar_offset_z: float,
        position: tuple[float, float, float],
        yaw: float,
        gains: FlightEstimatorGains = FlightEstimatorGains(),
        vision_fixes: Callable[[], Any] | None = None,
        fix_gains: VisionFixGains | None = None,
    ):
        self.clock = world.clock
        self.imu, self.flow, self.sonar, self.barometer = imu, flow, sonar, barometer
        self.floor_height = float(floor_height)
        self.lowest = float(floor_height) + float(landed_height)
        self._last_echo = (-math.inf, 0.0)  # stamp (s) and height (m) of the previous valid echo
        self.sonar_offset_z = float(sonar_offset_z)
        self.gains = gains
        self.p = [0.0, 0.0, 0.0]
        self.v = [0.0, 0.0, 0.0]
        self.bias = [0.0, 0.0, 0.0]  # m/s², accelerometer bias estimate (navigation frame; z: vision fixes only)
        self.resets = 0
        self.fixes = None if vision_fixes is None else VisionFixFusion(vision_fixes, fix_gains or VisionFixGains())
        self.shift = self.fixes.shift if self.fixes is not None else [0.0, 0.0, 0.0, 0.0]
        self.flow_rejected = 0
        self.height_valid = False
        self._t_echo = -math.inf
        self._t_floor_echo = -math.inf
        self._last = {"flow": -1.0, "sonar": -1.0, "baro": -1.0}
        self._baro_offset: float | None = None  # m, navigation z minus barometer reading
        self._baro_n = 0  # samples in the offset's running mean
        self._cache: StateEstimate | None = None
        self._rest_calls = -1
        _, self._w, self._q_imu = self.imu.sample()
        self.reset(np.asarray(position, dtype=float), float(yaw))
        self.resets = 0  # the start pose is not a hand-over

    # ------------------------------------------------------------- interface
    def reset(self, position: np.ndarray, yaw: float) -> None:
        """Restart at ``position`` (m) with heading ``yaw`` (rad), at rest; the barometer is re-calibrated."""
        self.p = [float(position[0]), float(position[1]), float(position[2])]
        self.v = [0.0, 0.0, 0.0]
        offset = float(yaw) - quat_yaw(self._q_imu)
        self._q_off = (0.0, 0.0, math.sin(offset / 2.0), math.cos(offset / 2.0))
        self._set_attitude(self._q_imu)
        self._baro_offset = None
        if self.fixes is not None:
            self.fixes.clear()
        self.resets += 1
        self._stamp = self.clock.now
        self._cache = None

    def estimate(self) -> StateEstimate:
        """The latest estimate (frame ``"odom"``)."""
        if self._cache is None:
            self._cache = StateEstimate(
                self._stamp, self.frame, np.array(self.p), np.array(self._q), np.array(self.v), np.array(self._w),
                self.source, (self.shift[0], self.shift[1], self.shift[2], self.shift[3]),
            )
        return self._cache

    def update(self, dt: float, at_rest: bool = False) -> None:
        """One filter step of ``dt`` s: IMU propagation, then the flow, sonar and barometer samples that are new.

        At rest (motors off or docked) only every ``REST_DECIMATION``-th call does anything: the
        velocity is zero, the position held, and the attitude (a carried vehicle turns with its
        carrier) and the barometer offset follow at a quarter of the rate.
        """
        if at_rest:
            self._rest_calls += 1
            if self._rest_calls % REST_DECIMATION:
                return
        else:
            self._rest_calls = -1  # the first call at rest runs
        self._cache = None
        self._stamp = self.clock.now
        f, self._w, q_imu = self.imu.sample()
        self._q_imu = q_imu
        self._set_attitude(q_imu)
        if at_rest:
            self.v = [0.0, 0.0, 0.0]
            self._calibrate_baro_at_rest()
            return
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = self.R
        fx, fy, fz = f
        b, v, p = self.bias, self.v, self.p
        ax = r00 * fx + r01 * fy + r02 * fz - b[0]
        ay = r10 * fx + r11 * fy + r12 * fz - b[1]
        az = r20 * fx + r21 * fy + r22 * fz - GRAVITY - b[2]
        v0x, v0y, v0z = v
        v[0] += ax * dt
        v[1] += ay * dt
        v[2] += az * dt
        p[0] += 0.5 * (v0x + v[0]) * dt  # trapezoidal position integration
        p[1] += 0.5 * (v0y + v[1]) * dt
        p[2] += 0.5 * (v0z + v[2]) * dt
        self._correct_height(r22)
        if p[2] < self.lowest:  # it cannot be under the floor (the velocity is left to the accelerometer,
            p[2] = self.lowest  # which feels the touchdown)
        self._correct_flow()
        if self.fixes is not None:
            self._correct_vision()

    # --------------------------------------------------------------- helpers
    def _set_attitude(self, q_imu: tuple[float, float, float, float]) -> None:
        q = self._q = quat_multiply(self._q_off, q_imu)
        self.R = rotation_rows(q)
        self.yaw = math.atan2(self.R[3], self.R[0])

    def _new(self, key: str, sensor: Sonar | Barometer | OpticalFlow) -> object | None:
        """The sensor's reading if it is newer than the last one this filter used, else None."""
        reading = sensor.read()
        if reading is None or reading.stamp <= self._last[key]:
            return None
        self._last[key] = reading.stamp
        return reading.data

    def _calibrate_baro(self, z: float, baro: float) -> None:
        """Offset of the barometer (navigation z minus reading): running mean of the first samples, then
        an exponential average of time constant ``baro_calibration_tau`` (the offset drifts)."""
        target = z - baro
        if self._baro_offset is None:
            self._baro_offset, self._baro_n = target, 1
            return
        self._baro_n += 1
        gain = max(1.0 / self._baro_n, self.barometer.period / self.gains.baro_calibration_tau)
        self._baro_offset += (target - self._baro_offset) * gain

    def _calibrate_baro_at_rest(self) -> None:
        baro = self._new("baro", self.barometer)
        if baro is not None:
            self._calibrate_baro(self.p[2], float(baro))  # type: ignore[arg-type]

    def _correct_height(self, r22: float) -> None:
        """Sonar echoes gated on the expected floor; the barometer when no floor echo is recent."""
        g, now, p, v = self.gains, self.clock.now, self.p, self.v
        anchored = self.fixes is not None and self.fixes.recent(now)  # vision fixes are the height reference
        echo = self._new("sonar", self.sonar)
        if echo is not None:
            rng = echo.range  # type: ignore[attr-defined]
            if echo.min_range < rng < echo.max_range:  # type: ignore[attr-defined]
                tilt = math.acos(max(-1.0, min(1.0, r22)))
                height = rng * math.cos(max(0.0, tilt - echo.half_angle)) - self.sonar_offset_z  # type: ignore[attr-defined]
                t_prev, h_prev = self._last_echo
                rate = (height - h_prev) / (now - t_prev) if now - t_prev < 0.5 else v[2]
                self._t_echo, self._last_echo = now, (now, height)
                e = self.floor_height + height - p[2]
                if not anchored and abs(e) < g.sonar_gate and abs(rate - v[2]) < g.sonar_rate_gate:  # off the floor
                    k = self.sonar.period * min(1.0, g.sonar_soft / abs(e)) if e else 0.0
                    p[2] += 2.0 * g.sonar_omega * k * e
                    v[2] += g.sonar_omega**2 * k * e
                    self._t_floor_echo = now
        self.height_valid = now - self._t_echo <= g.height_timeout
        baro = self._new("baro", self.barometer)
        if baro is None:
            return
        if self._baro_offset is None or anchored or now - self._t_floor_echo <= g.height_timeout:
            self._calibrate_baro(p[2], float(baro))  # type: ignore[arg-type]  # sonar or vision holds the height
        else:
            z_baro = float(baro) + self._baro_offset  # type: ignore[arg-type]
            period = self.barometer.period
            e = z_baro - p[2]
            p[2] += 2.0 * g.baro_omega * period * e
            v[2] += g.baro_omega**2 * period * e

    def _correct_flow(self) -> None:
        flow = self._new("flow", self.flow)
        if flow is None or not self.height_valid or not flow.valid:  # type: ignore[attr-defined]
            return
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        fx, fy = flow.vx, flow.vy  # type: ignore[attr-defined]
        ex, ey = c * fx - s * fy - self.v[0], s * fx + c * fy - self.v[1]
        if self.fixes is not None and self.fixes.flow_rejected(self.clock.now, ex, ey):
            self.flow_rejected += 1  # over the carrier's moving deck: off the vision-anchored velocity
            return
        period = self.flow.period
        kv, kb = self.gains.flow_velocity * period, self.gains.flow_bias * period
        self.v[0] += kv * ex
        self.v[1] += kv * ey
        self.bias[0] -= kb * ex
        self.bias[1] -= kb * ey

    def _correct_vision(self) -> None:
        """Fuse a new vision fix (delayed: against the estimate at its stamp), then record the estimate."""
        fixes, p, v = self.fixes, self.p, self.v
        correction = fixes.poll()  # type: ignore[union-attr]
        if correction is not None:
            dpx, dpy, dpz, dvx, dvy, dvz, dyaw, dbx, dby, dbz = correction
            b = self.bias
            b[0] += dbx
            b[1] += dby
            b[2] += dbz
            p[0] += dpx
            p[1] += dpy
            p[2] += dpz
            v[0] += dvx
            v[1] += dvy
            v[2] += dvz
            half = 0.5 * dyaw  # the heading offset turns about the navigation frame's z
            self._q_off = quat_multiply((0.0, 0.0, math.sin(half), math.cos(half)), self._q_off)
            self._set_attitude(self._q_imu)
        fixes.record(self.clock.now, p, self.yaw)  # type: ignore[union-attr]
