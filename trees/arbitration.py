"""Command arbitration: who drives a robot's resource when two nodes act on it in the same tick.

A py_trees memoryless selector initialises and ticks a higher-priority child
*before* it terminates the running lower child (see ``Selector.tick``). The
terminating skill's "leave the robot safe" would then overwrite the command
the preempting skill has just sent. The :class:`Arbiter` prevents that, per
robot and resource (:data:`~marsupial.api.capabilities.RESOURCES`: a
carrier's base, arm and docking device are driven by different skills):
every command is stamped with the tick number and the issuing node, and a
command a node sends while it finishes (its ``finish()``, safe-stops
included) is dropped when another node already commanded that resource in
the same tick (that node has taken the resource over and is responsible for
it).

Nodes never hold a robot: they hold views (:mod:`marsupial.api.views`)
whose commands go to a :class:`NodeSink`, which checks the node's claims,
stamps the command through the arbiter and appends it to the tick's outbox.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from marsupial.api.commands import Command, LinkSend, SafeStop, over_link

if TYPE_CHECKING:
    from marsupial.api.views import RobotView

#: a claim on every resource of a robot (the default of a skill that declares none)
ANY_RESOURCE = "*"


@dataclass(frozen=True)
class Stamp:
    """The last command a resource received: tick number, issuing node (uid and name), command type."""

    tick: int
    node_id: Any
    node_name: str
    method: str


class UnclaimedResourceError(RuntimeError):
    """A node commanded a robot resource it does not claim (a plug-in's ``claims`` are incomplete)."""


class Arbiter:
    """Stamps commands per robot and resource with the tick and the node, and keeps the tick's outbox.

    The runtime calls :meth:`new_tick` before every tree tick. Ticks count
    from 1; commands sent outside a tick (tick 0) are stamped too.
    """

    def __init__(self) -> None:
        self.tick = 0
        self._last: dict[tuple[str, str], Stamp] = {}
        #: the commands sent since the runtime last took them (:meth:`take`), in order, each with its sender's name
        self.outbox: list[tuple[str, Command]] = []

    def new_tick(self) -> int:
        """Start the next tick; returns its number."""
        self.tick += 1
        return self.tick

    def take(self) -> tuple[tuple[str, Command], ...]:
        """``(sender, command)`` of the commands sent since the last call, in order (the outbox is emptied)."""
        sent, self.outbox = tuple(self.outbox), []
        return sent

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

    def command(self, resource: str, command: Command, node_id: Any, node_name: str,
                yielding: bool = False, computer: str | None = None) -> Stamp | None:
        """Send ``command`` to its robot's ``resource`` on behalf of a node.

        ``yielding`` (a finishing node): the command is dropped when another
        node commanded the resource in this tick. ``computer``: the team member
        whose computer runs the node; a command for another robot goes out as
        its radio message (:func:`~marsupial.api.commands.over_link`). Returns
        the stamp that kept the resource (``None`` when the command was sent).
        """
        robot = command.robot
        if yielding:
            kept = self.holder(robot, resource, node_id)
            if kept is not None:
                return kept
        self._last[(robot, resource)] = Stamp(self.tick, node_id, node_name, type(command).__name__)
        if computer is not None and computer != robot:
            command = over_link(computer, command)
        self.outbox.append((node_name, command))
        return None

    def safe_stop(self, robot: RobotView | type[RobotView], name: str, node_id: Any, node_name: str,
                  resources: Any = None, computer: str | None = None) -> Stamp | None:
        """Leave ``resources`` of robot ``name`` (default: all its kind's) safe for a stopping node.

        Each resource is stopped unless another node took it over in this tick.
        Returns ``None`` when every safe-stop was applied, else the stamp of
        the first command that kept a resource.
        """
        kept: Stamp | None = None
        for resource in sorted(robot.resources() if resources is None else resources):
            holder = self.command(resource, SafeStop(name, resource), node_id, node_name, True, computer)
            kept = kept or holder
        return kept


@dataclass
class Claimant:
    """The node a :class:`NodeSink` commands for: its uid and name, the resources it claims, whether it is finishing.

    ``claims`` holds ``(robot, resource)`` pairs (``resource`` may be
    :data:`ANY_RESOURCE`); ``kept`` is the first stamp that kept a resource
    from one of its finishing commands; ``computer`` is the team member whose
    onboard computer runs the node (``None``: each command's own robot, no radio).
    """

    node_id: Any
    name: str
    claims: frozenset[tuple[str, str]]
    finishing: bool = False
    kept: Stamp | None = None
    computer: str | None = None

    def may_command(self, robot: str, resource: str) -> bool:
        """Whether the node claims ``robot``'s ``resource``."""
        return (robot, resource) in self.claims or (robot, ANY_RESOURCE) in self.claims


class UndeclaredSensorError(RuntimeError):
    """A node read a sensor it does not declare (a plug-in's ``sensors`` are incomplete): it is not delivered."""


class NodeSink:
    """Where one node's commands go (claims checked, stamped by the arbiter, appended to the tick's outbox).

    It also holds the ``(robot, sensor)`` pairs the node declares it reads: only those are delivered.
    """

    __slots__ = ("_arbiter", "_node", "_sensors")

    def __init__(self, arbiter: Arbiter, node: Claimant, sensors: frozenset[tuple[str, str]] = frozenset()):
        self._arbiter = arbiter
        self._node = node
        self._sensors = sensors

    def check_read(self, robot: str, sensor: str) -> None:
        """Raise :class:`UndeclaredSensorError` unless the node declares ``sensor`` of ``robot``."""
        if (robot, sensor) not in self._sensors:
            raise UndeclaredSensorError(
                f"'{self._node.name}' reads sensor '{sensor}' of '{robot}', which it does not declare; expected "
                f"'{sensor}' (its own robot) or '{{member}}/{sensor}' in the node's 'sensors'"
            )

    def submit(self, resource: str, command: Command) -> bool:
        """Send ``command`` to its robot's ``resource``; whether it was sent (a finishing node yields).

        Raises :class:`UnclaimedResourceError` for a resource the node does not claim.
        """
        node, robot = self._node, command.robot
        if not node.may_command(robot, resource):
            raise UnclaimedResourceError(
                f"'{node.name}' commands {type(command).__name__} of '{robot}' (resource '{resource}'), which it "
                f"does not claim; expected '{resource}' (its own robot) or '{{member}}/{resource}' in the node's "
                "'claims'"
            )
        kept = self._arbiter.command(resource, command, node.node_id, node.name, node.finishing, node.computer)
        node.kept = node.kept or kept
        return kept is None

    def safe_stop(self, robot: RobotView) -> None:
        """Arbitrated safe stop of the resources of ``robot`` the node claims (each unless taken over this tick)."""
        node = self._node
        resources = [r for r in sorted(robot.resources()) if node.may_command(robot.name, r)]
        stoppable = [r for r in resources if r in robot.safe_stops]
        kept = self._arbiter.safe_stop(robot, robot.name, node.node_id, node.name, stoppable, node.computer)
        node.kept = node.kept or kept

    def broadcast(self, command: LinkSend) -> None:
        """Send a team-link message (no resource: the radio is every node's)."""
        self._arbiter.outbox.append((self._node.name, command))
