"""Mobile manipulator of Narváez et al. (2020): Pioneer 3-DX base, 6-DoF arm, docking device.

The carrier of the VTOL-UAV docking system (§III-B, §V-B): a differential
Pioneer 3-DX (≤ 2 m/s, 10 kg payload) with a front Sick LMS111 LiDAR and a
front RealSense D435 RGB-D camera, and a 6-DoF Dynamixel arm on its top deck
whose first links are long (a broad vertical range for the contact phase).
The end effector carries the docking device's Part A (:mod:`.docking_device`)
and the PS Eye eye-in-hand camera, offset by ``O_C = [0.045, 0.01, 0.03]`` m
from the end-effector frame (eq. 1) and looking along Part A's approach axis,
so it sees a UAV hovering above Part A.

Geometry (``mobile_manipulator.urdf``): ``base_footprint`` on the floor,
``base_link`` at the base's centre of mass; ``arm_base`` (frame M of eq. 1,
on the top deck 0.24 m above the floor, 6 cm behind the centre) →
``arm_link_1`` … ``arm_link_5`` → ``end_effector`` (joint-6 flange) →
``part_a`` (mating face, z = approach direction) and ``eye_in_hand``
(OpenCV optical frame). ``lidar`` (scan plane = its x-y plane, 0.356 m above
the floor) and ``front_rgbd`` (optical frame, 0.41 m above the floor) face
forward. With all joints at zero the arm stands straight up (Part A 1.32 m
above the floor).

Arm control: each joint runs the per-joint PID "angle correction" loop of
§IV-B (:class:`ArmController`), limited to 15 rpm (§V-B) and to the stall
torque of its Dynamixel (URDF efforts), which hold a 0.5 kg UAV at the tip.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
import pybullet

from marsupial.api.errors import UnknownNameError
from marsupial.api.kinematics import ArmKinematics
from marsupial.api.model import DiffDriveLimits, Intrinsics, LidarSpec
from marsupial.api.views import CarrierView
from marsupial.geometry import Vector

from ..sensors.base import SensorConfig
from ..sensors.camera import Camera
from ..sensors.lidar import Lidar
from .arm import RPM, ArmController
from .docking_device import DockingDevice
from .encoders import JointEncoders
from .wheeled import WheeledRobot

if TYPE_CHECKING:
    from ..world import World
    from .base import Robot

ARM_JOINTS = tuple(f"arm_joint_{i}" for i in range(1, 7))
"""Arm joints, base to tip: yaw, shoulder pitch, elbow pitch, wrist roll, wrist pitch, flange roll."""
ARM_BASE_LINK = "arm_base"  # frame M of eq. (1)
PART_A_LINK = "part_a"
SENSOR_LINKS = {"eye_in_hand": "eye_in_hand", "front_rgbd": "front_rgbd", "lidar": "lidar"}
"""Link carrying each sensor (camera links are OpenCV optical frames; the LiDAR scans its x-y plane)."""

JOINT_SPEED_LIMIT = 15.0 * RPM  # rad/s: 15 rpm per joint, §V-B
PAYLOAD_KG = 10.0  # Pioneer 3-DX payload, §V-B-1

MOBILE_MANIPULATOR_LIMITS = DiffDriveLimits(
    max_speed=2.0,  # m/s, UGV longitudinal speed limit, §V-B-1
    max_omega=math.radians(100.0),  # rad/s, Pioneer 3-DX rotational speed (ARIA default)
    max_accel=1.0,  # m/s²
    max_alpha=2.0,  # rad/s²
)
"""Drive limits of the Pioneer 3-DX base."""

ARM_POSES: dict[str, tuple[float, ...]] = {
    # arm straight up; Part A 1.08 m above frame M
    "upright": (0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
    # folded over the rear deck for driving, Part A up, 0.74 m above the floor
    "stowed": (0.0, -1.55, 2.55, 0.0, -1.0, 0.0),
    # Part A and the eye-in-hand camera point up over the base centre, 0.95 m above the floor:
    # the initial-encounter pose (§IV, Fig. 3) with 0.35 m of upward range for the contact phase
    "docking_ready": (0.0, -0.87, 1.98, 0.0, -1.11, 0.0),
    # carries a docked UAV over the rear deck, Part A up 0.84 m above the floor: the UAV stays
    # behind the front RGB-D camera and above the LiDAR's scan plane (§IV-B, storage)
    "storage": (0.0, -1.3, 2.3, 0.0, -1.0, 0.0),
}
"""Named arm configurations (rad, :data:`ARM_JOINTS` order)."""

# default sensor settings; each can be overridden by name from the mission
_EYE_IN_HAND = {
    # PS Eye (§V-B): 640×480 at 60 Hz; its wide lens setting (75° horizontal) gives 60° vertically at 4:3
    "rate_hz": 60.0, "width": 640, "height": 480, "fov_v_deg": 60.0, "near": 0.02, "far": 10.0,
    # USB webcam: pixel noise (0-255), 1 % lost frames, 50 ms capture latency (chosen, see docs/world.md)
    "noise_std": 2.0, "dropout": 0.01, "latency_s": 0.05,
}
_FRONT_RGBD = {
    # RealSense D435 (§V-B): depth FOV 87°×58°, 0.1–10 m; 640×480 natively, 320×240 by default for speed
    "rate_hz": 30.0, "width": 320, "height": 240, "fov_v_deg": 58.0, "near": 0.1, "far": 10.0,
    "depth_noise_per_m": 0.02,  # 1σ depth error per metre of depth: RMS error ≤ 2 % at 2 m (D435 data sheet)
    "noise_std": 2.0, "latency_s": 0.05,  # chosen, see docs/world.md
}
_LIDAR = {
    # Sick LMS111-10100 (§V-B): 270°, 0.5° at 50 Hz, 20 m, 12 mm statistical error (1σ)
    "rate_hz": 50.0, "noise_std": 0.012,
    "beam_dropout": 0.002,  # lost echoes (dark, glossy or grazing surfaces; chosen)
}
DEPTH_CAMERAS = frozenset({"front_rgbd"})
"""Cameras whose depth image the carrier's computer receives (the PS Eye is a plain RGB webcam)."""


def _split_settings(
    sensor: str, settings: Mapping[str, Any], geometry: type
) -> tuple[dict[str, Any], dict[str, Any], dict[str, Any]]:
    """Split ``settings`` into SensorConfig fields, ``geometry`` fields and extra camera options."""
    config_fields = {f.name for f in dataclasses.fields(SensorConfig)}
    geometry_fields = {f.name for f in dataclasses.fields(geometry)}
    camera_options = {"segmentation", "depth_noise_per_m"} if geometry is Intrinsics else set()
    known = config_fields | geometry_fields | camera_options
    unknown = set(settings) - known
    if unknown:
        raise ValueError(f"unknown setting(s) {sorted(unknown)} of sensor '{sensor}'; expected some of {sorted(known)}")

    def pick(names: set[str]) -> dict[str, Any]:
        return {k: v for k, v in settings.items() if k in names}

    return pick(config_fields), pick(geometry_fields), pick(camera_options)


def _sensor_specs(kind: str, overrides: Mapping[str, Mapping[str, Any]]) -> dict[str, tuple[Any, ...]]:
    """``(SensorConfig, Intrinsics or LidarSpec, extra camera options)`` of each sensor, defaults + ``overrides``."""
    defaults = {"eye_in_hand": _EYE_IN_HAND, "front_rgbd": _FRONT_RGBD, "lidar": _LIDAR}
    for sensor in overrides:
        if sensor not in defaults:
            raise UnknownNameError(f"sensor of {kind}", sensor, defaults)
    specs = {}
    for sensor, default in defaults.items():
        geometry = LidarSpec if sensor == "lidar" else Intrinsics
        config, shape, extra = _split_settings(sensor, {**default, **overrides.get(sensor, {})}, geometry)
        specs[sensor] = (SensorConfig(**config), geometry(**shape), extra)
    return specs


def _docking_settings(settings: Mapping[str, Any]) -> dict[str, Any]:
    """``settings`` checked against the keyword parameters of :class:`DockingDevice`."""
    known = [p.name for p in inspect.signature(DockingDevice).parameters.values() if p.kind is p.KEYWORD_ONLY]
    unknown = set(settings) - set(known)
    if unknown:
        raise ValueError(f"unknown docking setting(s) {sorted(unknown)}; expected some of {known}")
    return dict(settings)


class MobileManipulator(WheeledRobot):
    """Pioneer 3-DX + 6-DoF arm + docking device Part A + eye-in-hand, front RGB-D and LiDAR sensors.

    Args:
        pose: ``[x, y]``, ``[x, y, yaw]`` or ``[x, y, z, yaw]`` of ``base_footprint`` (world frame).
        limits: drive limits replacing :data:`MOBILE_MANIPULATOR_LIMITS`, whole or by field.
        arm_pose: initial arm configuration: a name of :data:`ARM_POSES` or 6 joint angles (rad).
        sensors: per-sensor setting overrides, e.g.
            ``{"eye_in_hand": {"width": 320, "height": 240}, "lidar": {"noise_std": 0.0}}``.
            Cameras accept ``rate_hz, noise_std, dropout, latency_s, width, height,
            fov_v_deg, near, far, segmentation, depth_noise_per_m``; the LiDAR accepts
            ``rate_hz, noise_std, dropout, latency_s, fov_deg, resolution_deg,
            max_range, start_range, beam_dropout``.
        docking: keyword overrides of :class:`DockingDevice` (e.g. ``{"capture_distance": 0.02}``).
        localization: ``"odometry"`` or ``"map"`` (see :class:`WheeledRobot`).

    Attributes:
        arm: the joint PID controller (:class:`ArmController`).
        arm_kinematics: pinocchio model of the chain ``arm_base`` → ``part_a`` (same URDF).
        docking: the docking device (Part A on ``part_a``).
        eye_in_hand, front_rgbd: :class:`Camera` sensors; lidar: :class:`Lidar`.
    """

    kind = "mobile_manipulator"
    view_class = CarrierView
    #: the named arm poses its computer knows (rad)
    arm_poses: Mapping[str, tuple[float, ...]] = ARM_POSES

    @classmethod
    def declared_sensors(cls) -> frozenset[str] | None:
        """The eye-in-hand camera, the front RGB-D camera and the LiDAR."""
        return frozenset(SENSOR_LINKS)
    urdf = "mobile_manipulator.urdf"
    default_limits = MOBILE_MANIPULATOR_LIMITS
    payload_kg = PAYLOAD_KG

    def __init__(
        self,
        world: World,
        name: str,
        pose: Vector = (0.0, 0.0, 0.0),
        limits: DiffDriveLimits | Mapping[str, float] | None = None,
        localization: str = "odometry",
        arm_pose: str | Vector = "stowed",
        sensors: Mapping[str, Mapping[str, Any]] | None = None,
        docking: Mapping[str, Any] | None = None,
    ):
        sensor_specs = _sensor_specs(self.kind, sensors or {})  # bad settings fail before anything is built
        docking_settings = _docking_settings(docking or {})
        initial_q = self._configuration(arm_pose)
        super().__init__(world, name, pose=pose, limits=limits, localization=localization)
        cid = self.cid
        joints = {}
        for j in range(pybullet.getNumJoints(self.body_id, physicsClientId=cid)):
            info = pybullet.getJointInfo(self.body_id, j, physicsClientId=cid)
            joints[info[1].decode()] = info
        self.joint_indices = [joints[n][0] for n in ARM_JOINTS]
        self.lower = np.array([joints[n][8] for n in ARM_JOINTS])
        self.upper = np.array([joints[n][9] for n in ARM_JOINTS])
        self.max_torque = np.array([joints[n][10] for n in ARM_JOINTS])
        self.arm = ArmController(
            world,
            self.body_id,
            self.joint_indices,
            list(zip(self.lower, self.upper, strict=True)),
            max_speed=JOINT_SPEED_LIMIT,
            max_torque=self.max_torque,
        )
        self.arm_kinematics = ArmKinematics.from_urdf(self.urdf, ARM_BASE_LINK, PART_A_LINK)
        self.reset_arm(initial_q)
        self.encoders = JointEncoders(world, f"{name}/arm")
        self.docking = DockingDevice(self, PART_A_LINK, **docking_settings)
        self._add_sensors(sensor_specs)

    def _add_sensors(self, specs: dict[str, tuple[Any, ...]]) -> None:
        def camera(name: str) -> Camera:
            config, intrinsics, extra = specs[name]
            link = SENSOR_LINKS[name]
            return Camera(
                self, name, intrinsics, config, link=link, R_link_optical=np.eye(3),
                measures_depth=name in DEPTH_CAMERAS, **extra,
            )

        config, spec, _ = specs["lidar"]
        self.eye_in_hand: Camera = self.add_sensor(camera("eye_in_hand"))  # type: ignore[assignment]
        self.front_rgbd: Camera = self.add_sensor(camera("front_rgbd"))  # type: ignore[assignment]
        self.lidar: Lidar = self.add_sensor(  # type: ignore[assignment]
            Lidar(self, "lidar", spec, config, link=SENSOR_LINKS["lidar"])
        )

    def store(self, uav: Robot) -> None:
        """Start the run with ``uav`` stored: arm in the ``storage`` pose, UAV locked on Part A, charging."""
        self.reset_arm("storage")
        self.docking.attach_now(uav)

    # ------------------------------------------------------------------ arm
    @staticmethod
    def arm_pose(name: str) -> np.ndarray:
        """Joint angles (rad) of the named arm pose; the error lists :data:`ARM_POSES`."""
        try:
            return np.array(ARM_POSES[name])
        except KeyError:
            raise UnknownNameError("arm pose", name, ARM_POSES) from None

    @classmethod
    def _configuration(cls, q: str | Vector) -> np.ndarray:
        if isinstance(q, str):
            return cls.arm_pose(q)
        q = np.asarray(q, dtype=float)
        if q.shape != (len(ARM_JOINTS),):
            raise ValueError(
                f"expected {len(ARM_JOINTS)} joint angles ({', '.join(ARM_JOINTS)}) or a pose name, got shape {q.shape}"
            )
        return q

    @property
    def joint_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper joint limits (rad), :data:`ARM_JOINTS` order."""
        return self.lower.copy(), self.upper.copy()

    def set_joint_targets(self, q: str | Vector) -> None:
        """Move the arm toward ``q`` (6 angles in rad, or a name of :data:`ARM_POSES`), clipped to the limits."""
        self.arm.set_targets(self._configuration(q))
    def hold_arm(self) -> None:
        """Hold every arm joint where it is now."""
        self.arm.hold()

    def reset_arm(self, q: str | Vector) -> None:
        """Teleport the arm to ``q`` (angles or pose name) at rest and hold it there (scene set-up only)."""
        self.arm.reset(np.clip(self._configuration(q), self.lower, self.upper))

    def joint_positions(self) -> np.ndarray:
        """Arm joint angles now (rad)."""
        return self.arm.positions()
    def arm_encoders(self) -> np.ndarray:
        """Arm joint angles as the joint encoders read them (rad; Dynamixel 12-bit, :mod:`.encoders`)."""
        return self.encoders.read(self.arm.positions())

    def joint_velocities(self) -> np.ndarray:
        """Arm joint speeds now (rad/s)."""
        return self.arm.velocities()

    def joint_targets(self) -> np.ndarray:
        """Arm joint targets being tracked (rad)."""
        return self.arm.targets.copy()

    def arm_at_target(self, tolerance: float = 0.01) -> bool:
        """True when every joint is within ``tolerance`` rad of its target."""
        return bool(np.all(np.abs(self.arm.targets - self.arm.positions()) <= tolerance))

    def arm_base_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """World pose of frame M (``arm_base``): position (m), quaternion ``[x, y, z, w]``."""
        return self.link_pose(ARM_BASE_LINK)

    # ------------------------------------------------------------ stepping
    def pre_physics(self, dt: float) -> None:
        """Advance the base drive, the arm PID loops and the docking device by one physics step."""
        super().pre_physics(dt)
        self.arm.pre_physics(dt)
        self.docking.pre_physics(dt)

    def safe_stop(self) -> None:
        """Stop the base and hold the arm where it is (a docked UAV stays locked)."""
        self.stop()
        self.hold_arm()

    def state(self) -> dict[str, Any]:
        """Base pose and speeds, arm joint angles and targets (rad), docking device status."""
        state = super().state()
        state.update(
            joints=self.joint_positions().tolist(),
            joint_targets=self.arm.targets.tolist(),
            docking=self.docking.status(),
        )
        return state
