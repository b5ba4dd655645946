"""What a skill asks of a robot: command messages, applied by the world after the tick that sent them.

Each command is a frozen dataclass naming the team member it is for
(``robot``) and the command's arguments, in SI units. A skill never calls
the simulator: its robot view (:mod:`marsupial.api.views`) turns a call such
as ``robot.drive(0.3, 0.0)`` into :class:`Drive` and puts it in the tick's
outbox, through the run's arbiter (one node drives a resource at a time).
The world applies the outbox in order once the tree has ticked.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal


@dataclass(frozen=True)
class Command:
    """Base of every command: the team member it is for."""

    robot: str


@dataclass(frozen=True)
class FlyVelocity(Command):
    """Fly at ``(vx, vy, vz)`` m/s turning at ``yaw_rate`` rad/s; ``frame`` ``"body"`` (heading) or ``"world"``.

    ``"world"`` is the estimator's navigation frame: the autopilot tracks it on the onboard estimate.
    """

    vx: float
    vy: float
    vz: float
    yaw_rate: float = 0.0
    frame: str = "body"


@dataclass(frozen=True)
class Hover(Command):
    """Hold the present (estimated) position."""


@dataclass(frozen=True)
class SetMotors(Command):
    """Start (arm, ``on``) or stop the motors."""

    on: bool


@dataclass(frozen=True)
class ResetEstimate(Command):
    """Restart the onboard estimate at ``position`` (m) and ``yaw`` (rad) in its own frame.

    A correction the robot computed itself (a carrier's hand-over, a registration against its map).
    """

    position: tuple[float, ...]
    yaw: float


@dataclass(frozen=True)
class Drive(Command):
    """Drive a wheeled base at forward speed ``v`` (m/s) and yaw rate ``omega`` (rad/s, CCW), clipped to its limits."""

    v: float
    omega: float


@dataclass(frozen=True)
class Stop(Command):
    """Command a wheeled base to zero speed."""


@dataclass(frozen=True)
class SetJointTargets(Command):
    """Move the arm toward joint angles ``q`` (rad, base to tip) or a named pose of the robot's model."""

    q: tuple[float, ...] | str


@dataclass(frozen=True)
class HoldArm(Command):
    """Hold every arm joint where its encoder reads it now."""


@dataclass(frozen=True)
class DockingAction(Command):
    """Drive Part A's docking device: energise or release the magnet, close the levers (lock) or open them."""

    action: Literal["magnet_on", "magnet_off", "lock", "release"]


@dataclass(frozen=True)
class GripperAction(Command):
    """Open or close the gripper's fingers, or open the held launching apparatus's hold on its MAV (launch)."""

    action: Literal["open", "close", "release_scout"]


@dataclass(frozen=True)
class LiftAction(Command):
    """Raise the lifting platform to the storage capsule, lower it to the floor, or hold it where it is."""

    action: Literal["raise", "lower", "hold"]


@dataclass(frozen=True)
class SafeStop(Command):
    """Leave one resource safe (``resource``): hover in place, stop the wheels, hold the arm or the lift."""

    resource: str


@dataclass(frozen=True)
class LinkSend(Command):
    """Broadcast ``payload`` on the team link as ``robot``, on ``topic``; it arrives late, or is lost.

    ``reliable``: the sender's radio retries a lost message until it is acknowledged (it arrives later instead of
    never), and delivers the messages of its topic in the order sent.
    """

    topic: str
    payload: Any
    reliable: bool = False


#: commands a remote pilot streams at its control rate: a lost one is superseded by the next, so none is retried
PILOTING: tuple[type[Command], ...] = (FlyVelocity, Hover)


def command_topics(robot: str) -> tuple[str, str]:
    """The team-link topics on which ``robot``'s firmware takes commands from another member's computer.

    ``"<robot>/pilot"`` for piloting commands (:data:`PILOTING`: unacknowledged, the newest wins) and
    ``"<robot>/command"`` for one-shot commands (acknowledged and retried, applied in the order sent).
    """
    return f"{robot}/pilot", f"{robot}/command"


def command_topic(command: Command) -> str:
    """The team-link topic of :func:`command_topics` on which ``command`` travels."""
    pilot, one_shot = command_topics(command.robot)
    return pilot if isinstance(command, PILOTING) else one_shot


def over_link(computer: str, command: Command) -> LinkSend:
    """``command``, computed on team member ``computer``, as the radio message that carries it to its robot."""
    return LinkSend(computer, command_topic(command), command, reliable=not isinstance(command, PILOTING))
