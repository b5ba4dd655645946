"""Command arbitration: who drives a robot's resource when two nodes act on it in the same tick.

A py_trees memoryless selector initialises and ticks a higher-priority child
*before* it terminates the running lower child (see ``Selector.tick``). The
terminating skill's "leave the robot safe" would then overwrite the command
the preempting skill has just sent. The :class:`Arbiter` prevents that, per
robot and resource (:data:`~marsupial.world.capabilities.RESOURCES`: a
carrier's base, arm and docking device are driven by different skills):
every command is stamped with the tick number and the issuing node, and a
command a node sends while it finishes (its ``finish()``, safe-stops
included) is dropped when another node already commanded that resource in
the same tick (that node has taken the resource over and is responsible for
it).

Skills never hold a robot's interface: they get a :class:`CommandPort` over
it (:mod:`marsupial.world.onboard`), whose reads (estimate, sensors, device
states) pass through unchanged and whose command methods (the interface's
``commands``, device commands such as ``docking.release`` included) go
through the arbiter, for the resources the node claims only.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Collection
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from marsupial.world.onboard import Onboard

#: a claim on every resource of a robot (the default of a skill that declares none)
ANY_RESOURCE = "*"


@dataclass(frozen=True)
class Stamp:
    """The last command a resource received: tick number, issuing node (uid and name), method."""

    tick: int
    node_id: Any
    node_name: str
    method: str


class UnclaimedResourceError(RuntimeError):
    """A node commanded a robot resource it does not claim (a plug-in's ``claims`` are incomplete)."""


class Arbiter:
    """Stamps commands per robot and resource with the tick and the node.

    It drops a finishing node's commands on a resource taken over.

    The runner calls :meth:`new_tick` before every tree tick. Ticks count
    from 1; commands sent outside a tick (tick 0) are stamped too.
    """

    def __init__(self) -> None:
        self.tick = 0
        self._last: dict[tuple[str, str], Stamp] = {}

    def new_tick(self) -> int:
        """Start the next tick; returns its number."""
        self.tick += 1
        return self.tick

    def last(self, robot_name: str, resource: str | None = None) -> Stamp | None:
        """Stamp of the last command ``robot_name``'s ``resource`` (any: the latest) received; ``None`` if none."""
        stamps = [s for (r, res), s in self._last.items() if r == robot_name and resource in (None, res)]
        return max(stamps, key=lambda s: s.tick, default=None)

    def holder(self, robot_name: str, resource: str, node_id: Any) -> Stamp | None:
        """The stamp of another node's command to that resource in this tick (it keeps the resource), else ``None``."""
        last = self._last.get((robot_name, resource))
        if last is not None and last.tick == self.tick and last.node_id != node_id:
            return last
        return None

    def command(
        self, robot: str, resource: str, call: Callable[[], Any], node_id: Any, node_name: str, method: str,
        yielding: bool = False,
    ) -> tuple[Any, Stamp | None]:
        """Send one command (``call()``) to ``robot``'s ``resource`` on behalf of a node and stamp it.

        ``yielding`` (a finishing node): the command is dropped when another
        node commanded the resource in this tick. Returns the call's result
        (``None`` when dropped) and the stamp that kept the resource (``None``
        when the command was sent).
        """
        if yielding:
            kept = self.holder(robot, resource, node_id)
            if kept is not None:
                return None, kept
        result = call()
        self._last[(robot, resource)] = Stamp(self.tick, node_id, node_name, method)
        return result, None

    def safe_stop(
        self, robot: Onboard, node_id: Any, node_name: str, resources: Collection[str] | None = None
    ) -> Stamp | None:
        """Leave ``resources`` of ``robot`` (default: all) safe for a stopping node, each unless taken over this tick.

        Returns ``None`` when every safe-stop was applied, else the stamp of
        the first command (issued in this tick by another node) that kept a
        resource.
        """
        kept: Stamp | None = None
        for resource in sorted(robot.resources() if resources is None else resources):
            _, holder = self.command(
                robot.name, resource, functools.partial(robot.safe_stop, resource), node_id, node_name, "safe_stop",
                yielding=True,
            )
            kept = kept or holder
        return kept


@dataclass
class Claimant:
    """The node a :class:`CommandPort` commands for: its uid and name, the resources it claims, whether it is finishing.

    ``claims`` holds ``(robot, resource)`` pairs (``resource`` may be
    :data:`ANY_RESOURCE`); ``kept`` is the first stamp that kept a resource
    from one of its finishing commands.
    """

    node_id: Any
    name: str
    claims: frozenset[tuple[str, str]]
    finishing: bool = False
    kept: Stamp | None = None

    def may_command(self, robot: str, resource: str) -> bool:
        """Whether the node claims ``robot``'s ``resource``."""
        return (robot, resource) in self.claims or (robot, ANY_RESOURCE) in self.claims


class CommandPort:
    """A robot as one node sees it: attribute reads pass through, commands are arbitrated per resource.

    ``port.estimate()``, ``port.battery()``, ``port.sensor("lidar")`` read the
    robot; ``port.command_velocity(...)``, ``port.drive(...)``,
    ``port.docking.release()`` … are stamped by the arbiter (and refused,
    with :class:`UnclaimedResourceError`, on a resource the node does not
    claim); ``port.safe_stop()`` is the arbitrated safe-stop of the claimed
    resources (each may be dropped, see :meth:`Arbiter.safe_stop`).
    Private attributes of the interface are not reachable.
    """

    __slots__ = ("_onboard", "_target", "_prefix", "_arbiter", "_node")

    def __init__(self, onboard: Onboard, arbiter: Arbiter, node: Claimant, target: Any = None, prefix: str = ""):
        self._onboard = onboard
        self._target = onboard if target is None else target
        self._prefix = prefix
        self._arbiter = arbiter
        self._node = node

    @property
    def name(self) -> str:
        """The robot's team name."""
        return str(self._onboard.name)

    def provides(self, capability: type) -> bool:
        """Whether the robot has ``capability`` (a protocol of :mod:`marsupial.world.capabilities`)."""
        return isinstance(self._onboard, capability)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(f"{name!r}: the private attributes of '{self._onboard.name}' are not its interface")
        value = getattr(self._target, name)
        qualified = self._prefix + name
        if not self._prefix and name in self._onboard.devices():
            return CommandPort(self._onboard, self._arbiter, self._node, value, f"{name}.")
        if qualified == "safe_stop":
            return self.safe_stop
        resource = self._onboard.commands.get(qualified)
        if resource is None or not callable(value):
            return value

        def arbitrated(*args: Any, **kwargs: Any) -> Any:
            return self._command(resource, qualified, lambda: value(*args, **kwargs))

        return arbitrated

    def _command(self, resource: str, method: str, call: Callable[[], Any]) -> Any:
        node, robot = self._node, self._onboard.name
        if not node.may_command(robot, resource):
            raise UnclaimedResourceError(
                f"'{node.name}' commands {method}() of '{robot}' (resource '{resource}'), which it does not claim; "
                f"expected '{resource}' (its own robot) or '{{member}}/{resource}' in the node's 'claims'"
            )
        result, kept = self._arbiter.command(robot, resource, call, node.node_id, node.name, method, node.finishing)
        node.kept = node.kept or kept
        return result

    def safe_stop(self) -> Stamp | None:
        """Arbitrated safe stop of the resources of this robot the node claims.

        The stamp that kept one, else ``None``.
        """
        node, robot = self._node, self._onboard.name
        resources = [r for r in sorted(self._onboard.resources()) if node.may_command(robot, r)]
        kept = self._arbiter.safe_stop(self._onboard, node.node_id, node.name, resources)
        node.kept = node.kept or kept
        return kept

    def __repr__(self) -> str:
        return f"CommandPort({self._onboard.name!r} for {self._node.name!r})"
