"""What a robot's designers know: datasheet limits, sensor geometry and mounts, the robot's static model.

A robot view (:mod:`marsupial.api.views`) carries its robot's
:class:`RobotModel`, built once by the world from the robot's URDF and
datasheets: link offsets in the base frame, each sensor's facts
(:class:`SensorFacts`), drive and flight limits, named arm poses. Frames:
a link offset is the link's position (m) and rotation in the robot's base
frame as the URDF places it (rigid links, the arm at its reference pose).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .errors import UnknownNameError

# The UGV docking robots' design figures (Zhao et al., Table 1), shared by the world's models and the skills
ENTRANCE_WIDTH_M = 0.19  # b_e: the docking station's entrance slot (mother_ugv.urdf)
CAMERA_RESOLUTION = (640, 480)  # W × H of the child's camera
CAMERA_FOV_V_DEG = 61.0  # θ_f, the child camera's vertical field of view


@dataclass(frozen=True)
class FlightLimits:
    """What the autopilot allows (vendor SDK settings).

    Attributes:
        max_speed_xy: horizontal speed limit (m/s).
        max_speed_z: vertical speed limit (m/s).
        max_yaw_rate: yaw rate limit (rad/s).
        max_tilt: roll/pitch limit (rad).
        accel_ref: horizontal acceleration of the velocity reference (m/s²).
        accel_ref_z: vertical acceleration of the velocity reference (m/s²).
        thrust_to_weight: maximum thrust over weight.
    """

    max_speed_xy: float
    max_speed_z: float
    max_yaw_rate: float
    max_tilt: float
    accel_ref: float
    accel_ref_z: float = 2.0
    thrust_to_weight: float = 2.0


@dataclass(frozen=True)
class DiffDriveLimits:
    """Motion limits and slip of a base (SI units).

    Attributes:
        max_speed: |v| limit (m/s).
        max_omega: |omega| limit (rad/s).
        max_accel: |dv/dt| limit (m/s²).
        max_alpha: |domega/dt| limit (rad/s²).
        slip: fraction of the commanded speed lost to wheel slip (0 = none).
        drift_per_rad: lateral drift speed per (m/s · rad/s) while turning (m/s).
        noise_std: standard deviation of the seeded speed noise (m/s, and rad/s on omega).
        max_force: force (N) the drive constraint may exert; walls stronger than it stop the base.
        resync_m: distance (m) between body and reference beyond which the reference resyncs.
        turn_slip: fraction of the commanded yaw rate lost to wheel scrub (0 = none).
    """

    max_speed: float
    max_omega: float
    max_accel: float = 1.0
    max_alpha: float = 2.0
    slip: float = 0.0
    drift_per_rad: float = 0.0
    noise_std: float = 0.0
    max_force: float = 5000.0
    resync_m: float = 0.05
    turn_slip: float = 0.0


@dataclass(frozen=True)
class LidarSpec:
    """Geometry of a scanner; the defaults are a Sick LMS111-10100 (Narváez §V-B).

    Attributes:
        fov_deg: angular field of view (deg), centred on the sensor's +x axis.
        resolution_deg: angle between beams (deg); the LMS111 gives 0.5° at 50 Hz.
        max_range: farthest echo (m).
        start_range: distance (m) from the sensor origin where beams start (outside the housing).
        beam_dropout: probability in [0, 1] that one beam returns no echo.
    """

    fov_deg: float = 270.0
    resolution_deg: float = 0.5
    max_range: float = 20.0
    start_range: float = 0.06
    beam_dropout: float = 0.0

    def __post_init__(self) -> None:
        if not 0.0 < self.fov_deg <= 360.0 or self.resolution_deg <= 0.0:
            raise ValueError(
                f"fov_deg must be in (0, 360] and resolution_deg > 0; got {self.fov_deg}, {self.resolution_deg}"
            )
        if not 0.0 <= self.start_range < self.max_range:
            raise ValueError(f"need 0 <= start_range < max_range; got {self.start_range}, {self.max_range}")
        if not 0.0 <= self.beam_dropout <= 1.0:
            raise ValueError(f"beam_dropout must be within [0, 1], got {self.beam_dropout}")

    def angles(self) -> np.ndarray:
        """Beam angles (rad, float32), counter-clockwise from the sensor's +x axis."""
        half = math.radians(self.fov_deg) / 2.0
        step = math.radians(self.resolution_deg)
        n = int(round(2.0 * half / step)) + 1
        if self.fov_deg == 360.0:  # a full turn would count the seam twice
            n -= 1
        return (-half + step * np.arange(n)).astype(np.float32)


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics from resolution and vertical field of view.

    ``fy = (height / 2) / tan(fov_v / 2)``, square pixels (``fx = fy``),
    principal point at the image centre ``((w-1)/2, (h-1)/2)`` in OpenCV's
    pixel convention. ``near``/``far`` clip depth (m).
    """

    width: int
    height: int
    fov_v_deg: float
    near: float = 0.02
    far: float = 30.0

    @property
    def K(self) -> np.ndarray:
        """3×3 camera matrix in pixels."""
        f = (self.height / 2.0) / math.tan(math.radians(self.fov_v_deg) / 2.0)
        return np.array([[f, 0.0, (self.width - 1) / 2.0], [0.0, f, (self.height - 1) / 2.0], [0.0, 0.0, 1.0]])



@dataclass(frozen=True)
class SensorFacts:
    """Static facts of one sensor as its datasheet and its mount give them (no state, no truth).

    Attributes:
        name: short name on its robot (``"camera"``, ``"lidar"``, ``"sonar"`` …).
        kind: what it is (``"camera"``, ``"lidar"``, ``"sonar"``, ``"imu"``, ``"flow"``, ``"barometer"``,
            ``"battery"``, …).
        rate_hz: samples per simulated second.
        link: the URDF link it is mounted on (``None``: the base).
        offset: mount position (m) in that link's frame.
        R_link_optical: a camera's optical frame in the link frame (OpenCV axes), or the sensor's rotation.
        intrinsics: a camera's :class:`Intrinsics` (``None`` for other sensors).
        measures_depth: a camera that measures depth (RGB-D).
        half_angle: half-angle (rad) of a sonar's beam or an optical-flow field.
        min_range: nearest measurable distance (m).
        max_range: farthest measurable distance (m).
        spec: a LiDAR's :class:`LidarSpec`.
        queued: its samples come as a stream (``read_since``), not only the newest (all but cameras and LiDARs).
    """

    name: str
    kind: str
    rate_hz: float
    link: str | None = None
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    R_link_optical: np.ndarray | None = None
    intrinsics: Intrinsics | None = None
    measures_depth: bool = False
    half_angle: float | None = None
    min_range: float | None = None
    max_range: float | None = None
    spec: LidarSpec | None = None
    queued: bool = True

    @property
    def K(self) -> np.ndarray:
        """A camera's 3×3 intrinsic matrix (pixels); an error for other sensors."""
        if self.intrinsics is None:
            raise AttributeError(f"sensor '{self.name}' is a {self.kind}, not a camera: it has no intrinsics K")
        return self.intrinsics.K


@dataclass(frozen=True)
class RobotModel:
    """One team member as its designers describe it: kind, links, sensors, limits and device facts.

    Attributes:
        name: team name (``"uav"``, ``"carrier"``).
        kind: robot kind (``"bebop2"``, ``"mobile_manipulator"`` …).
        links: every URDF link's offset in the base frame: position (m), 3×3 rotation.
        sensors: each sensor's facts, by short name.
        limits: flight (:class:`FlightLimits`) or drive (:class:`DiffDriveLimits`) limits.
        mass: take-off / total mass (kg) from the datasheet (0: not given).
        battery_capacity_mAh: the pack's capacity (0: no battery).
        platform_size: a landing platform's length and width (m).
        lift_travel: a lifting platform's height at the storage capsule (m).
        capture_distance: the docking magnet's reach (m).
        joint_limits: arm joint limits, lower and upper (rad).
        arm_poses: named arm poses (rad).
        arm_base_link: frame M, the link the arm's poses are expressed in.
        arm_tip_link: the arm chain's last link.
        urdf: the asset file of the robot's model (for kinematics built from it).
    """

    name: str
    kind: str
    links: Mapping[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    sensors: Mapping[str, SensorFacts] = field(default_factory=dict)
    limits: FlightLimits | DiffDriveLimits | None = None
    mass: float = 0.0
    battery_capacity_mAh: float = 0.0
    platform_size: tuple[float, float] | None = None
    lift_travel: float | None = None
    capture_distance: float | None = None
    joint_limits: tuple[np.ndarray, np.ndarray] | None = None
    arm_poses: Mapping[str, np.ndarray] = field(default_factory=dict)
    arm_base_link: str | None = None
    arm_tip_link: str | None = None
    urdf: str | None = None
    extra: Mapping[str, Any] = field(default_factory=dict)

    def link_offset(self, link: str) -> tuple[np.ndarray, np.ndarray]:
        """Position (m) and rotation of ``link`` in the base frame, from the URDF; the error lists the links."""
        try:
            p, R = self.links[link]
        except KeyError:
            raise UnknownNameError(f"link of {self.kind}", link, self.links) from None
        return p.copy(), R.copy()

    def sensor(self, name: str) -> SensorFacts:
        """The facts of the sensor ``name`` (short name); the error lists the robot's sensors."""
        try:
            return self.sensors[name]
        except KeyError:
            raise UnknownNameError(f"sensor of {self.name}", name, self.sensors) from None
