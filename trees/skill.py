"""Base classes of mission nodes: skills (act) and conditions (test).

A mission node is a py_trees behaviour with three declared parts, checked
when the mission is compiled:

* ``Params`` — a pydantic model of typed, documented parameters (attribute
  docstrings are the docs; defaults are the papers' values);
* ``reads`` / ``writes`` — the blackboard keys it uses, formatted with the
  node's ``robot`` and its parameters (``"{robot}/coverage"``, ``"{key}"``);
* ``robot_kinds`` — the capabilities its robot must have (protocols of
  :mod:`marsupial.api.capabilities`, e.g. ``(Rotorcraft,)``; ``None``: any
  robot; set ``uses_robot = False`` for nodes that take no robot, like
  ``wait``) and ``sensors``, the sensors it reads on it;
* ``claims`` — the robot resources a skill commands (``"rotors"`` on its own
  robot, ``"{carrier}/arm"`` on the member a parameter names); the compiler
  refuses two parallel branches claiming one resource, and a command to a
  resource not claimed is an error.

A node is generic in its parameter class: ``class Goto(Skill[GotoParams])``
or, for a nested class, ``class Goto(Skill["Goto.Params"])``; ``Params``
is then that class and ``self.params`` is typed as it.

A :class:`Skill`'s life cycle maps onto py_trees': :meth:`Skill.start`
(``initialise``), :meth:`Skill.step` (``update``, returns a status and sets
``self.feedback_message``) and :meth:`Skill.finish` (``terminate``, on
SUCCESS, FAILURE or INVALID = preempted or stopped by its parent). The
default ``finish`` leaves the robot safe through the arbiter
(the safe stop of each resource it claims on its robot, unless the
preempting node already commands that resource in this tick). Every command
``finish`` sends yields so: the arbiter drops it when another node drove
the resource in the same tick. ``finish`` is named so because py_trees' own
``stop()`` does the tree's bookkeeping and must not be overridden. Every
start is recorded as a ``state_change`` event (status RUNNING) and every end
as an ``outcome`` event (SUCCESS, FAILURE or INVALID, with the last
feedback message). A :class:`Condition`
implements :meth:`Condition.check` and never returns RUNNING.
"""

from __future__ import annotations

import typing
import zlib
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any, ClassVar, ForwardRef, Generic, cast, overload

import numpy as np
import py_trees
from py_trees.common import Access, Status
from pydantic import BaseModel, ConfigDict, model_validator
from typing_extensions import TypeVar

from marsupial.api.errors import UnknownNameError
from marsupial.api.keys import Key
from marsupial.api.priors import PRIORS, BuildingPlan
from marsupial.api.ticks import LogRecord
from marsupial.api.views import LinkState, LinkView, RobotState, RobotView

from .arbitration import ANY_RESOURCE, Arbiter, Claimant, NodeSink, Stamp
from .metrics import MetricSpec
from .operator import OperatorLatch

_STATUSES = frozenset(Status)


def _tuple_field(annotation: Any) -> bool:
    """Whether a field's annotation is a tuple (or an optional tuple)."""
    if typing.get_origin(annotation) is tuple:
        return True
    return any(typing.get_origin(arg) is tuple for arg in typing.get_args(annotation))


class NodeParams(BaseModel):
    """Base of every node's ``Params``: unknown keys are errors, attribute docstrings are the docs.

    Values are checked strictly: a boolean or a string is not a number
    (``seconds: true`` and ``seconds: '2'`` are errors, not 1.0 and 2.0), and
    numbers are finite (NaN and infinities are refused). YAML lists are
    accepted for tuple parameters.
    """

    model_config = ConfigDict(
        extra="forbid", use_attribute_docstrings=True, frozen=True, strict=True, allow_inf_nan=False
    )

    @model_validator(mode="before")
    @classmethod
    def _lists_for_tuples(cls, data: Any) -> Any:
        if not isinstance(data, dict):
            return data
        fields = cls.model_fields
        return {
            key: tuple(value)
            if isinstance(value, list) and key in fields and _tuple_field(fields[key].annotation)
            else value
            for key, value in data.items()
        }


@dataclass(frozen=True)
class TeamMember:
    """Marks a string parameter as the name of a team member, optionally one with a capability.

    ``carrier: Annotated[str, TeamMember(Carrier)] = "carrier"``: the
    compiler checks, like ``robot:``, that the value names a member of the
    mission's ``team:`` (with a did-you-mean) whose kind has ``capability``
    (a protocol of :mod:`marsupial.api.capabilities`), and reports the
    parameter's file:line otherwise. An optional member
    (``Annotated[str, TeamMember()] | None``) is checked when given.
    """

    capability: type | None = None


@dataclass
class RunContext:
    """What the nodes of one run share, as data: sim time, the team's readings and models, the link, the operator.

    Nothing here leads to the world (the sensing boundary, ``docs/sensing.md``):
    the runtime fills it from the messages of each tick
    (:class:`~marsupial.api.ticks.TickInput`). Nodes get the simulated time
    (:attr:`now`), seeded random streams (:meth:`rng`), each team member's
    view through their own ports (:meth:`MissionNode.member`), the team link
    (:attr:`link`), the operator's pending commands (:attr:`operator`) and the
    scene knowledge the mission declares (:meth:`prior`). Events, metrics and
    images go to :attr:`records`, which the runtime passes to the recorder
    after the tick; the last value of every metric a node recorded is kept in
    :attr:`metrics`. A context without a team is one a tree is compiled in only
    to be drawn or exported.
    """

    arbiter: Arbiter = field(default_factory=Arbiter)
    operator: OperatorLatch = field(default_factory=OperatorLatch)
    seed: int = 0
    now: float = 0.0
    #: simulated time (s) between two ticks of the tree
    tick_period: float = 0.1
    robots: dict[str, RobotState] = field(default_factory=dict)
    views: dict[str, type[RobotView]] = field(default_factory=dict)
    link: LinkState = field(default_factory=LinkState)
    priors: dict[str, BuildingPlan] = field(default_factory=dict)
    record_images: bool = False
    records: list[LogRecord] = field(default_factory=list)
    metrics: dict[str, float] = field(default_factory=dict)
    #: what the nodes of the run share by name (e.g. one camera observer for every node looking through it)
    shared: dict[str, Any] = field(default_factory=dict)

    def rng(self, key: str) -> np.random.Generator:
        """A seeded random stream for ``key`` (derived from the run's seed; e.g. a planner's samples)."""
        return np.random.default_rng([self.seed, zlib.crc32(f"node/{key}".encode())])

    def team(self) -> tuple[str, ...]:
        """Names of the team members."""
        return tuple(self.robots)

    def state(self, name: str) -> RobotState:
        """The readings and model of team member ``name``; the error lists the team."""
        try:
            return self.robots[name]
        except KeyError:
            raise UnknownNameError("team member", name, self.robots) from None

    def prior(self, name: str) -> BuildingPlan:
        """The scene knowledge named ``name`` that the mission declares (:data:`marsupial.api.priors.PRIORS`).

        ``"building_plan"``: the :class:`~marsupial.api.priors.BuildingPlan` of
        the mission's scene (walls and door frames, zones, guide paths), copied
        from the scene file's declared data, never the bodies.
        """
        if name not in PRIORS:
            raise UnknownNameError("prior", name, PRIORS)
        try:
            return self.priors[name]
        except KeyError:
            raise RuntimeError(f"prior {name!r}: the tree was compiled without a world and cannot run") from None

    def event(self, kind: str, **fields: Any) -> None:
        """Record an event of ``kind`` (``preemption``, ``operator``, …) at the current sim time."""
        self.records.append(LogRecord("event", kind, None, fields))

    def metric(self, name: str, value: float, **labels: Any) -> None:
        """Record metric ``name`` = ``value`` at the current sim time and keep its last value.

        The last value is kept under ``name`` or, with labels, ``name[v1,v2]``
        (label values in the order given), e.g. ``battery_soc[uav]``.
        """
        key = f"{name}[{','.join(str(v) for v in labels.values())}]" if labels else name
        self.metrics[key] = float(value)
        self.records.append(LogRecord("metric", name, float(value), labels))

    def image(self, camera: str, rgb: Any, **options: Any) -> None:
        """Record a camera frame when the run records images (``--record-images``)."""
        if self.record_images:
            self.records.append(LogRecord("image", camera, rgb, options))


P = TypeVar("P", bound=NodeParams)
#: the robot a node acts on, as a capability protocol (``Rotorcraft``); unset: untyped
R = TypeVar("R", default=Any)
V = TypeVar("V")


def _params_argument(cls: type) -> type[NodeParams] | None:
    """The parameter class ``cls`` names as its generic argument (``Skill[GotoParams]``, ``Skill["Goto.Params"]``)."""
    for base in cls.__dict__.get("__orig_bases__", ()):
        for arg in typing.get_args(base):
            if isinstance(arg, typing.TypeVar):
                return cast("type[NodeParams] | None", arg.__bound__)
            if isinstance(arg, (str, ForwardRef)):
                text = arg if isinstance(arg, str) else arg.__forward_arg__
                if text != f"{cls.__name__}.Params" or "Params" not in cls.__dict__:
                    raise TypeError(
                        f"{cls.__name__}: a parameter class given as a string names '{cls.__name__}.Params'"
                    )
                return cast("type[NodeParams]", cls.__dict__["Params"])
            if isinstance(arg, type):
                return arg
    return None


class MissionNode(py_trees.behaviour.Behaviour, Generic[P, R]):
    """Base of skills and conditions: parameters, blackboard ports, the robot it acts on.

    Subclasses are built by the compiler as ``cls(name, params, context, robot)``.
    """

    #: the parameter class (the generic argument; :class:`NodeParams`: no parameters)
    Params: ClassVar[type[NodeParams]] = NodeParams
    params: P

    #: blackboard keys read / written, formatted with ``robot`` and the parameters
    reads: ClassVar[tuple[str | Key[Any], ...]] = ()
    writes: ClassVar[tuple[str | Key[Any], ...]] = ()
    #: capabilities its robot must have (``None``: any robot); ignored when ``uses_robot`` is False
    robot_kinds: ClassVar[tuple[type, ...] | None] = None
    #: sensors it reads: ``"<sensor>"`` of its robot or ``"{param}/<sensor>"`` of a member (short names, formatted
    #: with the parameters); only these are delivered to it, each tick it is ticked
    sensors: ClassVar[tuple[str, ...]] = ()
    #: resources it commands: ``"<resource>"`` of its robot or ``"{param}/<resource>"`` of a member (``None``: every
    #: resource of its robot)
    claims: ClassVar[tuple[str, ...] | None] = ()
    #: the parameter naming the team member whose onboard computer runs the node (``None``: no radio between its
    #: decisions and its robots); its commands to every other robot cross the team link (docs/sensing.md)
    runs_on: ClassVar[str | None] = None
    #: whether the node acts on / observes one team robot
    uses_robot: ClassVar[bool] = True
    #: a condition's parameter set by the compact guard form (``Condition.primary``); ``None`` for skills
    primary: ClassVar[str | None] = None
    #: the metrics it records (:mod:`marsupial.trees.metrics`), registered when the registry resolves it
    metrics: ClassVar[tuple[MetricSpec, ...]] = ()

    @property
    def operator_commands(self) -> tuple[str, ...]:
        """Operator commands this node consumes (the compiler accepts them in a mission's operator script)."""
        return ()

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        argument = _params_argument(cls)
        if argument is not None:
            cls.Params = argument
        if not (isinstance(cls.Params, type) and issubclass(cls.Params, NodeParams)):
            raise TypeError(f"{cls.__name__}: its parameter class must derive from NodeParams, not {cls.Params!r}")
        if cls.runs_on is not None and cls.runs_on not in cls.Params.model_fields:
            raise TypeError(f"{cls.__name__}: runs_on names '{cls.runs_on}', which is not one of its parameters")
        for kind in cls.robot_kinds or ():
            if not isinstance(kind, type):
                raise TypeError(
                    f"{cls.__name__}: robot_kinds lists capabilities (protocols of marsupial.api.capabilities, "
                    f"e.g. Rotorcraft), not {kind!r}"
                )

    def __init__(self, name: str, params: P | None = None, context: RunContext | None = None, robot: str | None = None):
        super().__init__(name)
        self.params = params if params is not None else cast(P, self.Params())
        self.context = context if context is not None else RunContext()
        self.robot_name = robot
        #: registry name of the node (``"goto"``, ``"battery_below"``); set by the compiler
        self.kind: str = type(self).__name__.lower()
        computer = getattr(self.params, self.runs_on) if self.runs_on is not None else None
        self._claimant = Claimant(self.id, name, frozenset(self.claimed(self.params, robot)), computer=computer)
        #: the ``(robot, sensor)`` pairs it reads (delivered while it is ticked), and the last tick it was ticked in
        self.reads_sensors = frozenset(self.sensors_read(self.params, robot))
        self.ticked = 0
        self._sink = NodeSink(self.context.arbiter, self._claimant, self.reads_sensors)
        self._views: dict[str, RobotView] = {}
        self.blackboard = self.attach_blackboard_client(name=name)
        for key in self.read_keys(self.params, robot):
            self.blackboard.register_key(key, access=Access.READ)
        for key in self.write_keys(self.params, robot):
            self.blackboard.register_key(key, access=Access.WRITE)

    # --------------------------------------------------------- declarations
    @classmethod
    def _format_keys(cls, keys: tuple[str | Key[Any], ...], params: P, robot: str | None) -> tuple[str, ...]:
        values = {**params.model_dump(), "robot": robot}
        return tuple(str(key).format(**values) for key in keys)

    @classmethod
    def read_keys(cls, params: P, robot: str | None) -> tuple[str, ...]:
        """Blackboard keys this node reads, for these parameters and robot."""
        return cls._format_keys(cls.reads, params, robot)

    @classmethod
    def write_keys(cls, params: P, robot: str | None) -> tuple[str, ...]:
        """Blackboard keys this node writes, for these parameters and robot."""
        return cls._format_keys(cls.writes, params, robot)

    @classmethod
    def _member_pairs(cls, entries: tuple[str, ...], params: P, robot: str | None) -> tuple[tuple[str, str], ...]:
        """``(member, item)`` pairs of ``"<item>"`` (this node's robot) / ``"{param}/<item>"`` entries.

        An entry on a member named by a parameter left unset (``None``) names nothing.
        """
        values = {**params.model_dump(), "robot": robot}
        pairs = []
        for entry in entries:
            member, _, item = entry.rpartition("/")
            name = member.format(**values) if member else robot
            if name not in (None, "None"):
                pairs.append((str(name), item.format(**values)))
        return tuple(pairs)

    def wanted_sensors(self) -> frozenset[tuple[str, str]]:
        """The declared sensors to deliver with the next tick (default: all of them, every tick it is ticked).

        A node that reads a sensor only now and then (a camera every half second) returns the pairs it will
        read at the next tick (``self.now + self.context.tick_period``) and nothing between: a camera nobody
        reads is not rendered.
        """
        return self.reads_sensors

    @classmethod
    def claimed(cls, params: P, robot: str | None) -> tuple[tuple[str, str], ...]:
        """``(robot, resource)`` pairs this node commands, for these parameters and robot (resource ``*``: any).

        A claim on a member named by a parameter left unset (``None``) claims nothing.
        """
        if cls.claims is None:
            return ((robot, ANY_RESOURCE),) if robot is not None else ()
        return cls._member_pairs(cls.claims, params, robot)

    @classmethod
    def sensors_read(cls, params: P, robot: str | None) -> tuple[tuple[str, str], ...]:
        """``(robot, sensor)`` pairs this node reads, for these parameters and robot: the runtime delivers these."""
        return cls._member_pairs(cls.sensors, params, robot)

    @classmethod
    def summary(cls) -> str:
        """First line of the class docstring (used by ``marsupial skills``)."""
        return (cls.__doc__ or "").strip().splitlines()[0] if cls.__doc__ else ""

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        """py_trees' ``Behaviour.tick`` without its per-tick debug logging and status-list building.

        Same semantics (initialise when not RUNNING, update, stop on a final
        status); leaves are most of a tree, so this keeps large trees fast.
        """
        self.ticked = self.context.arbiter.tick
        if self.status != Status.RUNNING:
            self.initialise()
        new_status = self.update()
        if new_status not in _STATUSES:  # a plug-in bug: end the run with an error naming the node, once
            raise TypeError(
                f"{type(self).__name__} '{self.name}' returned {new_status!r} from its tick; "
                "expected a py_trees Status (RUNNING, SUCCESS or FAILURE)"
            )
        if new_status != Status.RUNNING:
            self.stop(new_status)
        self.status = new_status
        yield self

    # -------------------------------------------------------------- access
    @property
    def now(self) -> float:
        """Simulated time (s) of the run."""
        return self.context.now

    @property
    def robot(self) -> R:
        """The view of the robot this node acts on (:mod:`marsupial.api.views`): its readings, model and commands."""
        if self.robot_name is None:
            raise RuntimeError(f"node '{self.name}' has no robot")
        return cast(R, self.member(self.robot_name))  # a view of the class the robot's kind names: it provides R

    def member(self, name: str) -> Any:
        """Team member ``name``'s view as this node sees it: this tick's readings, commands to claimed resources."""
        view = self._views.get(name)
        if view is None:
            context = self.context
            state = context.state(name)
            view = self._views[name] = context.views[name](state, self._sink)
        return view

    @property
    def link(self) -> LinkView:
        """The team link as this node's robot uses it (telemetry of the others: ``link.latest(name)``)."""
        if self.robot_name is None:
            raise RuntimeError(f"node '{self.name}' has no robot and no team link")
        return self.link_of(self.robot_name)

    def link_of(self, name: str) -> LinkView:
        """The team link as team member ``name`` uses it (this node sends as it)."""
        self.context.state(name)  # a clear error for an unknown member
        return LinkView(name, self.context.link, self._sink)

    @overload
    def read(self, key: Key[V], default: V | None = None) -> V | None: ...

    @overload
    def read(self, key: str, default: Any = None) -> Any: ...

    def read(self, key: str | Key[Any], default: Any = None) -> Any:
        """Blackboard value of a declared read key, ``default`` while nothing wrote it (typed for a :class:`Key`)."""
        try:
            return self.blackboard.get(str(key))
        except KeyError:
            return default

    @overload
    def write(self, key: Key[V], value: V) -> None: ...

    @overload
    def write(self, key: str, value: Any) -> None: ...

    def write(self, key: str | Key[Any], value: Any) -> None:
        """Set a declared write key on the blackboard; a :class:`Key` refuses a value of another type."""
        if isinstance(key, Key):
            key.check(value)
        self.blackboard.set(str(key), value, overwrite=True)


class Skill(MissionNode[P, R]):
    """Base of skills: override :meth:`start`, :meth:`step` and, if needed, :meth:`finish`.

    ``self.robot`` sends arbitrated commands; :attr:`stopped_by` tells, after
    :meth:`finish`, whether its commands and safe-stops were applied
    (``None``) or which node's command in the same tick kept a resource.
    A skill that declares no ``claims`` claims every resource of its robot.
    """

    claims: ClassVar[tuple[str, ...] | None] = None

    def __init__(self, *args: Any, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self._active = False

    @property
    def stopped_by(self) -> Stamp | None:
        """The stamp of another node's command that kept one of its resources when it finished, else ``None``."""
        return self._claimant.kept

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "stop" in cls.__dict__:
            raise TypeError(
                f"{cls.__name__} overrides stop(): override finish(status) instead "
                "(py_trees' stop() does the tree's bookkeeping)"
            )

    # ---------------------------------------------------------- life cycle
    def start(self) -> None:
        """Acquire the robot and reset state (called when the skill starts running)."""

    def step(self) -> Status:
        """One tick: read state, send one command, return RUNNING/SUCCESS/FAILURE."""
        raise NotImplementedError(f"{type(self).__name__} must implement step()")

    def finish(self, status: Status) -> None:
        """Called once when the skill ends with ``status`` (INVALID: preempted); leaves the robot safe."""
        self.leave_safe()

    def leave_safe(self) -> None:
        """Arbitrated safe stop of the resources the skill claims on its robot (a no-op for skills without a robot)."""
        if self.uses_robot and self.robot_name is not None:
            self.member(self.robot_name).safe_stop()

    # ------------------------------------------------------ py_trees hooks
    def initialise(self) -> None:
        self._active = True
        self._claimant.kept = None
        self.feedback_message = ""
        self.context.event("state_change", node=self.name, skill=self.kind, robot=self.robot_name, status="RUNNING")
        self.start()

    def update(self) -> Status:
        return self.step()

    def terminate(self, new_status: Status) -> None:
        if self._active:  # py_trees may stop a finished node again with INVALID: finish once
            self._active = False
            self._claimant.finishing = True  # its commands now yield to a node that took the resource this tick
            try:
                self.finish(new_status)
            finally:
                self._claimant.finishing = False
            self.context.event(
                "outcome",
                node=self.name,
                skill=self.kind,
                robot=self.robot_name,
                status=new_status.name,
                message=self.feedback_message,
            )


class Condition(MissionNode[P, R]):
    """Base of conditions: implement :meth:`check`; the node is SUCCESS when it holds, else FAILURE.

    ``primary`` names the parameter given as the value of the compact guard
    form (``{battery_below: 0.2, robot: uav}`` sets ``threshold``).
    """

    btcpp_kind: ClassVar[str] = "Condition"  # BehaviorTree.CPP export (trees/btxml.py)

    def check(self) -> bool:
        """Whether the condition holds now."""
        raise NotImplementedError(f"{type(self).__name__} must implement check()")

    def describe(self) -> str:
        """Human-readable text of this guard (used as the reason of a preemption)."""
        args = []
        if self.primary is not None:
            args.append(str(getattr(self.params, self.primary)))
        if self.robot_name is not None:
            args.append(f"robot={self.robot_name}")
        return f"{self.kind}({', '.join(args)})"

    def update(self) -> Status:
        holds = self.check()
        self.feedback_message = "holds" if holds else "does not hold"
        return Status.SUCCESS if holds else Status.FAILURE
