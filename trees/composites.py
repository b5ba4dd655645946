"""The tree nodes the compiler adds to py_trees': priorities with preemption records, sim-time timeout.

* :class:`Priorities` — a memoryless ``Selector`` whose children are
  :class:`GuardedBranch` es (``Sequence(guard..., do)``, guards re-evaluated
  every tick). When a higher-priority branch takes over from a running
  lower one, each skill or idle node that was running in the lower branch is recorded as
  a ``preemption`` event (``preempted``, ``by``, ``why``, ``robot``, and
  ``stop``: ``"safe_stop"`` when its safe-stop was applied, ``"kept by <node>"``
  when the preempting node already drives that robot in this tick).
* :class:`SimTimeout` — like ``py_trees.decorators.Timeout`` but on the
  world's *simulated* clock (py_trees' uses wall time).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from typing import Any

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import Status

from .conditions import OperatorSaid
from .skill import Condition, RunContext, Skill


class GuardedBranch(py_trees.composites.Sequence):
    """One entry of ``priorities``: its guard conditions, then its ``do`` node (memoryless).

    When the ``do`` node finishes (success or failure), the operator commands
    that guarded it are handled (un-latched).
    """

    def __init__(self, name: str, guards: Sequence[Condition[Any]], do: Behaviour, context: RunContext):
        super().__init__(name, memory=False, children=[*guards, do])
        self.guards = list(guards)
        self.do = do
        self.context = context
        for guard in self.guards:
            if isinstance(guard, OperatorSaid):
                guard.handled_by_branch = True

    def describe(self) -> str:
        """Text of the guards (``"battery_below(0.2, robot=uav)"``), the reason of a preemption."""
        return " and ".join(g.describe() for g in self.guards) or "default branch"

    def terminate(self, new_status: Status) -> None:
        channel = self.context.operator
        if channel is not None and new_status in (Status.SUCCESS, Status.FAILURE) and self.do.status == new_status:
            for guard in self.guards:
                if isinstance(guard, OperatorSaid):
                    channel.handle(guard.params.command)


def running_leaves(node: Behaviour) -> list[Behaviour]:
    """Leaves of ``node``'s subtree that are RUNNING: skills, and nodes that only wait (``idle``)."""
    return [n for n in node.iterate() if not n.children and n.status == Status.RUNNING]


class Priorities(py_trees.composites.Selector):
    """Reactive fallback over guarded branches, recording who preempted whom and why.

    Children are :class:`GuardedBranch` es or, for an unguarded last entry,
    any node. Skills of a preempted branch are terminated with INVALID by
    py_trees after the higher branch has been initialised and ticked; their
    ``finish`` leaves the robot safe through the arbiter.
    """

    def __init__(self, name: str, children: Sequence[Behaviour], context: RunContext):
        super().__init__(name, memory=False, children=list(children))
        self.context = context

    def tick(self) -> Iterator[Behaviour]:
        before = self.current_child if self.status == Status.RUNNING else None
        running = running_leaves(before) if before is not None else []
        for node in super().tick():
            if node is self and before is not None:
                self._record_preemption(before, running)
            yield node

    def _record_preemption(self, before: Behaviour, running: list[Behaviour]) -> None:
        now = self.current_child
        if now is None or now is before or self.status == Status.FAILURE:
            return
        if self.children.index(now) > self.children.index(before):
            return  # the running branch gave up (its guard no longer holds): not a preemption
        by = now.do.name if isinstance(now, GuardedBranch) else now.name
        why = now.describe() if isinstance(now, GuardedBranch) else "default branch"
        if not running:
            self.context.event("preemption", preempted=before.name, by=by, why=why, robot=None, stop=None)
        for leaf in running:
            self.context.event(
                "preemption",
                preempted=leaf.name,
                by=by,
                why=why,
                robot=getattr(leaf, "robot_name", None),
                stop=stop_text(leaf),
            )


def stop_text(leaf: Behaviour) -> str | None:
    """How a stopped leaf left its robot: ``"safe_stop"``, ``"kept by <node>"``, ``None`` (no robot, or not a skill)."""
    if not isinstance(leaf, Skill) or not leaf.uses_robot or leaf.robot_name is None:
        return None
    return "safe_stop" if leaf.stopped_by is None else f"kept by {leaf.stopped_by.node_name}"


class SimTimeout(py_trees.decorators.Decorator):
    """Fail (stopping the child) when the child runs longer than ``seconds`` of simulated time.

    A subclass sets ``expired`` (the status when the time is up) and ``expired_text`` (its feedback).
    """

    btcpp_tag: str | None = "Timeout"  # BehaviorTree.CPP export (trees/btxml.py)
    expired = Status.FAILURE
    expired_text = "timed out after {seconds:g} s"

    def __init__(self, name: str, child: Behaviour, seconds: float, clock: Callable[[], float]):
        super().__init__(name=name, child=child)
        self.seconds = float(seconds)
        self._clock = clock
        self._deadline = 0.0

    def btcpp_ports(self) -> dict[str, float]:
        """BehaviorTree.CPP ``Timeout`` port: the limit in milliseconds."""
        return {"msec": int(round(self.seconds * 1000.0))}

    def initialise(self) -> None:
        self._deadline = self._clock() + self.seconds

    def update(self) -> Status:
        if self.decorated.status != Status.RUNNING:
            self.feedback_message = self.decorated.feedback_message
            return self.decorated.status
        left = self._deadline - self._clock()
        if left <= 1e-9:
            self.feedback_message = self.expired_text.format(seconds=self.seconds)
            return self.expired
        self.feedback_message = f"{left:.1f} s left"
        return Status.RUNNING
