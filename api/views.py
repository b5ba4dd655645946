"""A robot as one node sees it: this tick's readings and its model in, command messages out.

A skill or condition holds a *view* of each robot it uses
(``self.robot``, ``self.member(name)``): an instance of one of the classes
below, chosen by the robot's kind. A view holds data only:

- a :class:`RobotState`: the robot's model (:class:`~marsupial.api.model.RobotModel`)
  and the readings its computer has this tick
  (:class:`~marsupial.api.readings.RobotReadings`), which the runtime
  replaces before every tick with what the world delivered;
- a :class:`CommandSink`: where its commands go (the runtime's arbitrated
  outbox for that node).

Reads (``estimate()``, ``joint_positions()``, ``docking.contact_switch``,
``sensor("camera").read()``) answer from the readings; commands
(``drive(v, omega)``, ``docking.lock()``) put a
:mod:`~marsupial.api.commands` message in the outbox, which the world applies
after the tick. A command therefore shows in the readings from the next tick
on, as it would on a robot whose computer sends it over a bus.

``commands`` maps each command method to the resource it drives
(``"docking.lock"`` for a method of the device at attribute ``docking``);
the runtime's arbiter stamps commands per robot and resource.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

import numpy as np

from marsupial.geometry import quaternion_from_matrix

from .commands import (
    Command,
    DockingAction,
    Drive,
    FlyVelocity,
    GripperAction,
    HoldArm,
    Hover,
    LiftAction,
    LinkSend,
    ResetEstimate,
    SetJointTargets,
    SetMotors,
    Stop,
)
from .errors import UnknownNameError
from .model import DiffDriveLimits, FlightLimits, RobotModel, SensorFacts
from .readings import BatteryStatus, DockingStatus, LinkMessage, Reading, RobotReadings, StateEstimate

if TYPE_CHECKING:
    from .kinematics import ArmKinematics

#: how long (s) a queued sensor's samples are kept for :meth:`SensorView.read_since`
QUEUE_S = 2.0


class CommandSink(Protocol):
    """Where a view's commands go: the runtime's outbox for one node, through the run's arbiter."""

    def submit(self, resource: str, command: Command) -> bool:
        """Send ``command`` to its robot's ``resource``; whether it was sent (a finishing node's may be dropped)."""

    def safe_stop(self, robot: RobotView) -> None:
        """Leave the resources of ``robot`` that the node claims safe (each unless taken over this tick)."""

    def broadcast(self, command: LinkSend) -> None:
        """Send a team-link message."""

    def check_read(self, robot: str, sensor: str) -> None:
        """Raise unless the node declared that it reads ``sensor`` of ``robot`` (what it declares is delivered)."""


class RobotState:
    """One robot's model and the readings its computer has now, as the runtime keeps them between ticks.

    :meth:`update` takes each tick's :class:`RobotReadings`. A sensor's newest
    sample is held until a newer one comes (a driver keeps the last message);
    queued sensors' samples are kept for :data:`QUEUE_S` s.
    """

    __slots__ = ("model", "readings", "held", "queues", "kinematics")

    def __init__(self, model: RobotModel, readings: RobotReadings | None = None):
        self.model = model
        self.readings = readings if readings is not None else RobotReadings(0.0)
        self.held: dict[str, Reading[Any] | None] = {}
        self.queues: dict[str, deque[Reading[Any]]] = {}
        self.kinematics: ArmKinematics | None = None

    def update(self, readings: RobotReadings) -> None:
        """Take this tick's readings: newest samples held, queued samples appended (the last :data:`QUEUE_S` s)."""
        self.readings = readings
        for name, reading in readings.sensors.items():
            if reading is not None:
                self.held[name] = reading
        for name, samples in readings.streams.items():
            queue = self.queues.setdefault(name, deque())
            queue.extend(samples)
            while queue and queue[0].stamp < readings.stamp - QUEUE_S:
                queue.popleft()


class SensorView:
    """One sensor as the robot's computer reads it: :meth:`read`, :meth:`read_since` and its static facts.

    Facts (``K``, ``intrinsics``, ``offset``, ``R_link_optical``,
    ``half_angle``, ``min_range``, ``max_range``, ``spec``, ``rate_hz``) come
    from the robot's model (:class:`~marsupial.api.model.SensorFacts`).
    """

    __slots__ = ("name", "facts", "_state", "_sink")

    def __init__(self, state: RobotState, name: str, sink: CommandSink):
        self.name = name
        self.facts: SensorFacts = state.model.sensor(name)
        self._state = state
        self._sink = sink

    def read(self) -> Reading[Any] | None:
        """The newest sample delivered (``None`` before the first); its ``stamp`` is the sample's sim time (s)."""
        self._sink.check_read(self._state.model.name, self.name)
        return self._state.held.get(self.name)

    def read_since(self, stamp: float) -> list[Reading[Any]]:
        """Every sample stamped after ``stamp`` (s), oldest first, as the driver's queue delivers them.

        For the sensors whose samples are queued (all but cameras and LiDARs,
        :attr:`SensorFacts.queued`); the queue keeps the last :data:`QUEUE_S` s.
        """
        if not self.facts.queued:
            raise TypeError(f"sensor '{self.name}' is a camera or a LiDAR: read() its newest frame or scan")
        self._sink.check_read(self._state.model.name, self.name)
        return [r for r in self._state.queues.get(self.name, ()) if r.stamp > stamp]

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        return getattr(self.facts, name)

    def __repr__(self) -> str:
        return f"SensorView({self.name!r})"


class RobotView:
    """Base of the views: name, kind, sensors, state estimate, model facts, per-resource safe stop.

    Subclasses add their kind's commands and device states.
    """

    #: command method -> resource it drives (``"device.method"`` for a device's)
    commands: ClassVar[Mapping[str, str]] = {}
    #: the resources whose safe stop does something (the others keep their state)
    safe_stops: ClassVar[frozenset[str]] = frozenset()

    __slots__ = ("_state", "_sink")

    def __init__(self, state: RobotState, sink: CommandSink):
        self._state = state
        self._sink = sink

    @property
    def name(self) -> str:
        """The robot's team name."""
        return self._state.model.name

    @property
    def kind(self) -> str:
        """The robot's kind (``"bebop2"``, ``"mobile_manipulator"`` …)."""
        return self._state.model.kind

    @property
    def model(self) -> RobotModel:
        """What the robot's designers wrote down: links, sensors, limits (:class:`RobotModel`)."""
        return self._state.model

    # ------------------------------------------------------------- sensing
    def sensor(self, name: str) -> SensorView:
        """The sensor called ``name`` (short name, e.g. ``"sonar"``); the error lists this robot's sensors."""
        return SensorView(self._state, name, self._sink)

    @property
    def sensor_names(self) -> tuple[str, ...]:
        """Short names of this robot's sensors."""
        return tuple(self._state.model.sensors)

    def estimate(self) -> StateEstimate:
        """The robot's onboard state estimate at this tick (its navigation frame)."""
        estimate = self._state.readings.estimate
        if estimate is None:
            raise RuntimeError(f"'{self.name}' has no state estimate: the robot has no onboard computer")
        return estimate

    @property
    def stamp(self) -> float:
        """Simulated time (s) of this tick's readings."""
        return self._state.readings.stamp

    # ---------------------------------------------------------- the model
    def link_offset(self, link: str) -> tuple[np.ndarray, np.ndarray]:
        """Position (m) and rotation of ``link`` in the base frame, from the robot's URDF (rigid links)."""
        return self._state.model.link_offset(link)

    def provides(self, capability: type) -> bool:
        """Whether this robot has ``capability`` (a protocol of :mod:`marsupial.api.capabilities`)."""
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
    def _send(self, method: str, command: Command) -> bool:
        """Put ``command`` (sent by the method ``method``) in the outbox for the resource that method drives."""
        return self._sink.submit(self.commands[method], command)

    def safe_stop(self) -> None:
        """Leave the resources this node claims on the robot safe: hover, stop the wheels, hold the arm or lift."""
        self._sink.safe_stop(self)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"


class BatteryView(RobotView):
    """A robot with a battery monitor: :meth:`battery` reads it (sensor ``battery``)."""

    __slots__ = ()

    def battery(self) -> BatteryStatus | None:
        """Latest battery sample (SOC %, V, A), ``None`` before one."""
        reading = self.sensor("battery").read()
        return None if reading is None else reading.data


class QuadrotorView(BatteryView):
    """A quadrotor's flight controller: velocity commands, motors, estimator hand-over, arming and dock states."""

    commands: ClassVar[Mapping[str, str]] = {
        "command_velocity": "rotors", "hover": "rotors", "set_motors": "rotors", "reset_estimate": "rotors",
    }
    safe_stops: ClassVar[frozenset[str]] = frozenset({"rotors"})
    __slots__ = ()

    def command_velocity(self, vx: float, vy: float, vz: float, yaw_rate: float = 0.0, frame: str = "body") -> None:
        """Fly at ``(vx, vy, vz)`` m/s turning at ``yaw_rate`` rad/s; ``frame`` ``"body"`` (heading) or ``"world"``.

        ``"world"`` is the estimator's navigation frame: the autopilot tracks
        the command on the onboard estimate, as the vendor's firmware does.
        """
        self._send("command_velocity", FlyVelocity(self.name, float(vx), float(vy), float(vz), float(yaw_rate), frame))

    def hover(self) -> None:
        """Hold the present (estimated) position."""
        self._send("hover", Hover(self.name))

    def set_motors(self, on: bool) -> None:
        """Start (arm) or stop the motors."""
        self._send("set_motors", SetMotors(self.name, bool(on)))

    def reset_estimate(self, position: Sequence[float], yaw: float) -> None:
        """Restart the onboard estimate at ``position`` (m) and ``yaw`` (rad), e.g. handed over by a carrier."""
        self._send("reset_estimate", ResetEstimate(self.name, tuple(float(v) for v in position), float(yaw)))

    @property
    def motors_on(self) -> bool:
        """True while the motors run (the flight controller's arming state)."""
        return self._state.readings.motors_on

    @property
    def docked(self) -> bool:
        """True while a docking device holds the vehicle (its dock-lock signal)."""
        return self._state.readings.docked

    @property
    def thrust(self) -> float:
        """Total thrust (N) the flight controller commands; 0 with the motors off."""
        return self._state.readings.thrust

    @property
    def limits(self) -> FlightLimits:
        """The kind's flight limits (datasheet)."""
        limits = self._state.model.limits
        assert isinstance(limits, FlightLimits)
        return limits

    @property
    def mass(self) -> float:
        """Take-off mass (kg), from the datasheet."""
        return self._state.model.mass

    @property
    def battery_capacity_mAh(self) -> float:
        """Capacity of the pack (mAh)."""
        return self._state.model.battery_capacity_mAh


class WheeledView(RobotView):
    """A wheeled base: drive commands, wheel-encoder speed, drive limits, footprint estimate."""

    commands: ClassVar[Mapping[str, str]] = {"drive": "base", "stop": "base", "reset_estimate": "base"}
    safe_stops: ClassVar[frozenset[str]] = frozenset({"base"})
    __slots__ = ()

    def drive(self, v: float, omega: float) -> None:
        """Command forward speed ``v`` (m/s) and yaw rate ``omega`` (rad/s, CCW), clipped to the limits."""
        self._send("drive", Drive(self.name, float(v), float(omega)))

    def stop(self) -> None:
        """Command zero speed."""
        self._send("stop", Stop(self.name))

    def speed(self) -> float:
        """Forward speed (m/s) from the wheel encoders."""
        return self._state.readings.wheel_speed

    @property
    def limits(self) -> DiffDriveLimits:
        """Drive limits (datasheet)."""
        limits = self._state.model.limits
        assert isinstance(limits, DiffDriveLimits)
        return limits

    def footprint_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Estimated pose of ``base_footprint``: position (m), quaternion, in the estimate's frame."""
        estimate = self.estimate()
        return estimate.position, estimate.orientation

    def reset_estimate(self, position: Sequence[float], yaw: float) -> None:
        """Restart the base estimate at ``position`` (m; x, y used) and ``yaw`` (rad) in its own frame.

        A correction the robot computed itself (e.g. registering a depth frame against its map).
        """
        self._send("reset_estimate", ResetEstimate(self.name, tuple(float(v) for v in position), float(yaw)))

    def odometry(self) -> StateEstimate:
        """The wheel odometry's own estimate of ``base_footprint`` (frame ``odom``): smooth, drifting with distance.

        Behind a map localiser this is the dead reckoning the fixes correct; without one it is :meth:`estimate`.
        """
        odometry = self._state.readings.odometry
        return odometry if odometry is not None else self.estimate()


class BatteryWheeledView(WheeledView, BatteryView):
    """A wheeled base with a battery monitor (``child_ugv``): drive commands, odometry and :meth:`battery`."""

    __slots__ = ()


class PlatformView(WheeledView):
    """A ground robot carrying a landing platform (``summit_xl``): its size from the model."""

    __slots__ = ()

    @property
    def platform_size(self) -> tuple[float, float]:
        """Platform length and width (m)."""
        size = self._state.model.platform_size
        assert size is not None
        return size


class DockingView:
    """Part A's docking device as the carrier's computer drives and reads it (Narváez §IV-C).

    Commands: :meth:`magnet_on`, :meth:`magnet_off`, :meth:`lock`,
    :meth:`release`. Device states: :attr:`magnet`, :attr:`contact_switch`,
    :attr:`locked`, :attr:`locking`, :attr:`charging`, :attr:`state`.
    """

    __slots__ = ("_robot",)

    def __init__(self, robot: CarrierView):
        self._robot = robot

    def _status(self) -> DockingStatus:
        status = self._robot._state.readings.docking
        if status is None:
            raise RuntimeError(f"'{self._robot.name}' reported no docking-device state")
        return status

    def _act(self, action: Any) -> None:
        self._robot._send(f"docking.{action}", DockingAction(self._robot.name, action))

    def magnet_on(self) -> None:
        """Energise the electromagnet."""
        self._act("magnet_on")

    def magnet_off(self) -> None:
        """De-energise the electromagnet."""
        self._act("magnet_off")

    def lock(self) -> bool:
        """Start closing the levers; False (and nothing sent) when the contact switch is open (nothing to lock)."""
        if not self.contact_switch:
            return False
        self._act("lock")
        return True

    def release(self) -> None:
        """Open the levers and switch the magnet off."""
        self._act("release")

    @property
    def magnet(self) -> bool:
        """True while the coil is energised."""
        return self._status().magnet

    @property
    def contact_switch(self) -> bool:
        """True while a Part B rests seated on Part A (the cone's limit switch)."""
        return self._status().contact_switch

    @property
    def locked(self) -> bool:
        """True while the levers hold a UAV (their end switch)."""
        return self._status().locked

    @property
    def locking(self) -> bool:
        """True while the levers are closing."""
        return self._status().locking

    @property
    def charging(self) -> bool:
        """True while the charger delivers current to a locked UAV (its current sense, §V-A)."""
        return self._status().charging

    @property
    def state(self) -> str:
        """``"locked"``, ``"magnet"`` or ``"open"`` (from the switches and the coil)."""
        return self._status().state

    @property
    def capture_distance(self) -> float:
        """The magnet's reach (m), from its datasheet."""
        reach = self._robot._state.model.capture_distance
        assert reach is not None
        return reach


class ArmModelView(WheeledView):
    """A wheeled base carrying an arm whose model the robot's computer has: kinematics, encoders, mount of frame M."""

    __slots__ = ()

    @property
    def arm_base_link(self) -> str:
        """Frame M: the link the arm's poses are expressed in."""
        link = self._state.model.arm_base_link
        assert link is not None
        return link

    @property
    def arm_kinematics(self) -> ArmKinematics:
        """pinocchio model of the arm (frame M → the tip link), built from the robot's URDF once."""
        state = self._state
        if state.kinematics is None:
            from .kinematics import ArmKinematics

            model = state.model
            assert model.urdf is not None and model.arm_tip_link is not None
            state.kinematics = ArmKinematics.from_urdf(model.urdf, self.arm_base_link, model.arm_tip_link)
        return state.kinematics

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

    def set_joint_targets(self, q: str | Sequence[float] | np.ndarray) -> None:
        """Move the arm toward ``q`` (joint angles in rad, or a named pose of the model)."""
        target = q if isinstance(q, str) else tuple(float(v) for v in q)
        self._send("set_joint_targets", SetJointTargets(self.name, target))

    def hold_arm(self) -> None:
        """Hold every arm joint where its encoder reads it now."""
        self._send("hold_arm", HoldArm(self.name))

    def joint_positions(self) -> np.ndarray:
        """Arm joint angles (rad) from the joint encoders."""
        q = self._state.readings.joint_positions
        if q is None:
            raise RuntimeError(f"'{self.name}' reported no joint encoders")
        return q.copy()

    @property
    def joint_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper joint limits (rad)."""
        limits = self._state.model.joint_limits
        assert limits is not None
        return limits[0].copy(), limits[1].copy()

    def arm_pose(self, name: str) -> np.ndarray:
        """Joint angles (rad) of a named arm pose; the error lists the model's poses."""
        try:
            return self._state.model.arm_poses[name].copy()
        except KeyError:
            raise UnknownNameError("arm pose", name, self._state.model.arm_poses) from None


class CarrierView(ArmModelView):
    """The mobile manipulator's computer: base, arm (encoders, kinematics), docking device, cameras, LiDAR."""

    commands: ClassVar[Mapping[str, str]] = {
        **WheeledView.commands,
        "set_joint_targets": "arm", "hold_arm": "arm",
        **{f"docking.{name}": "docking" for name in ("magnet_on", "magnet_off", "lock", "release")},
    }
    safe_stops: ClassVar[frozenset[str]] = frozenset({"base", "arm"})  # the docking device keeps its state
    __slots__ = ()

    @property
    def docking(self) -> DockingView:
        """Part A of the docking device (resource ``docking``): magnet, levers, switches."""
        return DockingView(self)

    def joint_targets(self) -> np.ndarray:
        """Arm joint targets being tracked (rad)."""
        q = self._state.readings.joint_targets
        if q is None:
            raise RuntimeError(f"'{self.name}' reported no joint targets")
        return q.copy()

    def arm_at_target(self, tolerance: float = 0.01) -> bool:
        """True when every encoder reads within ``tolerance`` rad of its target."""
        return bool(np.all(np.abs(self.joint_targets() - self.joint_positions()) <= tolerance))

    @property
    def lidar(self) -> SensorView:
        """The planar LiDAR on the base (sensor ``lidar``)."""
        return self.sensor("lidar")


class ManipulatorView(ArmModelView):
    """A wheeled base with an arm and a gripper (the ``mms``): joint targets and encoders, gripper commands."""

    commands: ClassVar[Mapping[str, str]] = {
        **WheeledView.commands,
        "set_joint_targets": "arm", "hold_arm": "arm", "open_gripper": "gripper", "close_gripper": "gripper",
        "release_scout": "gripper",
    }
    safe_stops: ClassVar[frozenset[str]] = frozenset({"base", "arm"})  # the gripper keeps what it holds
    __slots__ = ()

    def open_gripper(self) -> None:
        """Open the fingers, letting go of what they hold."""
        self._send("open_gripper", GripperAction(self.name, "open"))

    def close_gripper(self) -> None:
        """Close the fingers; they hold an apparatus handle they close around."""
        self._send("close_gripper", GripperAction(self.name, "close"))

    def gripper_opening(self) -> float:
        """Gap between the fingers (m), from their encoder."""
        opening = self._state.readings.gripper_opening
        if opening is None:
            raise RuntimeError(f"'{self.name}' reported no gripper encoder")
        return opening

    def release_scout(self) -> None:
        """Open the held launching apparatus's hold on its MAV (the launch command)."""
        self._send("release_scout", GripperAction(self.name, "release_scout"))


class LiftView(WheeledView):
    """A wheeled base with a lifting docking station (the ``mother_ugv``): raise, lower, platform height."""

    commands: ClassVar[Mapping[str, str]] = {
        **WheeledView.commands, "raise_platform": "lift", "lower_platform": "lift",
    }
    safe_stops: ClassVar[frozenset[str]] = frozenset({"base", "lift"})
    __slots__ = ()

    def raise_platform(self) -> None:
        """Raise the platform to the storage capsule."""
        self._send("raise_platform", LiftAction(self.name, "raise"))

    def lower_platform(self) -> None:
        """Lower the platform to the floor (the children roll off there)."""
        self._send("lower_platform", LiftAction(self.name, "lower"))

    def platform_height(self) -> float:
        """Platform height (m) from the lift encoder."""
        height = self._state.readings.platform_height
        if height is None:
            raise RuntimeError(f"'{self.name}' reported no lift encoder")
        return height

    @property
    def platform_occupied(self) -> bool:
        """The platform's load switch: pressed while a child stands wholly on the plate."""
        return self._state.readings.platform_occupied

    @property
    def lift_travel(self) -> float:
        """Platform height at the storage capsule (m), from the station's model."""
        travel = self._state.model.lift_travel
        assert travel is not None
        return travel


class LinkState:
    """The team link as the runtime keeps it between ticks: the newest message delivered per sender and topic."""

    __slots__ = ("latest",)

    def __init__(self) -> None:
        self.latest: dict[tuple[str, str], LinkMessage] = {}

    def update(self, delivered: Sequence[LinkMessage]) -> None:
        """Take the messages delivered since the last tick (a late older message does not replace a newer one)."""
        for message in delivered:
            key = (message.sender, message.topic)
            known = self.latest.get(key)
            if known is None or known.sent <= message.sent:
                self.latest[key] = message


class LinkView:
    """The team link as one robot's computer uses it: send as that robot, read what the others sent."""

    __slots__ = ("name", "_state", "_sink")

    def __init__(self, name: str, state: LinkState, sink: CommandSink):
        self.name = name
        self._state = state
        self._sink = sink

    def send(self, topic: str, payload: Any) -> None:
        """Broadcast ``payload`` on ``topic`` as this robot (it arrives late, or is lost)."""
        self._sink.broadcast(LinkSend(self.name, topic, payload))

    def latest(self, sender: str, topic: str = "estimate") -> LinkMessage | None:
        """The newest delivered message of ``sender`` on ``topic`` (default: its estimate telemetry)."""
        return self._state.latest.get((sender, topic))

    def __repr__(self) -> str:
        return f"LinkView({self.name!r})"


#: every view class, by name (a robot kind names its own; the runtime builds views by it)
VIEWS: dict[str, type[RobotView]] = {
    cls.__name__: cls
    for cls in (RobotView, BatteryView, QuadrotorView, WheeledView, BatteryWheeledView, PlatformView,
                ArmModelView, CarrierView, ManipulatorView, LiftView)
}
