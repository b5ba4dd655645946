"""What a robot can do, as typed protocols of its view, and the resources its commands drive.

A node states the robots it accepts by capability (``robot_kinds =
(Rotorcraft,)``), and a team-member parameter can require one
(``TeamMember(Carrier)``); the compiler checks them against the view class
of each robot kind (:func:`provides`), and skills test a member with
``self.member(name).provides(Carrier)``. One vocabulary serves both: these
protocols, implemented by the views of :mod:`marsupial.api.views`.

Resources are the parts of a robot that one node at a time drives
(:data:`RESOURCES`); each command method of a view drives one
(:attr:`~marsupial.api.views.RobotView.commands`), and the run's arbiter
stamps commands per robot and resource (:mod:`marsupial.trees.arbitration`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

if TYPE_CHECKING:
    import numpy as np

    from .kinematics import ArmKinematics
    from .model import RobotModel
    from .readings import BatteryStatus, StateEstimate
    from .views import DockingView, SensorView

#: the resources of the robots: wheeled base, arm joints, rotors (flight controller and its estimator),
#: docking device (magnet and levers), gripper, lifting platform
RESOURCES: tuple[str, ...] = ("base", "arm", "rotors", "docking", "gripper", "lift")


@runtime_checkable
class Robot(Protocol):
    """What every robot's view offers: its names, model, state estimate, sensors and safe stop.

    Every capability below extends it, so a skill typed by its capability
    (``Skill["X.Params", Rotorcraft]``) reads these too.
    """

    @property
    def name(self) -> str:
        """The robot's team name."""

    @property
    def kind(self) -> str:
        """The robot's kind (``"bebop2"`` …)."""

    @property
    def model(self) -> RobotModel:
        """What the robot's designers wrote down: links, sensors, limits."""

    def estimate(self) -> StateEstimate:
        """The onboard state estimate at this tick (navigation frame)."""

    def sensor(self, name: str) -> SensorView:
        """One sensor: its newest sample and its static facts."""

    def link_offset(self, link: str) -> tuple[np.ndarray, np.ndarray]:
        """Position (m) and rotation of ``link`` in the base frame, from the URDF."""

    def provides(self, capability: type) -> bool:
        """Whether the robot has ``capability``."""

    def safe_stop(self) -> None:
        """Leave the resources the node claims on the robot safe."""


@runtime_checkable
class HasBattery(Robot, Protocol):
    """A robot with a battery monitor (state of charge, voltage, current)."""

    def battery(self) -> BatteryStatus | None:
        """Latest battery-monitor sample, ``None`` before one."""


@runtime_checkable
class HasBase(Robot, Protocol):
    """A wheeled base (resource ``base``): drive commands, wheel-encoder speed, drive limits."""

    def drive(self, v: float, omega: float) -> None:
        """Command forward speed ``v`` (m/s) and yaw rate ``omega`` (rad/s)."""

    def stop(self) -> None:
        """Command zero speed."""

    def speed(self) -> float:
        """Forward speed (m/s) from the wheel encoders."""

    def footprint_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Estimated pose of ``base_footprint``: position (m), quaternion."""

    def reset_estimate(self, position: Sequence[float], yaw: float) -> None:
        """Restart the base estimate at ``position`` (m) and ``yaw`` (rad), a correction the robot computed."""


@runtime_checkable
class HasLidar(Robot, Protocol):
    """A robot with a planar LiDAR (sensor ``lidar``)."""

    @property
    def lidar(self) -> SensorView:
        """The planar LiDAR."""


@runtime_checkable
class HasPlatform(HasBase, Protocol):
    """A wheeled base carrying a landing platform."""

    @property
    def platform_size(self) -> tuple[float, float]:
        """Platform length and width (m)."""


@runtime_checkable
class Rotorcraft(HasBattery, Protocol):
    """A quadrotor's flight controller (resource ``rotors``): velocity commands, motors, arming and dock states."""

    def command_velocity(self, vx: float, vy: float, vz: float, yaw_rate: float = 0.0, frame: str = "body") -> None:
        """Fly at ``(vx, vy, vz)`` m/s turning at ``yaw_rate`` rad/s."""

    def hover(self) -> None:
        """Hold the present (estimated) position."""

    def set_motors(self, on: bool) -> None:
        """Start (arm) or stop the motors."""

    def reset_estimate(self, position: Sequence[float], yaw: float) -> None:
        """Restart the onboard estimate at ``position`` (m) and ``yaw`` (rad)."""

    @property
    def motors_on(self) -> bool:
        """True while the motors run."""

    @property
    def docked(self) -> bool:
        """True while a docking device holds the vehicle."""

    @property
    def thrust(self) -> float:
        """Total rotor thrust (N)."""

    @property
    def mass(self) -> float:
        """Take-off mass (kg)."""


@runtime_checkable
class HasArm(Robot, Protocol):
    """A robot arm (resource ``arm``): joint targets, hold, joint encoders."""

    def set_joint_targets(self, q: Any) -> None:
        """Move the arm toward joint angles ``q`` (rad)."""

    def hold_arm(self) -> None:
        """Hold every joint where its encoder reads it now."""

    def joint_positions(self) -> np.ndarray:
        """Joint angles (rad) from the encoders."""


@runtime_checkable
class HasArmModel(HasArm, Protocol):
    """An arm whose model the robot's computer has: kinematics and the estimated pose of its base frame M."""

    @property
    def arm_kinematics(self) -> ArmKinematics:
        """Kinematic model of the arm (frame M → its links), from the URDF."""

    def arm_base_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Estimated pose of frame M in the navigation frame: position (m), quaternion."""


@runtime_checkable
class Carrier(HasArm, HasBase, Protocol):
    """A carrier with a docking device on its arm (resources ``base``, ``arm``, ``docking``): the mobile manipulator."""

    @property
    def docking(self) -> DockingView:
        """Part A of the docking device (resource ``docking``): magnet, levers, switches."""

    @property
    def arm_kinematics(self) -> ArmKinematics:
        """Kinematic model of the arm (frame M → ``part_a``), from the URDF."""

    def arm_pose(self, name: str) -> np.ndarray:
        """Joint angles (rad) of a named arm pose."""


@runtime_checkable
class HasGripper(Robot, Protocol):
    """A gripper (resource ``gripper``): open, close, opening."""

    def open_gripper(self) -> None:
        """Open the fingers."""

    def close_gripper(self) -> None:
        """Close the fingers."""

    def gripper_opening(self) -> float:
        """Gap between the fingers (m), from their encoder."""


@runtime_checkable
class HasScoutLauncher(Robot, Protocol):
    """Launching apparatuses with micro-scouts, held by the gripper (resource ``gripper``): the launch command."""

    def release_scout(self) -> None:
        """Open the held apparatus's hold on its MAV (the launch command)."""


@runtime_checkable
class HasLift(Robot, Protocol):
    """A lifting platform (resource ``lift``): raise, lower, height, its load switch and travel."""

    def raise_platform(self) -> None:
        """Raise the platform to the storage capsule."""

    def lower_platform(self) -> None:
        """Lower the platform to the floor."""

    def platform_height(self) -> float:
        """Platform height (m) from the lift encoder."""

    @property
    def platform_occupied(self) -> bool:
        """The platform's load switch: a child stands wholly on the plate."""

    @property
    def lift_travel(self) -> float:
        """Platform height at the storage capsule (m)."""


#: every capability, by name (``marsupial skills`` and error messages name them so)
CAPABILITIES: tuple[type, ...] = (
    HasBattery, HasBase, HasLidar, HasPlatform, Rotorcraft, HasArm, HasArmModel, Carrier, HasGripper,
    HasScoutLauncher, HasLift,
)


def members(capability: type) -> frozenset[str]:
    """Names of the methods and properties ``capability`` (a protocol of this module) asks for, its bases' included."""
    names: set[str] = set()
    for base in capability.__mro__:
        if base in (Protocol, object) or not getattr(base, "_is_protocol", False):
            continue
        names.update(n for n in (*vars(base), *getattr(base, "__annotations__", {})) if not n.startswith("_"))
    return frozenset(names)


def provides(view_class: type, capability: type) -> bool:
    """Whether instances of ``view_class`` (a robot view class) have ``capability``, checked on the class.

    ``isinstance(interface, capability)`` answers the same for an instance;
    this form lets the compiler check a robot kind before any world exists.
    """
    return all(hasattr(view_class, name) for name in members(capability))
