"""Built-in conditions: battery, operator command, obstacle, explored area, difficult area, timer.

Each is a :class:`~marsupial.trees.skill.Condition` registered under the
``marsupial.conditions`` entry-point group. In the compact guard form the
value of the condition key is its ``primary`` parameter:
``{battery_below: 0.2, robot: uav}``, ``{operator: dock}``,
``{obstacle_ahead: 1.5, robot: carrier}``, ``{area_explored: 0.8}``,
``{difficult_area: 1.0, robot: carrier}``, ``{timer: 120}``.

They decide from what the robots sense (the sensing boundary,
:mod:`marsupial.api.views`): the battery monitor, the LiDAR scan, the
robot's estimated position against the zones the mission declares
(:meth:`~marsupial.trees.skill.RunContext.prior`), the blackboard and the
simulated time.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from pydantic import Field

from marsupial.api.capabilities import HasBase, HasBattery, HasLidar
from marsupial.sensing import scan_in_body, sensor_mount

from .skill import Condition, NodeParams


class BatteryBelow(Condition["BatteryBelow.Params"]):
    """Holds while the robot's battery monitor reads a state of charge below a fraction.

    The gauge reports whole percent (as the vendors' SDKs do), so the
    condition holds from the first reading below ``100 × threshold`` %; it
    does not hold before the first reading.
    """

    class Params(NodeParams):
        threshold: float = Field(0.2, ge=0.0, le=1.0)
        """State of charge (fraction 0..1) below which the condition holds."""

    primary: ClassVar[str] = "threshold"
    robot_kinds: ClassVar[tuple[type, ...]] = (HasBattery,)
    sensors: ClassVar[tuple[str, ...]] = ("battery",)  # the robots with a battery monitor (world/energy.py)

    def check(self) -> bool:
        status = self.robot.battery()
        return status is not None and status.soc_percent < 100.0 * self.params.threshold


class OperatorSaid(Condition["OperatorSaid.Params"]):
    """Holds while the operator's command is pending (said and not yet handled).

    Inside ``priorities`` the command is handled when the guarded branch
    finishes; elsewhere as soon as this condition reports that it holds
    (see :mod:`marsupial.trees.operator`).
    """

    class Params(NodeParams):
        command: str
        """Name of the operator command (``dock``, ``deploy``, …)."""

    primary: ClassVar[str] = "command"
    uses_robot: ClassVar[bool] = False

    #: set by the compiler for guards of ``priorities`` (the branch handles the command)
    handled_by_branch: bool = False

    def check(self) -> bool:
        channel = self.context.operator
        if channel is None or channel.latched(self.params.command) is None:
            return False
        if not self.handled_by_branch:
            channel.handle(self.params.command)
        return True

    def describe(self) -> str:
        channel = self.context.operator
        said = channel.latched(self.params.command) if channel is not None else None
        why = f": {said.why}" if said is not None and said.why else ""
        return f"operator({self.params.command}){why}"


class ObstacleAhead(Condition["ObstacleAhead.Params"]):
    """Holds when the robot's LiDAR sees an echo in front of it within a distance.

    The corridor is ``width`` wide, centred on the robot's heading, from its
    front (``front`` m ahead of ``base_footprint``) to ``distance`` m beyond,
    in the scan plane (for the mobile manipulator's LMS111, 0.36 m above the
    floor: lower obstacles are not seen). The latest scan counts; none yet:
    the condition does not hold.
    """

    class Params(NodeParams):
        distance: float = Field(1.0, gt=0.0)
        """Look-ahead distance from the robot's front (m)."""
        width: float = Field(0.6, gt=0.0)
        """Width of the watched corridor (m), centred on the robot."""
        front: float = Field(0.23, ge=0.0)
        """Distance (m) from ``base_footprint`` to the robot's front (Pioneer 3-DX: 0.455 m long)."""
        sensor: str = "lidar"
        """The planar LiDAR read (its URDF link has the same name)."""

    primary: ClassVar[str] = "distance"
    robot_kinds: ClassVar[tuple[type, ...]] = (HasBase, HasLidar)  # the wheeled robots with a planar LiDAR
    sensors: ClassVar[tuple[str, ...]] = ("{sensor}",)

    def check(self) -> bool:
        p = self.params
        port = self.robot.sensor(p.sensor)
        reading = port.read()
        if reading is None:
            return False
        echoes = scan_in_body(reading.data, sensor_mount(self.robot, p.sensor, port.offset))
        x, y = echoes[:, 0], echoes[:, 1]
        return bool(np.any((x >= p.front) & (x <= p.front + p.distance) & (np.abs(y) <= 0.5 * p.width)))


class AreaExplored(Condition["AreaExplored.Params"]):
    """Holds when the explored fraction on the blackboard reaches a threshold."""

    class Params(NodeParams):
        fraction: float = Field(0.8, ge=0.0, le=1.0)
        """Coverage fraction (0..1) at which the area counts as explored."""
        key: str = "coverage"
        """Blackboard key holding the explored fraction (written by an exploring skill)."""

    primary: ClassVar[str] = "fraction"
    uses_robot: ClassVar[bool] = False
    reads = ("{key}",)

    def check(self) -> bool:
        return float(self.read(self.params.key, 0.0)) >= self.params.fraction


class DifficultArea(Condition["DifficultArea.Params"]):
    """Holds when the robot's estimated position is near a declared difficult zone or plan element.

    Near means within a distance of a zone or plan element tagged as difficult.

    Zones and plan elements (door frames) come from the building plan the
    mission declares (``prior("building_plan")``), each by its box in plan
    view; the position is the robot's onboard estimate, so localisation
    error shifts where the condition starts to hold. The default tags are
    corridors and door frames.
    """

    class Params(NodeParams):
        distance: float = Field(1.0, ge=0.0)
        """Distance (m) from the tagged zone or element at which the condition holds."""
        tags: tuple[str, ...] = ("corridor", "door_frame")
        """Tags of the declared zones and plan elements that mark difficult areas."""

    primary: ClassVar[str] = "distance"

    def check(self) -> bool:
        plan = self.context.prior("building_plan")
        xy = self.robot.estimate().position[:2]
        d = self.params.distance
        return any(
            plan.zones_at(xy, margin=d, tag=tag) or any(e.distance(xy) <= d for e in plan.tagged(tag))
            for tag in self.params.tags
        )


class Timer(Condition["Timer.Params"]):
    """Holds once the simulated time reaches a given number of seconds since the run started."""

    class Params(NodeParams):
        seconds: float = Field(ge=0.0)
        """Simulated time (s) from which the condition holds."""

    primary: ClassVar[str] = "seconds"
    uses_robot: ClassVar[bool] = False

    def check(self) -> bool:
        return self.now + 1e-9 >= self.params.seconds
