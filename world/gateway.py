"""The world's side of the plug-in contract: what each robot's computer reads, and the commands it applies.

The sensing boundary (``docs/sensing.md``): a robot is a body (its true
pose, velocity and contacts, used only by the world, the sensors, the
recorder and the referee) plus a computer. A :class:`RobotGateway` is that
computer's bus, world side:

- :meth:`RobotGateway.model` builds the robot's
  :class:`~marsupial.api.model.RobotModel` once (URDF link offsets, sensor
  facts, datasheet limits): what its designers wrote down;
- :meth:`RobotGateway.readings` takes the robot's
  :class:`~marsupial.api.readings.RobotReadings` at a tick: its estimates,
  the states its devices report (encoders, switches, arming) and the
  newest samples of the sensors asked for, rendered or ray-cast only then.
  A camera frame reaches it as :class:`~marsupial.api.readings.CameraImage`
  (pixels and intrinsics, no pose, no segmentation), a LiDAR scan as
  :class:`~marsupial.api.readings.RangeScan` (ranges and angles, no body ids);
- :meth:`RobotGateway.apply` applies one :mod:`~marsupial.api.commands`
  message to the robot, as its firmware would.

Nothing here is handed to a node: the runtime passes the messages on.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Collection
from typing import TYPE_CHECKING, Any

import numpy as np

from marsupial.api import commands as cmd
from marsupial.api.model import Intrinsics, LidarSpec, RobotModel, SensorFacts
from marsupial.api.readings import CameraImage, DockingStatus, RangeScan, Reading, RobotReadings
from marsupial.api.views import (
    ArmModelView,
    CarrierView,
    LiftView,
    ManipulatorView,
    QuadrotorView,
    RobotView,
    WheeledView,
)

from .sensors.camera import Camera
from .sensors.lidar import Lidar

if TYPE_CHECKING:
    from .robots.base import Robot
    from .sensors.base import Sensor

#: how long (s) a queued sensor's samples are kept between two deliveries
QUEUE_S = 2.0


def _sensor_facts(robot: Robot, short: str, sensor: Sensor[Any]) -> SensorFacts:
    """The static facts of one sensor: datasheet figures and its mount on the robot (never its state)."""
    links = {index: name for name, index in robot.links.items()}
    link_index = getattr(sensor, "link", None)
    link = links.get(link_index) if isinstance(link_index, int) and link_index >= 0 else None
    intrinsics = getattr(sensor, "intrinsics", None)
    spec = getattr(sensor, "spec", None)
    mounted = isinstance(sensor, (Camera, Lidar)) or hasattr(sensor, "half_angle")
    offset = tuple(float(v) for v in sensor.offset) if mounted else (0.0, 0.0, 0.0)  # type: ignore[attr-defined]
    R = getattr(sensor, "R_link_optical", None)
    return SensorFacts(
        name=short,
        kind=type(sensor).__name__.lower(),
        rate_hz=sensor.config.rate_hz,
        link=link,
        offset=offset,  # type: ignore[arg-type]
        R_link_optical=None if R is None else np.array(R, dtype=float),
        intrinsics=intrinsics if isinstance(intrinsics, Intrinsics) else None,
        measures_depth=bool(getattr(sensor, "measures_depth", False)),
        half_angle=getattr(sensor, "half_angle", None),
        min_range=getattr(sensor, "min_range", None),
        max_range=getattr(sensor, "max_range", spec.max_range if isinstance(spec, LidarSpec) else None),
        spec=spec if isinstance(spec, LidarSpec) else None,
        queued=not isinstance(sensor, (Camera, Lidar)),
    )


def _joint_limits(robot: Robot, kinematics: Any) -> tuple[np.ndarray, np.ndarray] | None:
    """The arm's joint limits (rad): the robot's own where it clips to them, else its URDF's."""
    if kinematics is None:
        return None
    lower, upper = getattr(robot, "joint_limits", (kinematics.lower, kinematics.upper))
    return np.array(lower, dtype=float), np.array(upper, dtype=float)


def robot_model(robot: Robot) -> RobotModel:
    """What the robot's designers know of ``robot``: links, sensors, limits, device facts (built from its URDF)."""
    view = robot.view_class
    links = {name: (p.copy(), R.copy()) for name, (p, R) in robot._link_offsets.items()}
    sensors = {name.split("/", 1)[-1]: _sensor_facts(robot, name.split("/", 1)[-1], s)
               for name, s in robot.sensors.items()}
    battery = getattr(robot, "battery", None)
    arm = issubclass(view, ArmModelView)
    kinematics = getattr(robot, "arm_kinematics", None) if arm else None
    return RobotModel(
        name=robot.name,
        kind=robot.kind,
        links=links,
        sensors=sensors,
        limits=getattr(robot, "limits", None),
        mass=float(getattr(robot, "mass", 0.0) or 0.0),
        battery_capacity_mAh=float(battery.spec.capacity_mAh) if battery is not None else 0.0,
        platform_size=getattr(robot, "platform_size", None),
        lift_travel=getattr(robot, "lift_travel", None),
        capture_distance=float(robot.docking.capture_distance) if hasattr(robot, "docking") else None,
        joint_limits=_joint_limits(robot, kinematics),
        arm_poses={n: np.array(q, dtype=float) for n, q in getattr(robot, "arm_poses", {}).items()},
        arm_base_link=kinematics.base_link if kinematics is not None else None,
        arm_tip_link=kinematics.tip_link if kinematics is not None else None,
        urdf=str(robot.urdf) if arm else None,  # type: ignore[attr-defined]
    )


class RobotGateway:
    """One robot's computer bus, world side: its model, its readings at a tick, and the commands it applies."""

    def __init__(self, robot: Robot):
        self.robot = robot
        self.view_class: type[RobotView] = robot.view_class
        self._model: RobotModel | None = None
        self._queues: dict[str, deque[Reading[Any]]] = {}
        self._delivered: dict[str, float] = {}

    @property
    def name(self) -> str:
        """The robot's team name."""
        return self.robot.name

    def model(self) -> RobotModel:
        """The robot's model (built once)."""
        if self._model is None:
            self._model = robot_model(self.robot)
        return self._model

    # ------------------------------------------------------------- readings
    def readings(self, now: float, sensors: Collection[str] = ()) -> RobotReadings:
        """What the robot's computer has at ``now`` (s): estimates, device states, and the ``sensors`` asked for."""
        robot, view = self.robot, self.view_class
        estimator = getattr(robot, "estimator", None)
        fields: dict[str, Any] = {"estimate": estimator.estimate() if estimator is not None else None}
        odometry = getattr(robot, "odometry", None)
        if odometry is not None and odometry is not estimator:
            fields["odometry"] = odometry.estimate()
        if issubclass(view, QuadrotorView):
            on = bool(robot.motors_on)  # type: ignore[attr-defined]
            fields.update(motors_on=on, docked=bool(robot.docked),  # type: ignore[attr-defined]
                          thrust=float(robot.thrust) if on else 0.0)  # type: ignore[attr-defined]
        if issubclass(view, WheeledView):
            fields["wheel_speed"] = float(robot.wheel_speed())  # type: ignore[attr-defined]
        if issubclass(view, ArmModelView):
            fields["joint_positions"] = np.array(robot.arm_encoders(), dtype=float)  # type: ignore[attr-defined]
        if issubclass(view, CarrierView):
            fields["joint_targets"] = np.array(robot.joint_targets(), dtype=float)  # type: ignore[attr-defined]
            fields["docking"] = self._docking_status()
        if issubclass(view, ManipulatorView):
            fields["gripper_opening"] = float(robot.gripper_opening())  # type: ignore[attr-defined]
        if issubclass(view, LiftView):
            fields["platform_height"] = float(robot.platform_height())  # type: ignore[attr-defined]
            fields["platform_occupied"] = bool(robot.platform_switch())  # type: ignore[attr-defined]
        newest: dict[str, Reading[Any] | None] = {}
        streams: dict[str, tuple[Reading[Any], ...]] = {}
        for name in sensors:
            sensor = robot.sensor(name)
            newest[name] = self.deliverable(sensor)
            if not isinstance(sensor, (Camera, Lidar)):
                streams[name] = self.stream(name, sensor)
        return RobotReadings(now, sensors=newest, streams=streams, **fields)

    def _docking_status(self) -> DockingStatus:
        device = self.robot.docking  # type: ignore[attr-defined]
        uav = device.docked
        return DockingStatus(
            magnet=bool(device.magnet),
            contact_switch=bool(device.contact_switch()),
            locked=uav is not None,
            locking=bool(device.locking),
            charging=bool(uav is not None and getattr(uav, "charging", False)),
            state=str(device.state),
        )

    @staticmethod
    def deliverable(sensor: Sensor[Any]) -> Reading[Any] | None:
        """The sensor's newest readable sample as the robot receives it (frames without pose or segmentation)."""
        reading = sensor.read()
        if reading is None:
            return None
        if isinstance(sensor, Camera):
            frame = reading.data
            return Reading(reading.stamp, CameraImage(frame.rgb, frame.depth if sensor.measures_depth else None,
                                                      frame.K))
        if isinstance(sensor, Lidar):
            scan = reading.data
            return Reading(reading.stamp, RangeScan(scan.ranges, scan.angles, scan.max_range))
        return reading

    def stream(self, name: str, sensor: Sensor[Any]) -> tuple[Reading[Any], ...]:
        """The samples of a queued sensor since its last delivery (the first call starts its queue)."""
        queue = self._queues.get(name)
        if queue is None:
            queue = self._queues[name] = deque(maxlen=max(1, int(sensor.config.rate_hz * QUEUE_S)))
            sensor.world.add_step_hook(_enqueuer(sensor, queue))
            _enqueuer(sensor, queue)(0.0)
        since = self._delivered.get(name, -np.inf)
        fresh = tuple(r for r in queue if r.stamp > since)
        if fresh:
            self._delivered[name] = fresh[-1].stamp
        return fresh

    # ------------------------------------------------------------- commands
    def apply(self, command: cmd.Command) -> None:
        """Apply one command to the robot, as its firmware would."""
        handler = _HANDLERS.get(type(command))
        if handler is None:
            raise TypeError(f"'{self.name}' cannot apply {type(command).__name__}: not a robot command")
        handler(self.robot, command)


def _enqueuer(sensor: Sensor[Any], queue: deque[Reading[Any]]) -> Callable[[float], None]:
    """A step hook appending ``sensor``'s newest sample to ``queue`` when it is new (the sensor samples at its rate)."""

    def enqueue(dt: float) -> None:
        reading = sensor.read()
        if reading is not None and (not queue or reading.stamp > queue[-1].stamp):
            queue.append(reading)

    return enqueue


def _safe_stop(robot: Any, command: cmd.SafeStop) -> None:
    resource = command.resource
    if resource == "rotors":
        robot.safe_stop()  # hover in place when flying (motors on, not docked), else nothing
    elif resource == "base":
        robot.stop()
    elif resource == "arm":
        robot.hold_arm()
    elif resource == "lift":
        robot.hold_lift()


def _reset_estimate(robot: Any, command: cmd.ResetEstimate) -> None:
    robot.estimator.reset(np.asarray(command.position, dtype=float), float(command.yaw))


_LIFT = {"raise": "raise_platform", "lower": "lower_platform", "hold": "hold_lift"}
_GRIPPER = {"open": "open_gripper", "close": "close_gripper", "release_scout": "release_scout"}

#: how each command type acts on the robot (world side)
_HANDLERS: dict[type[cmd.Command], Callable[[Any, Any], None]] = {
    cmd.FlyVelocity: lambda r, c: r.command_velocity(c.vx, c.vy, c.vz, c.yaw_rate, c.frame),
    cmd.Hover: lambda r, c: r.hover(),
    cmd.SetMotors: lambda r, c: r.set_motors(c.on),
    cmd.ResetEstimate: _reset_estimate,
    cmd.Drive: lambda r, c: r.drive(c.v, c.omega),
    cmd.Stop: lambda r, c: r.stop(),
    cmd.SetJointTargets: lambda r, c: r.set_joint_targets(c.q if isinstance(c.q, str) else list(c.q)),
    cmd.HoldArm: lambda r, c: r.hold_arm(),
    cmd.DockingAction: lambda r, c: getattr(r.docking, c.action)(),
    cmd.GripperAction: lambda r, c: getattr(r, _GRIPPER[c.action])(),
    cmd.LiftAction: lambda r, c: getattr(r, _LIFT[c.action])(),
    cmd.SafeStop: _safe_stop,
}

