"""The nodes that wait: ``wait_until`` (a guard), ``run_for`` (a child for a while) and ``idle`` (forever).

=============  ==================================================================
mission node   py_trees
=============  ==================================================================
wait_until     :class:`WaitUntil` decorating the guard's condition: RUNNING until
               the condition holds (SUCCESS); with ``timeout``, FAILURE when it
               has not held after that many simulated seconds
run_for        :class:`RunFor` (a :class:`~.composites.SimTimeout` whose expiry is
               SUCCESS): the child's own SUCCESS or FAILURE before ``seconds``,
               else SUCCESS with the child stopped
idle           :class:`Idle`: RUNNING forever, commanding nothing
=============  ==================================================================

None of them commands a robot: a waiting branch leaves its robots to the
skills around it (a stopped skill's ``finish`` has already left them safe).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import Status

from .composites import SimTimeout
from .mission import IdleNode, NodeBase, RunForNode, WaitUntilNode

if TYPE_CHECKING:
    from .compiler import _Compiler
    from .skill import Condition

#: node types built here (see :func:`build_waiting`)
WAITING_KINDS = ("wait_until", "run_for", "idle")


class Idle(Behaviour):
    """RUNNING at every tick, commanding nothing; ends only when its parent stops it."""

    def update(self) -> Status:
        self.feedback_message = "idle"
        return Status.RUNNING


class WaitUntil(py_trees.decorators.Decorator):
    """RUNNING until its condition holds (then SUCCESS); FAILURE after ``timeout`` simulated seconds (``inf``: never).

    The condition is ticked every tick (it never runs); the node commands nothing.
    """

    def __init__(self, name: str, condition: Condition[Any], timeout: float, clock: Callable[[], float]):
        super().__init__(name=name, child=condition)
        self.timeout = float(timeout)
        self._clock = clock
        self._deadline = math.inf

    def btcpp_ports(self) -> dict[str, float]:
        """Port of the BehaviorTree.CPP export: the time limit (s), when there is one."""
        return {} if math.isinf(self.timeout) else {"timeout": self.timeout}

    def initialise(self) -> None:
        self._deadline = self._clock() + self.timeout

    def update(self) -> Status:
        if self.decorated.status == Status.SUCCESS:
            self.feedback_message = f"{self.decorated.name} holds"
            return Status.SUCCESS
        left = self._deadline - self._clock()
        if left <= 1e-9:
            self.feedback_message = f"{self.decorated.name} did not hold within {self.timeout:g} s"
            return Status.FAILURE
        limit = "" if math.isinf(left) else f", {left:.1f} s left"
        self.feedback_message = f"waiting for {self.decorated.name}{limit}"
        return Status.RUNNING


class RunFor(SimTimeout):
    """Run the child for ``seconds`` of simulated time: SUCCESS (child stopped) if it is still running then.

    The child's own SUCCESS or FAILURE before that is the node's result: unlike ``invert: timeout:``, a
    failing child fails the node.
    """

    btcpp_tag = None  # no BehaviorTree.CPP built-in behaves like it: exported as a RunFor decorator
    expired = Status.SUCCESS
    expired_text = "ran for {seconds:g} s"

    def btcpp_ports(self) -> dict[str, float]:
        """Port of the BehaviorTree.CPP export: the duration (s)."""
        return {"seconds": self.seconds}


def build_waiting(compiler: _Compiler, node: NodeBase) -> Behaviour:
    """The py_trees behaviour of a ``wait_until``, ``run_for`` or ``idle`` node (children built by ``compiler``)."""
    context = compiler.context

    def clock() -> float:
        return context.now

    if isinstance(node, WaitUntilNode):
        guard = compiler.guard(node.wait_until)
        timeout = math.inf if node.timeout is None else node.timeout
        return WaitUntil(compiler.unique(node.name or f"wait until {guard.describe()}"), guard, timeout, clock)
    if isinstance(node, RunForNode):
        return RunFor(compiler.unique(node.name or "run_for"), compiler.build(node.run_for), node.seconds, clock)
    if isinstance(node, IdleNode):
        return Idle(compiler.unique(node.name or "idle"))
    raise compiler.mission.error_at(node, f"'{node.kind}' is not a waiting node")
