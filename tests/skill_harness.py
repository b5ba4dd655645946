"""Ticks mission nodes against a real world without a mission file (skill-level tests), optionally logging to MCAP.

The nodes get what they get in a mission run: the tree side's context
(:func:`~marsupial.trees.host.run_context`), ticked by a
:class:`~marsupial.trees.host.TreeHost` on the messages the world side
(:class:`~marsupial.trees.bridge.WorldBridge`) builds, its outputs applied
to the world after every tick.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import Status

from marsupial.api.ticks import TickOutput, TreeSetup
from marsupial.trees.bridge import WorldBridge
from marsupial.trees.host import TreeHost, deliver, run_context
from marsupial.trees.operator import OperatorChannel
from marsupial.trees.recorder import Recorder
from marsupial.trees.skill import NodeParams
from marsupial.world import World
from marsupial.world.scoring import Referee


class Harness:
    """A run context over ``world`` that ticks a tree at ``tick_hz`` (simulated), like the runner does.

    With ``log_path`` the nodes' events and metrics and the robots' true
    and estimated poses (every tick) are recorded to that MCAP file;
    :meth:`close` finalises it. The runner's referee scores the run on truth
    (tracking errors, unintended contacts), as in a mission run.
    """

    def __init__(self, world: World, tick_hz: float = 10.0, log_path: str | Path | None = None,
                 operator: OperatorChannel | None = None):
        py_trees.blackboard.Blackboard.clear()
        self.world = world
        #: the operator's commands, polled before every tick and delivered with its input
        self.operator = operator
        self.recorder = Recorder(log_path, {"mission_name": "harness"}) if log_path is not None else None
        self.bridge = WorldBridge(world, self.recorder)
        setup = TreeSetup("", None, {}, {}, world.seed, tick_hz, self.bridge.team(), self.bridge.priors())
        self.context = run_context(setup)
        world.add_actor(Referee(world, self.bridge.scores))
        self.period = 1.0 / tick_hz
        self._host: TreeHost | None = None

    def node(self, cls: type, robot: str | None = None, name: str | None = None, **params) -> Behaviour:
        """A node of class ``cls`` on ``robot`` with ``params`` (validated like a mission's)."""
        validated: NodeParams = cls.Params.model_validate(params)
        return cls(name or cls.__name__.lower(), validated, self.context, robot)

    def feed(self, *nodes: Behaviour) -> None:
        """Deliver this instant's readings to the nodes' context (the sensors ``nodes`` declare), as a tick does."""
        self.bridge.ask(pair for node in nodes for pair in node.reads_sensors)
        deliver(self.context, self.bridge.tick_input())
        self.context.arbiter.new_tick()

    def flush(self) -> None:
        """Apply the commands nodes sent outside :meth:`run` (after :meth:`feed` and direct checks) to the world."""
        sent, records = self.context.arbiter.take(), tuple(self.context.records)
        self.context.records.clear()
        self.bridge.apply(TickOutput(tuple(c for _, c in sent), tuple(s for s, _ in sent), records))

    def host(self, root: Behaviour) -> TreeHost:
        """The tree side ticking ``root`` (kept while the root is the same)."""
        if self._host is None or self._host.root is not root:
            self._host = TreeHost(self.context, root)
        return self._host

    def run(self, root: Behaviour, seconds: float, on_tick: Callable[[], None] | None = None) -> Status:
        """Tick ``root`` until it ends or ``seconds`` of simulated time pass; returns its last status."""
        host, bridge = self.host(root), self.bridge
        end = self.world.now + seconds
        while True:
            said = self.operator.poll(self.world.now) if self.operator is not None else ()
            bridge.apply(host.tick(bridge.tick_input(said)))
            if self.recorder is not None:
                robots = self.world.robots.items()
                self.recorder.log_robot_poses(
                    self.world.now,
                    {n: r.pose() for n, r in robots},
                    {n: (r.estimator.estimate().position, r.estimator.estimate().orientation) for n, r in robots},
                )
            if on_tick is not None:
                on_tick()
            if root.status in (Status.SUCCESS, Status.FAILURE) or self.world.now + 1e-9 >= end:
                return root.status
            self.world.step(self.period)

    def stop(self, root: Behaviour) -> None:
        """Stop a still-running tree as the runner does at the end of a run (its robots left safe)."""
        self.bridge.apply(self.host(root).stop())

    def close(self) -> None:
        """Finalise the log (if any)."""
        if self.recorder is not None:
            self.recorder.close("success")

    def blackboard(self, key: str):
        """Value of a blackboard key (``None`` if unset)."""
        return py_trees.blackboard.Blackboard.storage.get(key if key.startswith("/") else "/" + key)
