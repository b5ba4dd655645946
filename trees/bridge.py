"""The world side of a run's tick exchange: each tick's input taken from the world, each output applied to it.

:class:`WorldBridge` holds the world and the run's recorder, never the tree:
:meth:`WorldBridge.tick_input` reads every robot through its gateway
(:class:`~marsupial.world.gateway.RobotGateway`: estimates, device states and
the sensors the tree asked for, rendered or ray-cast only then) and the
team-link deliveries; :meth:`WorldBridge.apply` applies the tree's commands
(team-link sends go on the radio) and writes what the nodes recorded. The
referee scores the run on truth through :class:`ScoreBoard`, which writes to
the recorder and to the run's result only.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

from marsupial.api.commands import LinkSend, command_topics
from marsupial.api.model import RobotModel
from marsupial.api.priors import BuildingPlan
from marsupial.api.ticks import OperatorCommand, TickInput, TickOutput, TreeSetup
from marsupial.world.gateway import RobotGateway

from . import exchange_log

if TYPE_CHECKING:
    from marsupial.world import World

    from .mission import Mission
    from .recorder import Recorder


def metric_key(name: str, labels: dict[str, Any]) -> str:
    """``name`` or, with labels, ``name[v1,v2]`` (label values in the order given): a metric's key in a result."""
    return f"{name}[{','.join(str(v) for v in labels.values())}]" if labels else name


class ScoreBoard:
    """Where the referee's truth scores go: the recorder and the run's result, never a node."""

    def __init__(self, world: World, recorder: Recorder | None, metrics: dict[str, float]):
        self._world = world
        self._recorder = recorder
        self._metrics = metrics

    def metric(self, name: str, value: float, **labels: Any) -> None:
        """Record metric ``name`` = ``value`` at the world's time and keep its last value."""
        self._metrics[metric_key(name, labels)] = float(value)
        if self._recorder is not None:
            self._recorder.log_metric(self._world.now, name, float(value), **labels)

    def event(self, kind: str, **fields: Any) -> None:
        """Record an event of ``kind`` at the world's time."""
        if self._recorder is not None:
            self._recorder.log_event(self._world.now, kind, **fields)


class WorldBridge:
    """Builds each tick's :class:`TickInput` from the world and applies each :class:`TickOutput` to it."""

    def __init__(self, world: World, recorder: Recorder | None, record_inputs: bool = False):
        self.world = world
        self.recorder = recorder
        #: log every exchanged message on ``/replay`` (``--record-inputs``)
        self.record_inputs = record_inputs and recorder is not None
        self.gateways = {name: RobotGateway(robot) for name, robot in world.robots.items()}
        for name, gateway in self.gateways.items():  # each robot's firmware obeys what other members' computers send
            for topic in command_topics(name):
                world.team_link.listen(topic, gateway.apply)
        #: the last value of every metric of the run (nodes' and referee's)
        self.metrics: dict[str, float] = {}
        self.scores = ScoreBoard(world, recorder, self.metrics)
        self._tick = 0
        self._sensors: dict[str, tuple[str, ...]] = {}

    def setup(self, mission: Mission, seed: int) -> TreeSetup:
        """What the tree side needs: the mission, the seed, every member's model and view, the building plan."""
        setup = TreeSetup(
            mission=mission.text,
            mission_path=str(mission.path) if mission.path is not None else None,
            overrides=dict(mission.overrides),
            subtrees=dict(mission.subtree_texts),
            seed=seed,
            tick_hz=mission.spec.run.tick_hz,
            team=self.team(),
            priors=self.priors(),
        )
        self._log("setup", 0, setup)
        return setup

    def team(self) -> dict[str, tuple[RobotModel, str]]:
        """Every member's model and the name of its view class."""
        return {name: (gateway.model(), gateway.view_class.__name__) for name, gateway in self.gateways.items()}

    def priors(self) -> dict[str, BuildingPlan]:
        """The scene knowledge an operator gives the robots: the building plan of the world's scene."""
        return {"building_plan": self.world.plan}

    def tick_input(self, operator: Iterable[OperatorCommand] = (), kind: str = "tick") -> TickInput:
        """The next tick's input: the time, every robot's readings (the sensors asked for), link deliveries.

        ``kind`` names the exchange it is for in the replay log (``tick`` or ``pause``).
        """
        self._tick += 1
        now = self.world.now
        robots = {name: gateway.readings(now, self._sensors.get(name, ())) for name, gateway in self.gateways.items()}
        message = TickInput(self._tick, now, robots, self.world.team_link.take_delivered(), tuple(operator))
        self._log(kind, self._tick, message)
        return message

    def _log(self, kind: str, tick: int, message: Any) -> None:
        """Write one exchanged message to the replay log (``--record-inputs``)."""
        if self.record_inputs and self.recorder is not None:
            self.recorder.log_exchange(self.world.now, kind, tick, exchange_log.encode(message))

    def apply(self, output: TickOutput) -> None:
        """Apply the tree's commands in order, write its records and statuses, and keep the sensors it asks for."""
        self._log("output", self._tick, (output.senders, output.commands))
        link = self.world.team_link
        for command in output.commands:
            if isinstance(command, LinkSend):
                link.send(command.robot, command.topic, command.payload, command.reliable)
            else:
                self.gateways[command.robot].apply(command)
        self._record(output)
        self.ask(output.sensors)

    def ask(self, sensors: Iterable[tuple[str, str]]) -> None:
        """Deliver these ``(robot, sensor)`` pairs' samples with the next inputs (and no others)."""
        by_robot: dict[str, list[str]] = {}
        for robot, sensor in sorted(sensors):
            by_robot.setdefault(robot, []).append(sensor)
        self._sensors = {robot: tuple(names) for robot, names in by_robot.items()}

    def _record(self, output: TickOutput) -> None:
        now, recorder = self.world.now, self.recorder
        for record in output.records:
            if record.kind == "metric":
                self.metrics[metric_key(record.name, record.fields)] = float(record.value)
            if recorder is None:
                continue
            if record.kind == "event":
                recorder.log_event(now, record.name, **record.fields)
            elif record.kind == "metric":
                recorder.log_metric(now, record.name, float(record.value), **record.fields)
            elif record.kind == "image":
                recorder.log_image(now, record.name, record.value, **record.fields)
        if recorder is not None and output.tree is not None:
            recorder.log_tree(now, output.tree)
