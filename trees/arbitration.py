"""Command arbitration: who drives a robot when two nodes act on it in the same tick.

A py_trees memoryless selector initialises and ticks a higher-priority child
*before* it terminates the running lower child (see ``Selector.tick``). The
terminating skill's "leave the robot safe" would then overwrite the command
the preempting skill has just sent. The :class:`Arbiter` prevents that: every
robot command is stamped with the tick number and the issuing node, and a
safe-stop asked for in tick *k* is dropped when another node already
commanded that robot in tick *k* (that node has taken the robot over and is
responsible for it).

Skills never hold a robot's body: they get a :class:`CommandPort` over its
onboard interface (:mod:`marsupial.world.onboard`), whose reads (estimate,
sensors, device states) pass through unchanged and whose command methods
(the interface's ``commands``) go through the arbiter.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from marsupial.world.onboard import Onboard as Robot


@dataclass(frozen=True)
class Stamp:
    """The last command a robot received: tick number, issuing node (uid and name), method."""

    tick: int
    node_id: Any
    node_name: str
    method: str


def commands_of(robot: Robot) -> frozenset[str]:
    """Names of the command methods of an onboard interface (its ``commands`` attribute)."""
    return frozenset(robot.commands)


class Arbiter:
    """Stamps robot commands with the tick and the node, and arbitrates safe-stops.

    The runner calls :meth:`new_tick` before every tree tick. Ticks count
    from 1; commands sent outside a tick (tick 0) are stamped too.
    """

    def __init__(self) -> None:
        self.tick = 0
        self._last: dict[str, Stamp] = {}

    def new_tick(self) -> int:
        """Start the next tick; returns its number."""
        self.tick += 1
        return self.tick

    def last(self, robot_name: str) -> Stamp | None:
        """Stamp of the last command ``robot_name`` received (``None`` if none yet)."""
        return self._last.get(robot_name)

    def command(self, robot: Robot, node_id: Any, node_name: str, method: str, *args: Any, **kwargs: Any) -> Any:
        """Call ``robot.<method>(*args, **kwargs)`` on behalf of a node and stamp it."""
        result = getattr(robot, method)(*args, **kwargs)
        self._last[robot.name] = Stamp(self.tick, node_id, node_name, method)
        return result

    def safe_stop(self, robot: Robot, node_id: Any, node_name: str) -> Stamp | None:
        """Leave ``robot`` safe on behalf of a stopping node, unless another node drives it this tick.

        Returns ``None`` when ``robot.safe_stop()`` was applied, else the
        stamp of the command (issued in this tick by another node) that kept
        the robot.
        """
        last = self._last.get(robot.name)
        if last is not None and last.tick == self.tick and last.node_id != node_id:
            return last
        robot.safe_stop()
        self._last[robot.name] = Stamp(self.tick, node_id, node_name, "safe_stop")
        return None


class CommandPort:
    """A robot as one node sees it: attribute reads pass through, commands are arbitrated.

    ``port.pose()``, ``port.battery``, ``port.sensor("lidar")`` read the robot;
    ``port.command_velocity(...)``, ``port.drive(...)``, … are stamped by the
    arbiter; ``port.safe_stop()`` is the arbitrated safe-stop (it may be
    dropped, see :meth:`Arbiter.safe_stop`).
    """

    __slots__ = ("robot", "_arbiter", "_node_id", "_node_name", "_commands")

    def __init__(self, robot: Robot, arbiter: Arbiter, node_id: Any, node_name: str):
        self.robot = robot
        self._arbiter = arbiter
        self._node_id = node_id
        self._node_name = node_name
        self._commands = commands_of(robot)

    def __getattr__(self, name: str) -> Any:
        value = getattr(self.robot, name)
        if name not in self._commands or not callable(value):
            return value
        if name == "safe_stop":
            return lambda: self._arbiter.safe_stop(self.robot, self._node_id, self._node_name)

        def arbitrated(*args: Any, **kwargs: Any) -> Any:
            return self._arbiter.command(self.robot, self._node_id, self._node_name, name, *args, **kwargs)

        return arbitrated

    def __repr__(self) -> str:
        return f"CommandPort({self.robot.name!r} for {self._node_name!r})"
