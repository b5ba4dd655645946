"""What a robot's computer receives: sensor samples, state estimates, device states and team-link messages.

Every reading is data (frozen dataclasses of numbers and numpy arrays)
holding only what the sensor or device measures: a camera frame has
pixels, intrinsics and its stamp, never the true camera pose or a
segmentation; a LiDAR scan has ranges and beam angles, never body ids.
Times are simulated seconds; frames as named on each field.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Generic, TypeVar

import numpy as np

from marsupial.geometry import rotation_matrix, yaw_of

T = TypeVar("T")


@dataclass(frozen=True)
class Reading(Generic[T]):
    """One sample: the simulated time it was taken (s) and its data."""

    stamp: float
    data: T


@dataclass(frozen=True)
class StateEstimate:
    """One onboard estimate of a robot's base (ground robots: its ``base_footprint``).

    Attributes:
        stamp: simulated time (s) of the estimate.
        frame: navigation frame (``"odom"`` or ``"map"``).
        position: position (m) in ``frame``.
        orientation: ``[x, y, z, w]`` quaternion of the body in ``frame``.
        velocity: linear velocity (m/s) in ``frame``.
        angular_velocity: body rates (rad/s, body frame).
        source: what produced it (e.g. ``"imu+flow+sonar+baro"``, ``"wheel_odometry"``, ``"map_localization"``).
        frame_shift: corrections by which external fixes have moved ``frame`` under the body so far,
            ``(x, y, z (m), yaw (rad))``, cumulated (PX4 publishes its estimator's resets likewise); a consumer
            that propagates with the estimate subtracts their change to get a smooth trajectory.
    """

    stamp: float
    frame: str
    position: np.ndarray
    orientation: np.ndarray
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    angular_velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    source: str = ""
    frame_shift: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)

    @property
    def yaw(self) -> float:
        """Heading (rad) about the frame's z axis."""
        return yaw_of(self.orientation)

    @property
    def rotation(self) -> np.ndarray:
        """``R_frame_body`` (3×3)."""
        return rotation_matrix(self.orientation)

    @property
    def speed(self) -> float:
        """Horizontal speed (m/s)."""
        return math.hypot(float(self.velocity[0]), float(self.velocity[1]))

    def to_dict(self) -> dict[str, object]:
        """JSON-ready form (for logs and the team link)."""
        return {
            "stamp": self.stamp,
            "frame": self.frame,
            "position": [float(v) for v in self.position],
            "orientation": [float(v) for v in self.orientation],
            "velocity": [float(v) for v in self.velocity],
            "angular_velocity": [float(v) for v in self.angular_velocity],
            "source": self.source,
            "frame_shift": [float(v) for v in self.frame_shift],
        }


@dataclass(frozen=True)
class BatteryStatus:
    """One battery-gauge sample: SOC (%), terminal voltage (V), current (A, > 0 discharging)."""

    soc_percent: float
    voltage: float
    current: float


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
    (``robot.link_offset("lidar")``), not the simulator's sensor pose.
    """

    ranges: np.ndarray
    angles: np.ndarray
    max_range: float

    def points_sensor(self) -> np.ndarray:
        """``(m, 2)`` x, y (m, sensor frame) of the beams that returned an echo."""
        hit = np.isfinite(self.ranges)
        r, a = self.ranges[hit], self.angles[hit]
        return np.stack((r * np.cos(a), r * np.sin(a)), axis=1)


VISION_FIX = "vision_fix"


def vision_fix_topic(uav: str) -> str:
    """Team-link topic of the vision fixes of ``uav`` (``"<uav>/vision_fix"``)."""
    return f"{uav}/{VISION_FIX}"


@dataclass(frozen=True)
class VisionFix:
    """One external measurement of a UAV's base pose, as its observer sends it over the team link.

    Attributes:
        stamp: time (s, simulated) the measurement was taken (the camera frame's stamp).
        position: UAV base position (m) in the sender's navigation frame N.
        yaw: UAV heading (rad) about N's z axis.
        source: what measured it (e.g. ``"carrier/eye_in_hand"``).
    """

    stamp: float
    position: tuple[float, float, float]
    yaw: float
    source: str = ""


@dataclass(frozen=True)
class LinkMessage:
    """One delivered message: sender, topic, send and delivery times (s), payload."""

    sender: str
    topic: str
    sent: float
    delivered: float
    payload: Any


@dataclass(frozen=True)
class DockingStatus:
    """Part A's docking device as its switches and coil report it (Narváez §IV-C).

    Attributes:
        magnet: the coil is energised.
        contact_switch: a Part B rests seated in the cone (the limit switch under Part A's face).
        locked: the levers hold a UAV (their end switch).
        locking: the levers are closing.
        charging: the charger delivers current to a locked UAV (its current sense, §V-A).
        state: ``"locked"``, ``"magnet"`` or ``"open"``.
    """

    magnet: bool
    contact_switch: bool
    locked: bool
    locking: bool
    charging: bool
    state: str


@dataclass(frozen=True)
class RobotReadings:
    """What one robot's computer has at a tick: its estimates, device states and the sensors asked for.

    Fields a robot kind does not have stay ``None`` (or ``False``/0).

    Attributes:
        stamp: simulated time (s) of the snapshot.
        estimate: the onboard state estimate (its navigation frame, see :class:`StateEstimate`).
        odometry: a ground robot's wheel odometry (frame ``odom``), its dead reckoning behind a map localiser.
        motors_on: a quadrotor's flight controller reports its motors running.
        docked: a quadrotor's dock-lock signal (a docking device holds it).
        thrust: total thrust (N) the flight controller commands (0 with the motors off).
        wheel_speed: forward speed (m/s) from the wheel encoders.
        joint_positions: arm joint angles (rad) from the joint encoders, base to tip.
        joint_targets: arm joint targets being tracked (rad).
        gripper_opening: gap between the fingers (m), from their encoder.
        platform_height: a lift's platform height (m), from its encoder.
        platform_occupied: a lift's load switch: a child stands wholly on the plate.
        docking: Part A's switches and coil (a carrier).
        sensors: newest readable sample of each sensor asked for (short name), ``None`` before the first.
        streams: every sample of each queued sensor stamped since the previous snapshot, oldest first.
    """

    stamp: float
    estimate: StateEstimate | None = None
    odometry: StateEstimate | None = None
    motors_on: bool = False
    docked: bool = False
    thrust: float = 0.0
    wheel_speed: float = 0.0
    joint_positions: np.ndarray | None = None
    joint_targets: np.ndarray | None = None
    gripper_opening: float | None = None
    platform_height: float | None = None
    platform_occupied: bool = False
    docking: DockingStatus | None = None
    sensors: dict[str, Reading[Any] | None] = field(default_factory=dict)
    streams: dict[str, tuple[Reading[Any], ...]] = field(default_factory=dict)


@dataclass(frozen=True)
class ImuData:
    """One IMU sample.

    Attributes:
        linear_acceleration: specific force (m/s², body frame), includes the gravity reaction.
        angular_velocity: body rates (rad/s, body frame).
        orientation: ``[x, y, z, w]`` quaternion of the body in the world frame, as the attitude filter outputs it.
    """

    linear_acceleration: np.ndarray
    angular_velocity: np.ndarray
    orientation: np.ndarray


@dataclass(frozen=True)
class RangeData:
    """One range sample: distance to the first echo (m, ``inf`` if none) and the beam's geometry."""

    range: float
    half_angle: float  # rad, beam cone half-angle
    min_range: float  # m, shorter echoes read as min_range
    max_range: float  # m


@dataclass(frozen=True)
class FlowData:
    """One optical-flow sample.

    Attributes:
        valid: False when no surface is in range (the velocity is then 0).
        vx, vy: velocity relative to the surface (m/s), heading frame (x forward, y left).
        range: median depth (m) of the surface along the camera axis, by which the device scaled the flow
            (``inf`` if none).
    """

    valid: bool
    vx: float
    vy: float
    range: float
