"""Downward optical-flow velocity sensor (PX4Flow-like, or a drone's vertical camera with its flow firmware).

The device tracks the texture under a downward camera and scales the image
flow by its range to the surface, so what it measures is the vehicle's
velocity *relative to the surface under the camera*: over a moving
platform it reads the velocity relative to the platform. It is modelled by
five rays from the camera, one along the body's -z axis and four towards
the corners of a square field of half-angle ``FLOW_HALF_ANGLE``: for each,
the body (and link) hit and its pybullet velocity at the hit point give
the vehicle's velocity relative to that point of the surface (the field's
half-angle is the static fact ``half_angle`` of the sensor's port); the device
reports the per-axis median of the rays that hit (the texture that fills
most of the view wins: a small platform far below hardly moves the flow,
a platform filling the view carries it), in the heading frame (x forward,
y left, horizontal: the firmware derotates the flow with the gyro and the
attitude). Fewer than three hits: invalid.

Errors (scaled by ``world.noise_scale``; sources in ``docs/world.md``):
white noise of 1σ ``config.noise_std + noise_per_m · range`` (m/s per axis:
the flow in pixels shrinks with height, so its metric noise grows), a
per-run scale error (1σ ``scale_std``: lens and range calibration) and a
slowly varying bias per axis (Ornstein–Uhlenbeck, 1σ ``bias_std``, time
constant ``bias_tau``: texture and lighting under the camera), which no
other sensor observes, so the integrated position drifts. No
surface within ``max_range`` or nearer than ``min_range`` (out of focus):
the sample is invalid.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import pybullet

from marsupial.api.readings import FlowData

from .base import Sensor, SensorConfig

if TYPE_CHECKING:
    from ..robots.base import Robot


FLOW_HALF_ANGLE = math.radians(15.0)  # rad, the part of the vertical camera's view the flow is measured in (chosen)


class OpticalFlow(Sensor[FlowData]):
    """Optical flow of ``robot`` (base-frame camera origin ``offset``): see the module docstring.

    Args:
        noise_per_m: growth of the velocity noise with range ((m/s)/m).
        scale_std: 1σ per-run scale error (fraction).
        bias_std, bias_tau: 1σ (m/s) and time constant (s) of the slowly varying bias.
        min_range, max_range: ranges (m) within which the flow is valid.
    """

    def __init__(
        self,
        robot: Robot,
        name: str,
        config: SensorConfig,
        noise_per_m: float,
        scale_std: float,
        min_range: float,
        max_range: float,
        offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
        bias_std: float = 0.0,
        bias_tau: float = 30.0,
    ):
        super().__init__(robot.world, f"{robot.name}/{name}", config)
        self.robot = robot
        self.noise_per_m = noise_per_m * self.noise_scale
        self.scale = 1.0 + scale_std * self.noise_scale * float(self.rng.standard_normal())
        self.min_range = min_range
        self.max_range = max_range
        self.offset = tuple(float(v) for v in offset)
        self.half_angle = FLOW_HALF_ANGLE  # static fact (datasheet): half-angle of the square flow field, rad
        self._static: set[int] = set()  # static bodies of this world seen under the camera
        # ray ends (base frame, relative to the origin) reaching max_range vertically below the camera
        t = math.tan(FLOW_HALF_ANGLE)
        directions = [(0.0, 0.0, -1.0)] + [(sx * t, sy * t, -1.0) for sx in (-1.0, 1.0) for sy in (-1.0, 1.0)]
        self._rays = [(dx * max_range, dy * max_range, dz * max_range) for dx, dy, dz in directions]
        self.bias_std, self.bias_tau = bias_std * self.noise_scale, bias_tau
        self.bias = [self.bias_std * float(b) for b in self.rng.standard_normal(2)]  # stationary start
        self._t_bias = robot.world.now

    def _advance_bias(self) -> None:
        """OU step of the bias to now: b ← b φ + σ √(1 - φ²) n, φ = exp(-Δt / τ)."""
        now = self.world.now
        if self.bias_std > 0.0 and now > self._t_bias:
            phi = math.exp(-(now - self._t_bias) / self.bias_tau)
            s = self.bias_std * math.sqrt(1.0 - phi * phi)
            n0, n1 = self.normals.take(2)
            self.bias[0] = self.bias[0] * phi + s * n0
            self.bias[1] = self.bias[1] * phi + s * n1
        self._t_bias = now

    def measure(self) -> FlowData:
        cid, own = self.world.client_id, self.robot.body_id
        p, q, v, _ = self.robot.base_state()
        x, y, z, w = q
        r00, r01, r02 = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)  # R_world_body
        r10, r11, r12 = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
        r20, r21, r22 = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
        ox, oy, oz = self.offset
        origin = (
            p[0] + r00 * ox + r01 * oy + r02 * oz,
            p[1] + r10 * ox + r11 * oy + r12 * oz,
            p[2] + r20 * ox + r21 * oy + r22 * oz,
        )
        ends = [
            (origin[0] + r00 * dx + r01 * dy + r02 * dz, origin[1] + r10 * dx + r11 * dy + r12 * dz,
             origin[2] + r20 * dx + r21 * dy + r22 * dz)
            for dx, dy, dz in self._rays
        ]
        hits = pybullet.rayTestBatch([origin] * len(ends), ends, physicsClientId=cid)
        rel_x, rel_y, ranges = [], [], []
        for body, link, fraction, point, _ in hits:
            distance = fraction * self.max_range  # along the camera axis (every ray reaches max_range in depth)
            if body < 0 or body == own or distance < self.min_range:
                continue
            sx, sy = _surface_velocity(body, link, point, cid, self._static)
            rel_x.append(v[0] - sx)
            rel_y.append(v[1] - sy)
            ranges.append(distance)
        if len(ranges) < 3:
            return FlowData(False, 0.0, 0.0, math.inf)
        dvx, dvy, distance = _median(rel_x), _median(rel_y), _median(ranges)
        yaw = math.atan2(r10, r00)
        c, s = math.cos(yaw), math.sin(yaw)
        self._advance_bias()
        vx = self.scale * (c * dvx + s * dvy) + self.bias[0]
        vy = self.scale * (-s * dvx + c * dvy) + self.bias[1]
        std = self.config.noise_std + self.noise_per_m * distance
        if std > 0.0:
            n0, n1 = self.normals.take(2)
            vx, vy = vx + std * n0, vy + std * n1
        return FlowData(True, vx, vy, distance)


def _median(values: list[float]) -> float:
    """Median of 3–5 values."""
    ordered = sorted(values)
    n = len(ordered)
    return ordered[n // 2] if n % 2 else 0.5 * (ordered[n // 2 - 1] + ordered[n // 2])


def _surface_velocity(
    body: int, link: int, point: tuple[float, float, float], cid: int, static: set[int]
) -> tuple[float, float]:
    """Horizontal world velocity (m/s) of ``point`` on ``body``'s ``link`` (rigid-body: v + ω × r).

    ``static`` collects the ids of massless single-body bodies (floor, walls) met so far: they never move.
    """
    if body in static:
        return 0.0, 0.0
    if (
        link < 0
        and pybullet.getNumJoints(body, physicsClientId=cid) == 0
        and pybullet.getDynamicsInfo(body, -1, physicsClientId=cid)[0] == 0.0
    ):
        static.add(body)
        return 0.0, 0.0
    if link < 0:
        (vx, vy, _), (wx, wy, wz) = pybullet.getBaseVelocity(body, physicsClientId=cid)
        if not (vx or vy or wx or wy or wz):
            return 0.0, 0.0
        com = pybullet.getBasePositionAndOrientation(body, physicsClientId=cid)[0]
    else:
        state = pybullet.getLinkState(body, link, computeLinkVelocity=1, physicsClientId=cid)
        com, (vx, vy, _), (wx, wy, wz) = state[0], state[6], state[7]
    rx, ry, rz = point[0] - com[0], point[1] - com[1], point[2] - com[2]
    return vx + wy * rz - wz * ry, vy + wz * rx - wx * rz
