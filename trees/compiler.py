"""Compile a mission (subtrees inlined) into a py_trees tree, checking it as a whole first.

Node mapping (py_trees 2.x):

=============  ==================================================================
mission node   py_trees
=============  ==================================================================
sequence       ``composites.Sequence(memory=memory)``
selector       ``composites.Selector(memory=memory)``
parallel       ``composites.Parallel(ParallelPolicy.SuccessOnAll() / SuccessOnOne())``
priorities     :class:`~.composites.Priorities` (memoryless ``Selector``) of
               :class:`~.composites.GuardedBranch` = ``Sequence(guards..., do)``
repeat         ``decorators.Repeat(num_success=times)`` (-1: forever)
retry          ``decorators.Retry(num_failures=times)``
timeout        :class:`~.composites.SimTimeout` (simulated seconds)
invert         ``decorators.Inverter``
until          ``Selector(memory=False)[guard, SuccessIsRunning(child)]``: the
               child is restarted whenever it succeeds, until the guard holds
               (SUCCESS); a failing child fails the node
wait_until,    :mod:`~.waiting` (:func:`~.waiting.build_waiting`): ``WaitUntil``,
run_for, idle  ``RunFor``, ``Idle``
skill          the registered :class:`~.skill.Skill` class
condition      the registered :class:`~.skill.Condition` class
=============  ==================================================================

Checked here, each error at the node's file:line (:meth:`Mission.error_at`):
unknown skill/condition names (with the closest name), ambiguous providers,
parameter types and values (each skill's pydantic ``Params``), the robot a
node needs and its capabilities and sensors, team members named by
parameters (:class:`~.skill.TeamMember`) and their capabilities, two parallel
branches claiming one resource of one robot, blackboard keys read but
written by no node, and scripted operator commands nobody listens to.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import ParallelPolicy
from pydantic import TypeAdapter, ValidationError

from marsupial.api.errors import UnknownNameError

from .composites import GuardedBranch, Priorities, SimTimeout
from .conditions import OperatorSaid
from .errors import MissionError, one_of, suggest
from .mission import Guard, Mission, NodeBase
from .operator import CONTROL_COMMANDS
from .registry import Registry
from .resources import ResourceChecks, kind_capabilities, members_with, team_member_of
from .skill import Condition, MissionNode, RunContext, Skill
from .waiting import WAITING_KINDS, build_waiting


@dataclass
class CompiledTree:
    """A compiled mission: the py_trees root and its skill/condition leaves.

    ``listens`` holds the operator commands some ``operator`` condition waits for.
    """

    root: Behaviour
    nodes: list[MissionNode[Any]] = field(default_factory=list)
    listens: set[str] = field(default_factory=set)

    @property
    def skills(self) -> list[Skill[Any]]:
        """Skill leaves, in tree order."""
        return [n for n in self.nodes if isinstance(n, Skill)]


def robot_kind_matches(kind: str, accepted: tuple[type, ...] | None) -> bool:
    """Whether robots of ``kind`` have every capability in ``accepted`` (``None``: any robot)."""
    return accepted is None or set(accepted) <= kind_capabilities(kind)


class _Compiler:
    """One compilation: builds nodes depth first, then runs the whole-tree checks."""

    def __init__(self, mission: Mission, context: RunContext, registry: Registry):
        self.mission = mission
        self.spec = mission.spec
        self.context = context
        self.registry = registry
        self.leaves: list[tuple[MissionNode[Any], Any]] = []  # (node, where it was written)
        self.names: dict[str, int] = {}
        self.resources = ResourceChecks(mission)

    # ---------------------------------------------------------------- names
    def unique(self, name: str) -> str:
        """``name``, or ``name #2``, ``#3`` … when it is already used in this tree."""
        seen = self.names.get(name, 0) + 1
        self.names[name] = seen
        return name if seen == 1 else f"{name} #{seen}"

    # ---------------------------------------------------------------- build
    def build(self, node: Any) -> Behaviour:  # a node model of the mission (its fields by kind)
        """The py_trees behaviour of a mission node, its children built and its names made unique."""
        kind = node.kind
        if kind in ("skill", "condition"):
            return self.leaf(kind, getattr(node, kind), node.robot, node.params, node, node.name)
        if kind == "subtree":
            raise self.mission.error_at(node, f"subtree '{node.subtree}' was not expanded")
        if kind in WAITING_KINDS:
            return build_waiting(self, node)
        name = self.unique(node.name or kind)
        if kind in ("sequence", "selector", "parallel", "priorities"):
            return self.composite(kind, name, node)
        return self.decorator(kind, name, node)

    def composite(self, kind: str, name: str, node: Any) -> Behaviour:
        """A ``sequence``, ``selector``, ``parallel`` or ``priorities`` node named ``name``, its children built."""
        if kind == "sequence":
            return py_trees.composites.Sequence(
                name, memory=node.memory, children=[self.build(c) for c in node.sequence]
            )
        if kind == "selector":
            return py_trees.composites.Selector(
                name, memory=node.memory, children=[self.build(c) for c in node.selector]
            )
        if kind == "parallel":
            policy = ParallelPolicy.SuccessOnAll() if node.success_on == "all" else ParallelPolicy.SuccessOnOne()
            return py_trees.composites.Parallel(name, policy=policy, children=self.parallel_branches(node.parallel))
        return Priorities(name, [self.entry(e) for e in node.priorities], self.context)

    def decorator(self, kind: str, name: str, node: Any) -> Behaviour:
        """A ``repeat``, ``retry``, ``timeout``, ``invert`` or ``until`` node named ``name``, its child built."""
        if kind == "repeat":
            return py_trees.decorators.Repeat(name, self.build(node.repeat), num_success=node.times)
        if kind == "retry":
            return py_trees.decorators.Retry(name, self.build(node.retry), num_failures=node.times)
        if kind == "timeout":
            return SimTimeout(name, self.build(node.timeout), node.seconds, lambda: self.context.now)
        if kind == "invert":
            return py_trees.decorators.Inverter(name, self.build(node.invert))
        if kind == "until":
            guard = self.guard(node.condition)
            child = self.build(node.until)
            again = py_trees.decorators.SuccessIsRunning(self.unique(f"{child.name} (again)"), child)
            return py_trees.composites.Selector(name, memory=False, children=[guard, again])
        raise self.mission.error_at(node, f"unknown node type '{kind}'")  # the model admits no other

    def parallel_branches(self, branches: Iterable[NodeBase]) -> list[Behaviour]:
        """The branches of a ``parallel``, checked not to claim one resource of one robot twice."""
        built, leaves = [], []
        for branch in branches:
            first = len(self.leaves)
            built.append(self.build(branch))
            leaves.append(self.leaves[first:])
        self.resources.check_parallel(leaves, self.spec.team)
        return built

    def entry(self, entry: Any) -> Behaviour:
        do = self.build(entry.do)
        if not entry.when:
            return do
        guards = [self.guard(g) for g in entry.when]
        branch = GuardedBranch("", guards, do, self.context)
        branch.name = self.unique(f"when {branch.describe()}")
        return branch

    def guard(self, guard: Guard) -> Condition[Any]:
        cls = self.resolve("condition", guard.condition, guard.key_path + (guard.condition,))
        params = dict(guard.params)
        if cls.primary is None:
            if guard.argument not in (None, True):
                raise self.mission.error_at(
                    guard.key_path + (guard.condition,),
                    f"condition '{guard.condition}' takes no argument",
                    expected=f"{{{guard.condition}: true}} or parameters under 'params'",
                )
        else:
            if cls.primary in params:
                raise self.mission.error_at(
                    guard.key_path + ("params", cls.primary),
                    f"'{cls.primary}' is given twice (as the value of '{guard.condition}' and in params)",
                )
            params[cls.primary] = guard.argument
        return self.leaf("condition", guard.condition, guard.robot, params, guard, None, cls)  # type: ignore[return-value]

    def resolve(self, kind: str, name: str, where: Any) -> type[MissionNode[Any]]:
        try:
            return self.registry.resolve(kind, name)
        except MissionError as err:
            if name in self.spec.plugins:
                where = ("plugins", name)
            raise self.mission.error_at(where, err.message, err.expected, err.suggestion) from None

    def leaf(
        self,
        kind: str,
        type_name: str,
        robot: str | None,
        raw_params: dict[str, Any],
        where: Any,
        name: str | None,
        cls: type[MissionNode[Any]] | None = None,
    ) -> MissionNode[Any]:
        at = where.key_path
        if cls is None:
            cls = self.resolve(kind, type_name, at + (kind,))
        robot = self.robot_for(cls, kind, type_name, robot, at)
        try:
            params = cls.Params.model_validate(raw_params)
        except ValidationError as exc:
            if isinstance(where, Guard):
                raise self.guard_params_error(exc, where, cls) from None
            raise self.mission.validation_error(exc, at + ("params",), cls.Params) from None
        self.check_members(cls, params, raw_params, robot, where)
        default = f"{type_name}@{robot}" if robot else type_name
        node = cls(self.unique(name or default), params, self.context, robot)
        node.kind = type_name
        self.leaves.append((node, at))
        return node

    def guard_params_error(self, exc: ValidationError, guard: Guard, cls: type[MissionNode[Any]]) -> MissionError:
        """Errors of a guard's parameters point at the condition key for the primary one."""
        first = exc.errors()[0]
        field_name = first["loc"][0] if first["loc"] else None
        if isinstance(field_name, str) and field_name == cls.primary:
            info = cls.Params.model_fields[field_name]
            try:  # validate the value alone, so the error points at the condition key
                TypeAdapter(info.rebuild_annotation()).validate_python(guard.argument)
            except ValidationError as alone:
                return self.mission.validation_error(alone, guard.key_path + (guard.condition,), info.annotation)
        return self.mission.validation_error(exc, guard.key_path + ("params",), cls.Params)

    def check_members(
        self, cls: type[MissionNode[Any]], params: Any, raw_params: dict[str, Any], robot: str | None, where: Any
    ) -> None:
        """Parameters naming team members (:class:`~.skill.TeamMember`) name one, with the capability they require."""
        team = self.spec.team
        for field_name, info in type(params).model_fields.items():
            member = team_member_of(info.annotation, info.metadata)
            value = getattr(params, field_name)
            if member is None or value is None:
                continue
            if isinstance(where, Guard) and field_name == cls.primary:
                at = where.key_path + (where.condition,)
            elif field_name in raw_params:
                at = where.key_path + ("params", field_name)
            else:
                at = where.key_path
            given = "" if field_name in raw_params else " (its default)"
            if value not in team:
                raise self.mission.error_at(
                    at,
                    f"parameter '{field_name}' names '{value}'{given}, which is not a team member",
                    expected=f"a team member ({one_of(team)})",
                    suggestion=suggest(value, team),
                )
            if member.capability is not None and not robot_kind_matches(team[value].robot, (member.capability,)):
                able = members_with(team, (member.capability,))
                raise self.mission.error_at(
                    at,
                    f"parameter '{field_name}' names '{value}' (a {team[value].robot}), which lacks capability "
                    f"{member.capability.__name__}",
                    expected=f"a team member with capability {member.capability.__name__} "
                    f"({one_of(able) if able else 'none in this team'})",
                )

    def robot_for(
        self, cls: type[MissionNode[Any]], kind: str, type_name: str, robot: str | None, at: Any
    ) -> str | None:
        team = self.spec.team
        if not cls.uses_robot:
            if robot is not None:
                raise self.mission.error_at(at + ("robot",), f"{kind} '{type_name}' takes no robot")
            return None
        if robot is None:
            candidates = [n for n, m in team.items() if robot_kind_matches(m.robot, cls.robot_kinds)]
            if len(team) == 1 and candidates:
                return candidates[0]
            raise self.mission.error_at(
                at,
                f"{kind} '{type_name}' needs a robot",
                expected=f"'robot:' naming a team member ({one_of(candidates or team)})",
            )
        if robot not in team:
            raise self.mission.error_at(
                at + ("robot",),
                f"unknown robot '{robot}'",
                expected=f"a team member ({one_of(team)})",
                suggestion=suggest(robot, team),
            )
        robot_kind = team[robot].robot
        try:
            matches = robot_kind_matches(robot_kind, cls.robot_kinds)
        except UnknownNameError as err:
            raise self.mission.error_at(
                ("team", robot, "robot"),
                f"unknown robot kind '{robot_kind}'",
                expected=one_of(err.known),
                suggestion=suggest(robot_kind, err.known),
            ) from None
        if not matches:
            needs = " and ".join(c.__name__ for c in cls.robot_kinds or ())
            able = members_with(team, cls.robot_kinds)
            raise self.mission.error_at(
                at + ("robot",),
                f"{kind} '{type_name}' cannot run on '{robot}' (a {robot_kind})",
                expected=f"a robot with capability {needs} ({one_of(able) if able else 'none in this team'})",
            )
        own = [s for s in cls.sensors if "/" not in s and "{" not in s]  # fixed names on its own robot
        missing = self.resources.missing_sensors(robot_kind, own)
        if missing:
            raise self.mission.error_at(
                at + ("robot",),
                f"{kind} '{type_name}' reads sensor '{missing[0]}', which '{robot}' (a {robot_kind}) does not have",
                expected="a robot with the sensors " + ", ".join(own),
            )
        return robot

    # --------------------------------------------------------------- checks
    def check_blackboard(self, initial: Iterable[str]) -> None:
        """Every key read must be written by some node or provided initially."""
        written = {_absolute(k) for node, _ in self.leaves for k in node.write_keys(node.params, node.robot_name)}
        written |= {_absolute(k) for k in initial}
        for node, at in self.leaves:
            for key in node.read_keys(node.params, node.robot_name):
                if _absolute(key) not in written:
                    raise self.mission.error_at(
                        at,
                        f"'{node.name}' reads blackboard key '{key}' that no node writes",
                        expected=f"a key written by a node of this mission ({one_of(sorted(written))})",
                        suggestion=suggest(_absolute(key), written),
                    )

    def listened_commands(self) -> set[str]:
        said = {n.params.command for n, _ in self.leaves if isinstance(n, OperatorSaid)}
        return said | {c for n, _ in self.leaves for c in n.operator_commands}  # skills that ask

    def check_operator_script(self, listens: set[str]) -> None:
        """Scripted operator commands must be control commands or listened to by the tree."""
        known = set(CONTROL_COMMANDS) | listens
        for i, event in enumerate(self.spec.operator):
            if event.say not in known:
                raise self.mission.error_at(
                    ("operator", i, "say"),
                    f"no node listens to operator command '{event.say}'",
                    expected=f"{one_of(known)} (an 'operator' condition of the tree, or abort/pause/resume)",
                    suggestion=suggest(event.say, known),
                )


def _absolute(key: str) -> str:
    return key if key.startswith("/") else "/" + key


def compile_mission(
    mission: Mission,
    context: RunContext | None = None,
    registry: Registry | None = None,
    initial_keys: Iterable[str] = (),
) -> CompiledTree:
    """Build the py_trees tree of ``mission`` (its subtrees already inlined) and check it.

    ``context`` is the run the nodes act in (world, arbiter, operator,
    recorder); without one the tree can be drawn or exported but not run.
    ``initial_keys`` are blackboard keys set before the first tick.
    Raises :class:`MissionError` at the offending node's file:line.
    """
    context = context if context is not None else RunContext()
    compiler = _Compiler(mission, context, registry or Registry(mission.spec.plugins))
    root = compiler.build(mission.spec.tree)
    compiler.check_blackboard(initial_keys)
    listens = compiler.listened_commands()
    compiler.check_operator_script(listens)
    return CompiledTree(root, [n for n, _ in compiler.leaves], listens)
