"""Inertial measurement unit: specific force and angular rate in the body frame, plus its attitude output.

The body frame is the robot's base frame (x forward, y left, z up). An
accelerometer at rest reads the reaction to gravity, ``+g`` along world z
expressed in the body frame; in free fall it reads zero.

Error model (every figure scaled by ``world.noise_scale``; values and
sources in ``docs/world.md``, "Sensing boundary and noise sources"):

- accelerometer: white noise ``config.noise_std`` (m/s²) plus a per-flight
  bias (1σ ``accel_bias_std`` per axis, drawn once per run: the residual
  after the flat-trim calibration at boot);
- gyroscope: white noise ``gyro_noise_std`` (rad/s) plus a per-run bias
  (1σ ``gyro_bias_std``);
- attitude (the orientation the flight controller's attitude filter
  outputs): roll and pitch errors follow an Ornstein–Uhlenbeck process
  (σ ``attitude_std``, time constant ``attitude_tau``), the heading error is
  the integral of the z gyro bias (no magnetometer indoors).

The sampling path :meth:`Imu.sample` is plain ``math`` (the flight
estimator reads it at the autopilot rate); :meth:`Imu.measure` wraps it for
the sensor port.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np

from marsupial.api.readings import ImuData

from ..world import GRAVITY
from .base import Sensor, SensorConfig

if TYPE_CHECKING:
    from ..world import World

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


class Inertial(Protocol):
    """What an IMU needs from its robot: world-frame orientation, body rates and acceleration (tuples)."""

    name: str
    world: World

    def inertial_truth(self) -> tuple[Quat, Vec3, Vec3]:
        """``(q_world_body [x, y, z, w], angular velocity (rad/s, world), acceleration (m/s², world))``."""
        ...


@dataclass(frozen=True)
class ImuErrors:
    """Bias and attitude-error figures of an IMU (nominal, before ``noise_scale``).

    Attributes:
        gyro_noise_std: white noise on the rates (rad/s, per sample).
        accel_bias_std: 1σ per-flight accelerometer bias per axis (m/s²).
        gyro_bias_std: 1σ per-run gyro bias per axis (rad/s).
        attitude_std: 1σ roll/pitch error of the attitude output (rad).
        attitude_tau: correlation time of the roll/pitch error (s).
    """

    gyro_noise_std: float = 0.005
    accel_bias_std: float = 0.05
    gyro_bias_std: float = 0.0005
    attitude_std: float = math.radians(0.5)
    attitude_tau: float = 10.0


def quat_multiply(a: Quat, b: Quat) -> Quat:
    """Hamilton product ``a ⊗ b`` of ``[x, y, z, w]`` quaternions."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def quat_yaw(q: Quat) -> float:
    """Heading (rad) of an ``[x, y, z, w]`` quaternion about world z."""
    x, y, z, w = q
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def rotation_rows(q: Quat) -> tuple[float, ...]:
    """Row-major 3×3 rotation matrix ``(r00, r01, …, r22)`` of an ``[x, y, z, w]`` quaternion."""
    x, y, z, w = q
    return (
        1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
        2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
        2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y),
    )


class Imu(Sensor[ImuData]):
    """IMU of ``robot``.

    ``config.noise_std`` on accelerations (m/s²), biases and attitude error per :class:`ImuErrors`.
    """

    def __init__(self, robot: Inertial, name: str, config: SensorConfig, errors: ImuErrors = ImuErrors()):
        super().__init__(robot.world, f"{robot.name}/{name}", config)
        self.robot = robot
        self.errors = errors
        k = self.noise_scale
        self.gyro_noise_std = errors.gyro_noise_std * k
        draw = self.rng.standard_normal(8)
        self.accel_bias = tuple(float(b) * errors.accel_bias_std * k for b in draw[:3])
        self.gyro_bias = tuple(float(b) * errors.gyro_bias_std * k for b in draw[3:6])
        self._att_std = errors.attitude_std * k
        self._att_tau = errors.attitude_tau
        # roll/pitch errors start from their stationary distribution; the heading error from 0
        self._att_err = [float(draw[6]) * self._att_std, float(draw[7]) * self._att_std, 0.0]
        self._t_err = robot.world.now
        self._ou_dt, self._ou = -1.0, (1.0, 0.0)

    def _advance_errors(self, now: float) -> None:
        """Propagate the attitude error to ``now`` (exact OU discretisation: e ← e·φ + σ√(1-φ²)·n)."""
        dt = now - self._t_err
        self._t_err = now
        e = self._att_err
        if self._att_std > 0.0:
            if dt != self._ou_dt:  # φ and the step σ of the last interval are reused (the autopilot's is fixed)
                phi = math.exp(-dt / self._att_tau)
                self._ou_dt, self._ou = dt, (phi, self._att_std * math.sqrt(1.0 - phi * phi))
            phi, s = self._ou
            n0, n1 = self.normals.take(2)
            e[0] = e[0] * phi + s * n0
            e[1] = e[1] * phi + s * n1
        e[2] += self.gyro_bias[2] * dt

    def sample(self) -> tuple[Vec3, Vec3, Quat]:
        """One measurement now in plain floats: ``(specific force (body), rates (body), orientation)``."""
        q, w_world, a_world = self.robot.inertial_truth()
        now = self.world.clock.steps / self.world.clock.physics_hz
        if now > self._t_err:
            self._advance_errors(now)
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = rotation_rows(q)
        ax, ay, az = a_world[0], a_world[1], a_world[2] + GRAVITY
        wx, wy, wz = w_world
        ba, bg = self.accel_bias, self.gyro_bias
        fx = r00 * ax + r10 * ay + r20 * az + ba[0]
        fy = r01 * ax + r11 * ay + r21 * az + ba[1]
        fz = r02 * ax + r12 * ay + r22 * az + ba[2]
        gx = r00 * wx + r10 * wy + r20 * wz + bg[0]
        gy = r01 * wx + r11 * wy + r21 * wz + bg[1]
        gz = r02 * wx + r12 * wy + r22 * wz + bg[2]
        sa, sg = self.config.noise_std, self.gyro_noise_std
        if sa > 0.0 or sg > 0.0:
            n0, n1, n2, n3, n4, n5 = self.normals.take(6)
            fx, fy, fz = fx + sa * n0, fy + sa * n1, fz + sa * n2
            gx, gy, gz = gx + sg * n3, gy + sg * n4, gz + sg * n5
        ex, ey, ez = self._att_err
        if ex or ey or ez:  # small world-frame error rotation applied on the left
            k = 0.5 / math.sqrt(1.0 + 0.25 * (ex * ex + ey * ey + ez * ez))
            q = quat_multiply((k * ex, k * ey, k * ez, 2.0 * k), q)
        return (fx, fy, fz), (gx, gy, gz), q

    def measure(self) -> ImuData:
        f, w, q = self.sample()
        return ImuData(np.array(f), np.array(w), np.array(q))
