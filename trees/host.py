"""The tree side of a run: the compiled tree and the data its nodes hold, ticked on messages alone.

A :class:`TreeHost` owns a mission's compiled tree and its
:class:`~marsupial.trees.skill.RunContext`. It never sees the world: each
tick it takes a :class:`~marsupial.api.ticks.TickInput` (time, the team's
readings, team-link deliveries, operator commands), ticks the tree once and
answers with a :class:`~marsupial.api.ticks.TickOutput` (the commands its
nodes sent, what they recorded, the tree's statuses and the sensors the
nodes it ticked declare, which the next input delivers). The runner drives
it in the same process or, with ``--isolate``, in a process of its own
(:mod:`marsupial.trees.isolation`); ``marsupial replay --against`` drives it
with a log's recorded inputs.
"""

from __future__ import annotations

from pathlib import Path

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import Status

from marsupial.api.ticks import TickInput, TickOutput, TreeSetup
from marsupial.api.views import VIEWS, RobotState, RobotView

from .btxml import STATUS_NAMES, TreeTracker
from .compiler import compile_mission
from .mission import Mission, parse_mission
from .skill import MissionNode, RunContext, Skill


def run_context(setup: TreeSetup, record_images: bool = False) -> RunContext:
    """The context a run's nodes share, built from the setup message: the team's models and views, seed, priors."""
    return RunContext(
        seed=setup.seed,
        tick_period=1.0 / setup.tick_hz,
        robots={name: RobotState(model) for name, (model, _) in setup.team.items()},
        views={name: VIEWS[view] for name, (_, view) in setup.team.items()},
        priors=dict(setup.priors),
        record_images=record_images,
    )


def deliver(context: RunContext, message: TickInput) -> None:
    """Put a tick's input in the nodes' context: the time, every robot's readings, link deliveries, operator."""
    context.now = message.t
    for name, readings in message.robots.items():
        context.robots[name].update(readings)
    context.link.update(message.link)
    for command in message.operator:
        context.operator.latch(command)


class TreeHost:
    """A tree and its nodes' data, ticked on :class:`TickInput` messages (see the module docstring).

    Args:
        context: the run context its nodes were built with (:func:`run_context`).
        root: the tree's root behaviour.
        listens: the operator commands some node of the tree listens to.
    """

    def __init__(self, context: RunContext, root: Behaviour, listens: frozenset[str] = frozenset()):
        self.context = context
        self.root = root
        self.listens = listens
        self.nodes = [node for node in root.iterate() if isinstance(node, MissionNode)]
        self._tracker = TreeTracker()

    @classmethod
    def for_mission(cls, mission: Mission, setup: TreeSetup, record_images: bool = False) -> TreeHost:
        """A host of ``mission``'s compiled tree (the blackboard cleared first)."""
        py_trees.blackboard.Blackboard.clear()
        context = run_context(setup, record_images)
        tree = compile_mission(mission, context)
        return cls(context, tree.root, frozenset(tree.listens))

    @classmethod
    def from_setup(cls, setup: TreeSetup, record_images: bool = False) -> TreeHost:
        """A host built from the setup message alone: the mission parsed from its text (isolated runs)."""
        path = Path(setup.mission_path) if setup.mission_path else None
        mission = parse_mission(setup.mission, setup.mission_path or "<mission>", setup.overrides, path)
        return cls.for_mission(mission, setup, record_images)

    # ------------------------------------------------------------- ticking
    def tick(self, message: TickInput) -> TickOutput:
        """Tick the tree once on ``message``; the commands, records, statuses and sensors to deliver next."""
        deliver(self.context, message)
        arbiter = self.context.arbiter
        arbiter.new_tick()
        self.root.tick_once()
        return self._output(self._declared(arbiter.tick))

    def pause(self, message: TickInput) -> TickOutput:
        """The operator paused the run: every robot's resources left safe, in a tick of the operator's own."""
        deliver(self.context, message)
        arbiter = self.context.arbiter
        arbiter.new_tick()
        for name, view in self.context.views.items():
            arbiter.safe_stop(view, name, "operator", "operator", sorted(view.safe_stops))
        return self._output(frozenset())

    def stop(self) -> TickOutput:
        """End of the run: skills still running are stopped (they leave their robots safe)."""
        if self.root.status == Status.RUNNING:
            self.root.stop(Status.INVALID)
        return self._output(frozenset())

    def _declared(self, tick: int) -> frozenset[tuple[str, str]]:
        """``(robot, sensor)`` pairs the nodes ticked in ``tick`` declare they read."""
        return frozenset(pair for node in self.nodes if node.ticked == tick for pair in node.wanted_sensors())

    def _output(self, sensors: frozenset[tuple[str, str]]) -> TickOutput:
        context = self.context
        records, context.records = tuple(context.records), []
        status = self.root.status
        sent = context.arbiter.take()
        return TickOutput(
            commands=tuple(command for _, command in sent),
            senders=tuple(sender for sender, _ in sent),
            records=records,
            status=STATUS_NAMES[status],
            tree=self._tracker.status(self.root),
            sensors=sensors,
            active=self._active(),
        )

    def _active(self) -> dict[str, tuple[str, ...]]:
        """The running skills' names by robot (``""``: skills without a robot)."""
        active: dict[str, list[str]] = {}
        for node in self.nodes:
            if isinstance(node, Skill) and node.status == Status.RUNNING:
                active.setdefault(node.robot_name or "", []).append(node.name)
        return {robot: tuple(names) for robot, names in active.items()}


def view_name(view_class: type[RobotView]) -> str:
    """The name under which a view class travels in a :class:`TreeSetup` (:data:`~marsupial.api.views.VIEWS`)."""
    if VIEWS.get(view_class.__name__) is not view_class:
        raise TypeError(f"{view_class.__name__} is not a view of marsupial.api.views")
    return view_class.__name__

