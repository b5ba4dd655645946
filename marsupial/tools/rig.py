"""Bench rigs: a robot's view read straight from a live world, its commands applied at once.

Unit tests and benchmarks of algorithms (detection on a real frame, an
estimator after a few steps) want a robot's view without a tree around it. :func:`live_view`
builds one of the robot's view class whose readings are taken from the
world whenever they are read (a sensor is sampled when it is read) and
whose commands the world applies immediately. Mission runs never use this:
their nodes get the readings of their tick, through the runtime.
"""

from __future__ import annotations

from collections import deque
from typing import Any

from marsupial.api.commands import Command, LinkSend, SafeStop
from marsupial.api.readings import RobotReadings
from marsupial.api.views import RobotState, RobotView
from marsupial.world import World
from marsupial.world.gateway import RobotGateway


class _Sensors:
    """``held``/``queues`` of a live state: each sensor read from the world when asked for."""

    def __init__(self, gateway: RobotGateway, queued: bool):
        self._gateway = gateway
        self._queued = queued

    def get(self, name: str, default: Any = None) -> Any:
        robot = self._gateway.robot
        sensor = robot.sensor(name)
        if self._queued:
            return deque(self._gateway.stream(name, sensor))
        return self._gateway.deliverable(sensor)


class LiveState(RobotState):
    """A robot state whose readings come from the world at every access (bench rigs only)."""

    __slots__ = ("_gateway",)

    def __init__(self, gateway: RobotGateway):
        self._gateway = gateway
        self.model = gateway.model()
        self.kinematics = None

    @property
    def readings(self) -> RobotReadings:  # type: ignore[override]
        return self._gateway.readings(self._gateway.robot.world.now)

    @property
    def held(self) -> Any:  # type: ignore[override]
        return _Sensors(self._gateway, queued=False)

    @property
    def queues(self) -> Any:  # type: ignore[override]
        return _Sensors(self._gateway, queued=True)


class DirectSink:
    """Commands applied to the world at once, team-link sends put on its radio; every sensor readable."""

    def __init__(self, world: World):
        self._world = world

    def submit(self, resource: str, command: Command) -> bool:
        """Apply ``command`` to its robot now."""
        RobotGateway(self._world.robot(command.robot)).apply(command)
        return True

    def safe_stop(self, robot: RobotView) -> None:
        """Apply the safe stop of each of ``robot``'s resources now."""
        for resource in sorted(robot.safe_stops):
            self.submit(resource, SafeStop(robot.name, resource))

    def broadcast(self, command: LinkSend) -> None:
        """Send a team-link message now."""
        self._world.team_link.send(command.robot, command.topic, command.payload)

    def check_read(self, robot: str, sensor: str) -> None:
        """Every sensor may be read on a rig."""


def live_view(world: World, name: str) -> Any:
    """The view of team member ``name`` read live from ``world`` (its kind's view class), commands applied at once."""
    gateway = RobotGateway(world.robot(name))
    return gateway.view_class(LiveState(gateway), DirectSink(world))



