"""Onboard interfaces: what a robot's own computer has, and all that a skill may use of a robot.

The sensing boundary (``docs/world.md``, "Sensing boundary"): a robot is a
body (its true pose, velocity and contacts, used only by the world, the
sensors, the recorder and scoring) plus an onboard interface, built here:

- sensor readings (:class:`SensorPort`: camera images without their true
  pose, depth, LiDAR scans, sonar, IMU, barometer, battery monitor);
- the robot's state estimate (:class:`~marsupial.world.estimation.StateEstimate`), and the
  message with which a team member corrects a UAV's
  (:class:`~marsupial.world.estimation.external.VisionFix`, on the team link);
- the states its devices report (motor arming, docking switches, magnet,
  lift encoder) and its joint and wheel encoders;
- its command inputs (:attr:`Onboard.commands`, each driving one of the
  robot's resources, :data:`~marsupial.world.capabilities.RESOURCES`) and
  the per-resource safe stop (:meth:`Onboard.safe_stop`);
- its static model: mount extrinsics, URDF link offsets, arm kinematics,
  limits — what its designers wrote down, not what the world measures.

An interface keeps its robot in a private slot and offers no attribute that
leads to the world, pybullet or a truth accessor; a test runs every shipped
mission with truth calls from skill code trapped
(``tests/test_sensing_boundary.py``). Frames and units as in
:mod:`marsupial.world.estimation.base`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from types import CodeType
from typing import TYPE_CHECKING, Any, ClassVar, TypeVar

import numpy as np

from marsupial.geometry import quaternion_from_matrix, rotation_matrix

from .estimation.base import StateEstimate
from .estimation.external import VisionFix, vision_fix_topic  # noqa: F401 (the message a team member sends a UAV's estimator)
from .sensor_port import SENSOR_FACTS, CameraImage, RangeScan, SensorPort  # noqa: F401 (part of this interface)

if TYPE_CHECKING:
    from .robots.base import Robot


F = TypeVar("F", bound=Callable[..., Any])

#: code of the world-side functions that simulate a piece of hardware (an encoder, a switch, a servo)
HARDWARE_CODE: set[CodeType] = set()


def simulates_hardware(function: F) -> F:
    """Mark a world-side function that simulates hardware and may therefore read simulator truth.

    An encoder reading, a limit switch, a servo holding its position or a
    device's latch acts on the physics the way the real part does; the
    onboard interface calls it on a skill's behalf. Sensors' ``read`` /
    ``measure`` and the physics-step hooks are hardware by construction.
    The sensing-boundary test accepts truth reads only below such a frame.
    """
    HARDWARE_CODE.add(function.__code__)
    return function


class Onboard:
    """Base of onboard interfaces: name, kind, sensors, state estimate, per-resource safe stop, static link model.

    Subclasses add their kind's commands and device states. :attr:`commands`
    maps each command method to the resource it drives (``"docking.release"``
    for a method of the device at attribute ``docking``), which the run's
    arbiter stamps per robot and resource; :attr:`safe_stops` maps each
    resource to the command that leaves it safe (a resource without one, like
    a docking device, keeps its state).
    """

    #: command method -> resource it drives (``"device.method"`` for a device's), see ``marsupial.trees.arbitration``
    commands: ClassVar[Mapping[str, str]] = {}
    #: resource -> the command method that leaves it safe
    safe_stops: ClassVar[Mapping[str, str]] = {}

    __slots__ = ("name", "kind", "__robot", "__ports")  # private slots, name-mangled to _Onboard__…

    def __init__(self, robot: Robot):
        self.name = robot.name
        self.kind = robot.kind
        self.__robot = robot
        self.__ports: dict[str, SensorPort] = {}

    @property
    def _robot(self) -> Robot:
        """The body behind this interface: for the world-side subclasses of this module only."""
        return self.__robot

    # ------------------------------------------------------------- sensing
    def sensor(self, name: str) -> SensorPort:
        """The sensor called ``name`` (short name, e.g. ``"sonar"``); the error lists this robot's sensors."""
        port = self.__ports.get(name)
        if port is None:
            sensor = self.__robot.sensor(name)
            short = sensor.name.split("/", 1)[-1]
            port = self.__ports[name] = SensorPort(short, sensor, depth=getattr(sensor, "measures_depth", True))
        return port

    @property
    def sensor_names(self) -> tuple[str, ...]:
        """Short names of this robot's sensors."""
        return tuple(n.split("/", 1)[-1] for n in self.__robot.sensors)

    def estimate(self) -> StateEstimate:
        """The robot's onboard state estimate now (see :mod:`marsupial.world.estimation`)."""
        return self.__robot.estimator.estimate()

    # ---------------------------------------------------------- the model
    def link_offset(self, link: str) -> tuple[np.ndarray, np.ndarray]:
        """Position (m) and rotation of ``link`` in the base frame, from the robot's URDF (rigid links)."""
        return self.__robot.link_offset(link)

    def provides(self, capability: type) -> bool:
        """Whether this robot has ``capability`` (a protocol of :mod:`marsupial.world.capabilities`)."""
        return isinstance(self, capability)

    @classmethod
    def resources(cls) -> frozenset[str]:
        """The resources this kind of robot has (those its commands drive)."""
        return frozenset(cls.commands.values())

    @classmethod
    def devices(cls) -> frozenset[str]:
        """Attributes holding devices whose methods are commands (``docking`` of a carrier)."""
        return frozenset(name.split(".", 1)[0] for name in cls.commands if "." in name)

    # ------------------------------------------------------------ commands
    def safe_stop(self, resource: str | None = None) -> None:
        """Leave ``resource`` (``None``: all) safe by its safe-stop command: hover, stop wheels, hold the arm."""
        for name in sorted(self.resources()) if resource is None else (resource,):
            method = self.safe_stops.get(name)
            if method is not None:
                getattr(self, method)()

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"


class BatteryOnboard(Onboard):
    """A robot with a battery monitor: :meth:`battery` reads it."""

    __slots__ = ()

    def battery(self) -> Any:
        """Latest battery sample (:class:`~marsupial.world.energy.BatteryStatus`: SOC %, V, A), ``None`` before one."""
        reading = self.sensor("battery").read()
        return None if reading is None else reading.data


class QuadrotorOnboard(BatteryOnboard):
    """A quadrotor's onboard computer: velocity commands, motors, estimator hand-over, arming and dock states."""

    commands: ClassVar[Mapping[str, str]] = {
        "command_velocity": "rotors", "hover": "rotors", "set_motors": "rotors", "reset_estimate": "rotors",
    }
    safe_stops: ClassVar[Mapping[str, str]] = {"rotors": "_hover_if_flying"}
    __slots__ = ()

    def command_velocity(self, vx: float, vy: float, vz: float, yaw_rate: float = 0.0, frame: str = "body") -> None:
        """Fly at ``(vx, vy, vz)`` m/s turning at ``yaw_rate`` rad/s; ``frame`` ``"body"`` (heading) or ``"world"``.

        ``"world"`` is the estimator's navigation frame: the autopilot tracks
        the command on the onboard estimate, as the vendor's firmware does.
        """
        self._robot.command_velocity(vx, vy, vz, yaw_rate, frame)  # type: ignore[attr-defined]

    def hover(self) -> None:
        """Hold the present (estimated) position."""
        self._robot.hover()  # type: ignore[attr-defined]

    def set_motors(self, on: bool) -> None:
        """Start (arm) or stop the motors."""
        self._robot.set_motors(on)  # type: ignore[attr-defined]

    def _hover_if_flying(self) -> None:
        """The rotors' safe stop: hover in place when flying (motors on, not docked), else nothing."""
        self._robot.safe_stop()

    def reset_estimate(self, position: Sequence[float], yaw: float) -> None:
        """Restart the onboard estimate at ``position`` (m) and ``yaw`` (rad), e.g. handed over by a carrier."""
        self._robot.estimator.reset(np.asarray(position, dtype=float), float(yaw))

    @property
    def motors_on(self) -> bool:
        """True while the motors run (the flight controller's arming state)."""
        return bool(self._robot.motors_on)  # type: ignore[attr-defined]

    @property
    def docked(self) -> bool:
        """True while a docking device holds the vehicle (its dock-lock signal)."""
        return bool(self._robot.docked)  # type: ignore[attr-defined]

    @property
    def thrust(self) -> float:
        """Total thrust (N) the flight controller commands (motor speeds via its rotor model); 0 with the motors off."""
        return float(self._robot.thrust) if self.motors_on else 0.0  # type: ignore[attr-defined]

    @property
    def limits(self) -> Any:
        """The kind's :class:`~marsupial.world.robots.quadrotor.FlightLimits` (datasheet)."""
        return self._robot.limits  # type: ignore[attr-defined]

    @property
    def mass(self) -> float:
        """Take-off mass (kg), from the datasheet."""
        return float(self._robot.mass)  # type: ignore[attr-defined]

    @property
    def battery_capacity_mAh(self) -> float:
        """Capacity of the pack (mAh)."""
        return float(self._robot.battery.spec.capacity_mAh)  # type: ignore[attr-defined]


class WheeledOnboard(Onboard):
    """A wheeled base: drive commands, wheel-encoder speed, drive limits, footprint estimate."""

    commands: ClassVar[Mapping[str, str]] = {"drive": "base", "stop": "base", "reset_estimate": "base"}
    safe_stops: ClassVar[Mapping[str, str]] = {"base": "stop"}
    __slots__ = ()

    def drive(self, v: float, omega: float) -> None:
        """Command forward speed ``v`` (m/s) and yaw rate ``omega`` (rad/s, CCW), clipped to the limits."""
        self._robot.drive(v, omega)  # type: ignore[attr-defined]

    def stop(self) -> None:
        """Command zero speed."""
        self._robot.stop()  # type: ignore[attr-defined]

    def speed(self) -> float:
        """Forward speed (m/s) from the wheel encoders."""
        return float(self._robot.wheel_speed())  # type: ignore[attr-defined]

    @property
    def limits(self) -> Any:
        """Drive limits (:class:`~marsupial.world.robots.diff_drive.DiffDriveLimits`)."""
        return self._robot.limits  # type: ignore[attr-defined]

    def footprint_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Estimated pose of ``base_footprint``: position (m), quaternion, in the estimate's frame."""
        estimate = self.estimate()
        return estimate.position, estimate.orientation

    def reset_estimate(self, position: Sequence[float], yaw: float) -> None:
        """Restart the base estimate at ``position`` (m; x, y used) and ``yaw`` (rad) in its own frame: a correction
        the robot computed itself (e.g. registering a depth frame against its map), never the simulator's pose."""
        self._robot.estimator.reset(np.asarray(position, dtype=float), float(yaw))

    def odometry(self) -> StateEstimate:
        """The wheel odometry's own estimate of ``base_footprint`` (frame ``odom``): smooth, drifting with distance.

        Behind a map localiser (``localization: map``) this is the dead reckoning the fixes correct, free of
        their jumps; without one it is :meth:`estimate` itself.
        """
        return self._robot.odometry.estimate()  # type: ignore[attr-defined]


class BatteryWheeledOnboard(WheeledOnboard, BatteryOnboard):
    """A wheeled base with a battery monitor (``child_ugv``): drive commands, odometry and :meth:`battery`."""

    __slots__ = ()


class PlatformOnboard(WheeledOnboard):
    """A ground robot carrying a landing platform (``summit_xl``): its size and mount from the model."""

    __slots__ = ()

    @property
    def platform_size(self) -> tuple[float, float]:
        """Platform length and width (m)."""
        return self._robot.platform_size  # type: ignore[attr-defined]


class DockingPort:
    """Part A's docking device as the carrier's computer drives and reads it (Narváez §IV-C).

    Commands: :meth:`magnet_on`, :meth:`magnet_off`, :meth:`lock`,
    :meth:`release`. Device states: :attr:`magnet` (coil energised),
    :attr:`contact_switch` (Part B seated in the cone: the limit switch
    under Part A's face), :attr:`locked` (lever end switch), :attr:`locking`,
    :attr:`charging` (the charger's current sense).
    """

    __slots__ = ("__device",)

    def __init__(self, device: Any):
        self.__device = device

    def magnet_on(self) -> None:
        """Energise the electromagnet."""
        self.__device.magnet_on()

    def magnet_off(self) -> None:
        """De-energise the electromagnet."""
        self.__device.magnet_off()

    def lock(self) -> bool:
        """Start closing the levers; False when the contact switch is open (nothing to lock)."""
        return bool(self.__device.lock())

    def release(self) -> None:
        """Open the levers and switch the magnet off."""
        self.__device.release()

    @property
    def magnet(self) -> bool:
        """True while the coil is energised."""
        return bool(self.__device.magnet)

    @property
    def contact_switch(self) -> bool:
        """True while a Part B rests seated on Part A (the cone's limit switch)."""
        return bool(self.__device.contact_switch())

    @property
    def locked(self) -> bool:
        """True while the levers hold a UAV (their end switch)."""
        return self.__device.docked is not None

    @property
    def locking(self) -> bool:
        """True while the levers are closing."""
        return bool(self.__device.locking)

    @property
    def charging(self) -> bool:
        """True while the charger delivers current to a locked UAV (the charger's current sense, §V-A)."""
        uav = self.__device.docked
        return bool(uav is not None and getattr(uav, "charging", False))

    @property
    def state(self) -> str:
        """``"locked"``, ``"magnet"`` or ``"open"`` (from the switches and the coil)."""
        return str(self.__device.state)

    @property
    def capture_distance(self) -> float:
        """The magnet's reach (m), from its datasheet."""
        return float(self.__device.capture_distance)


class ArmModelOnboard(WheeledOnboard):
    """A wheeled base carrying an arm whose model the robot's computer has: kinematics and mount of frame M.

    :attr:`arm_base_link` names frame M, the link the arm's poses are expressed in.
    """

    arm_base_link: ClassVar[str] = "arm_base"
    __slots__ = ()

    @property
    def arm_kinematics(self) -> Any:
        """pinocchio model of the arm (frame M → the tip link; every link after M), from the URDF."""
        return self._robot.arm_kinematics  # type: ignore[attr-defined]

    def arm_mount(self) -> tuple[np.ndarray, np.ndarray]:
        """Frame M in the ``base_footprint`` frame the estimate is of: position (m), rotation (URDF)."""
        p_fp, R_fp = self.link_offset("base_footprint")
        p_M, R_M = self.link_offset(self.arm_base_link)
        return R_fp.T @ (p_M - p_fp), R_fp.T @ R_M

    def arm_base_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Estimated pose of frame M: the footprint estimate composed with M's URDF mount (position m, quaternion)."""
        estimate = self.estimate()
        p_M_fp, R_fp_M = self.arm_mount()
        R = estimate.rotation
        return estimate.position + R @ p_M_fp, quaternion_from_matrix(R @ R_fp_M)


class CarrierOnboard(ArmModelOnboard):
    """The mobile manipulator's computer: base, arm (encoders, kinematics), docking device, cameras, LiDAR."""

    commands: ClassVar[Mapping[str, str]] = {
        **WheeledOnboard.commands,
        "set_joint_targets": "arm", "hold_arm": "arm",
        **{f"docking.{name}": "docking" for name in ("magnet_on", "magnet_off", "lock", "release")},
    }
    safe_stops: ClassVar[Mapping[str, str]] = {"base": "stop", "arm": "hold_arm"}  # the docking device keeps its state
    __slots__ = ("docking",)

    def __init__(self, robot: Robot):
        super().__init__(robot)
        self.docking = DockingPort(robot.docking)  # type: ignore[attr-defined]

    def set_joint_targets(self, q: str | Sequence[float]) -> None:
        """Move the arm toward ``q`` (6 angles in rad, or a named pose)."""
        self._robot.set_joint_targets(q)  # type: ignore[attr-defined]

    def hold_arm(self) -> None:
        """Hold every arm joint where its encoder reads it now."""
        self._robot.hold_arm()  # type: ignore[attr-defined]

    def joint_positions(self) -> np.ndarray:
        """Arm joint angles (rad) from the joint encoders."""
        return self._robot.arm_encoders()  # type: ignore[attr-defined]

    def joint_targets(self) -> np.ndarray:
        """Arm joint targets being tracked (rad)."""
        return self._robot.joint_targets()  # type: ignore[attr-defined]

    def arm_at_target(self, tolerance: float = 0.01) -> bool:
        """True when every encoder reads within ``tolerance`` rad of its target."""
        return bool(np.all(np.abs(self.joint_targets() - self.joint_positions()) <= tolerance))

    @property
    def lidar(self) -> SensorPort:
        """The planar LiDAR on the base (sensor ``lidar``)."""
        return self.sensor("lidar")

    @property
    def joint_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper joint limits (rad)."""
        return self._robot.joint_limits  # type: ignore[attr-defined]

    def arm_pose(self, name: str) -> np.ndarray:
        """Joint angles (rad) of a named arm pose."""
        return self._robot.arm_pose(name)  # type: ignore[attr-defined]


class ManipulatorOnboard(ArmModelOnboard):
    """A wheeled base with an arm and a gripper (the ``mms``): joint targets and encoders, gripper commands."""

    arm_base_link: ClassVar[str] = "arm_base_link"

    commands: ClassVar[Mapping[str, str]] = {
        **WheeledOnboard.commands,
        "set_joint_targets": "arm", "hold_arm": "arm", "open_gripper": "gripper", "close_gripper": "gripper",
        "release_scout": "gripper",
    }
    safe_stops: ClassVar[Mapping[str, str]] = {"base": "stop", "arm": "hold_arm"}  # the gripper keeps what it holds
    __slots__ = ()

    def set_joint_targets(self, q: Sequence[float]) -> None:
        """Move the arm toward joint angles ``q`` (6 values, rad)."""
        self._robot.set_joint_targets(q)  # type: ignore[attr-defined]

    def hold_arm(self) -> None:
        """Hold the arm joints where they are now."""
        self._robot.hold_arm()  # type: ignore[attr-defined]

    def joint_positions(self) -> np.ndarray:
        """Arm joint angles (rad) from the joint encoders."""
        return self._robot.arm_encoders()  # type: ignore[attr-defined]

    def open_gripper(self) -> None:
        """Open the fingers, letting go of what they hold."""
        self._robot.open_gripper()  # type: ignore[attr-defined]

    def close_gripper(self) -> None:
        """Close the fingers; they hold an apparatus handle they close around."""
        self._robot.close_gripper()  # type: ignore[attr-defined]

    def gripper_opening(self) -> float:
        """Gap between the fingers (m), from their encoder."""
        return float(self._robot.gripper_opening())  # type: ignore[attr-defined]

    def release_scout(self) -> bool:
        """Open the held launching apparatus's hold on its MAV (the launch command); whether one was let go."""
        return bool(self._robot.release_scout())  # type: ignore[attr-defined]


class LiftOnboard(WheeledOnboard):
    """A wheeled base with a lifting docking station (the ``mother_ugv``): raise, lower, platform height."""

    commands: ClassVar[Mapping[str, str]] = {
        **WheeledOnboard.commands, "raise_platform": "lift", "lower_platform": "lift",
    }
    safe_stops: ClassVar[Mapping[str, str]] = {"base": "stop", "lift": "_hold_lift"}
    __slots__ = ()

    def raise_platform(self) -> list[str]:
        """Raise the platform; returns the team members it lifts."""
        return list(self._robot.raise_platform())  # type: ignore[attr-defined]

    def lower_platform(self) -> None:
        """Lower the platform to the floor (the children roll off there)."""
        self._robot.lower_platform()  # type: ignore[attr-defined]

    def platform_height(self) -> float:
        """Platform height (m) from the lift encoder."""
        return float(self._robot.platform_height())  # type: ignore[attr-defined]

    @property
    def platform_occupied(self) -> bool:
        """The platform's load switch: pressed while a child stands wholly on the plate."""
        return bool(self._robot.platform_switch())  # type: ignore[attr-defined]

    @property
    def lift_travel(self) -> float:
        """Platform height at the storage capsule (m), from the station's model."""
        return float(self._robot.lift_travel)  # type: ignore[attr-defined]

    def _hold_lift(self) -> None:
        """The lift's safe stop: hold the platform where it is."""
        self._robot.hold_lift()  # type: ignore[attr-defined]


def onboard_of(robot: Robot) -> Onboard:
    """The onboard interface of ``robot`` (its class's ``onboard_class``), built once and kept on the robot."""
    port = robot._onboard
    if port is None:
        port = robot._onboard = robot.onboard_class(robot)
    return port


def base_frame_offset(p_base: np.ndarray, q_base: np.ndarray, p_link: np.ndarray,
                      q_link: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position (m) and rotation of a link in its base frame, from the two world poses (model set-up only)."""
    R_base = rotation_matrix(q_base)
    return R_base.T @ (np.asarray(p_link) - np.asarray(p_base)), R_base.T @ rotation_matrix(q_link)
