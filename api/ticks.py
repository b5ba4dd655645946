"""The messages the world side and the tree side exchange, in lockstep, once per tick.

Before a tick the world side sends a :class:`TickInput`: the simulated time,
each robot's :class:`~marsupial.api.readings.RobotReadings` (the sensors the
running nodes declared, rendered or ray-cast only then), the team-link
messages delivered since the last tick and the operator's commands. The tree
ticks on them alone and answers with a :class:`TickOutput`: the commands its
nodes sent (in order), what they record (events, metrics, images) and the
sensors the nodes it ticked declare (:attr:`TickOutput.sensors`), which the
next input delivers. The same messages cross a process boundary
(``marsupial run --isolate``) and are what ``--record-inputs`` logs for replay.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from .commands import Command
from .model import RobotModel
from .priors import BuildingPlan
from .readings import LinkMessage, RobotReadings


@dataclass(frozen=True)
class OperatorCommand:
    """One operator command as consumed: its name, reason, sim time (s) and source (script, stdin or api)."""

    say: str
    why: str
    at: float
    source: str


@dataclass(frozen=True)
class LogRecord:
    """Something a node records: an ``event`` (kind and fields), a ``metric`` (name, value, labels) or an ``image``.

    Attributes:
        kind: ``"event"``, ``"metric"``, ``"image"`` or ``"text"``.
        name: the event kind, metric name, camera name or text level.
        value: the metric's value, the image (RGB array) or the text.
        fields: the event's fields, the metric's labels or the image's options.
    """

    kind: str
    name: str
    value: Any = None
    fields: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class TreeStatus:
    """The statuses of the tree's nodes after a tick, in uid order (``IDLE``/``RUNNING``/``SUCCESS``/``FAILURE``).

    ``xml`` (BehaviorTree.CPP XML with uids) and ``names`` come with the first
    status and whenever the tree's structure changed; ``None`` otherwise.
    """

    statuses: tuple[str, ...]
    names: tuple[str, ...] | None = None
    xml: str | None = None


@dataclass(frozen=True)
class TickInput:
    """What the tree receives before tick ``tick`` at simulated time ``t`` (s)."""

    tick: int
    t: float
    robots: dict[str, RobotReadings]
    link: tuple[LinkMessage, ...] = ()
    operator: tuple[OperatorCommand, ...] = ()


@dataclass(frozen=True)
class TickOutput:
    """What the tree answers: its commands in order, its records, its status, and the sensors to deliver next.

    Attributes:
        commands: the commands its nodes sent, in the order sent (the arbiter already dropped the overridden).
        senders: the name of the node that sent each command.
        records: events, metrics and images the nodes recorded.
        status: the root's status after the tick (``RUNNING``, ``SUCCESS``, ``FAILURE``; ``IDLE`` when not ticked).
        tree: the nodes' statuses (``None``: unchanged since the last output).
        sensors: ``(robot, sensor)`` pairs the nodes it ticked declare, delivered with the next input.
        active: the names of the running skills by robot (``""``: skills without a robot), for progress displays.
    """

    commands: tuple[Command, ...] = ()
    senders: tuple[str, ...] = ()
    records: tuple[LogRecord, ...] = ()
    status: str = "IDLE"
    tree: TreeStatus | None = None
    sensors: frozenset[tuple[str, str]] = frozenset()
    active: dict[str, tuple[str, ...]] = field(default_factory=dict)


@dataclass(frozen=True)
class TreeSetup:
    """What the tree side needs to build a run's tree: the mission, the seed, the team's models and the priors.

    Attributes:
        mission: the mission's YAML text.
        mission_path: where it was loaded from (``None``: given as text), for its subtrees and error messages.
        overrides: the ``--set`` overrides applied to it.
        subtrees: the texts of the subtrees it uses, by name (so a log replays without the files).
        seed: the run's seed (the nodes' random streams derive from it).
        tick_hz: the tree's tick rate (Hz).
        team: each member's :class:`RobotModel` and the name of its view class (:data:`~marsupial.api.views.VIEWS`).
        priors: the scene knowledge the mission declares, by name.
    """

    mission: str
    mission_path: str | None
    overrides: dict[str, str]
    subtrees: dict[str, str]
    seed: int
    tick_hz: float
    team: dict[str, tuple[RobotModel, str]]
    priors: dict[str, BuildingPlan] = field(default_factory=dict)
