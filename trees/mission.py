"""Mission files: the pydantic model of a mission, loading by name or path, overrides, JSON Schema.

A mission is a YAML document with the keys ``mission, description, world,
team, operator, plugins, params, run, tree`` (see ``docs/missions.md``).
:func:`load_mission` finds it (by name among the package's missions, or by
path), applies ``--set`` overrides, substitutes ``${param}`` references,
validates it against :class:`MissionSpec`, inlines subtrees and checks that
every ``robot:`` names a team member. Every problem raises one
:class:`~marsupial.trees.errors.MissionError` that names file:line:column,
the key path, what was expected and the closest known name.

Nodes keep the key path they were written at (:attr:`NodeBase.key_path`, a
:class:`KeyPath` that also knows its source file, so nodes inlined from a
subtree point into the subtree file); later stages report problems there with
:meth:`Mission.error_at`.
"""

from __future__ import annotations

import copy
import functools
import types
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from importlib.resources import files
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal, Union, get_args, get_origin

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Discriminator,
    Field,
    PrivateAttr,
    Tag,
    TypeAdapter,
    ValidationError,
    model_validator,
)
from pydantic_core import PydanticCustomError

from .errors import KeyPathLike, MissionError, combine_errors, one_of, suggest
from .yaml_source import SourceDoc, load_yaml, parse_scalar

MAX_REPORTED_ERRORS = 5


class KeyPath(tuple):
    """A key path (keys and list indices) that also remembers the document it points into.

    ``source`` is the :class:`SourceDoc` (the mission, or a subtree file for
    inlined nodes) and ``note`` says through which include it was reached.
    Adding a tuple keeps both: ``node.key_path + ("params", "speed")``.
    """

    source: SourceDoc | None
    note: str | None

    def __new__(cls, items: KeyPathLike = (), source: SourceDoc | None = None, note: str | None = None):
        self = super().__new__(cls, tuple(items))
        self.source = source
        self.note = note
        return self

    def __add__(self, other: KeyPathLike) -> KeyPath:
        return KeyPath(tuple(self) + tuple(other), self.source, self.note)


# --------------------------------------------------------------------------- nodes

NODE_KINDS = (
    "sequence", "selector", "parallel", "priorities", "repeat", "retry",
    "timeout", "invert", "until", "skill", "condition", "subtree",
)  # the structural keys: a node mapping has exactly one of them


def node_kind(value: Any) -> str | None:
    """The node type of a node mapping (its single structural key), or ``None`` if it has none or several.

    ``until`` nodes also carry a ``condition:`` guard, which is then not a structural key.
    """
    if isinstance(value, NodeBase):
        return value.kind
    if not isinstance(value, Mapping):
        return None
    kinds = [k for k in NODE_KINDS if k in value]
    if "until" in kinds and "condition" in kinds:
        kinds.remove("condition")  # the until node's guard
    return kinds[0] if len(kinds) == 1 else None


class NodeBase(BaseModel):
    """Common part of every tree node: an optional display ``name`` and the key path it was written at."""

    model_config = ConfigDict(extra="forbid")
    kind: ClassVar[str]

    name: str | None = Field(None, description="Display name of the node (in logs, tree drawings).")
    _key_path: KeyPath = PrivateAttr(default_factory=KeyPath)

    @property
    def key_path(self) -> KeyPath:
        """Where this node was written (key path + source document), for :meth:`Mission.error_at`."""
        return self._key_path

    @property
    def label(self) -> str:
        """``name`` if given, else the node type and, for leaves, what they run (``"skill wait"``)."""
        if self.name:
            return self.name
        target = getattr(self, self.kind)
        return f"{self.kind} {target}" if isinstance(target, str) else self.kind

    def map_children(self, fn: Callable[[Node, tuple], Node]) -> None:
        """Replace each child ``c`` (at relative key path ``rel``) with ``fn(c, rel)``; leaves have none."""

    @property
    def children(self) -> list[Node]:
        """The child nodes, in order."""
        found: list[Node] = []
        self.map_children(lambda child, _: found.append(child) or child)
        return found

    def guards(self) -> list[Guard]:
        """The guards of this node (``priorities`` and ``until`` have some)."""
        return []

    def walk(self) -> Iterator[Node]:
        """This node and all its descendants, depth first."""
        yield self
        for child in self.children:
            yield from child.walk()

    def set_key_path(self, key_path: KeyPath) -> None:
        """Record ``key_path`` on this node and, below it, on its children and guards."""
        self._key_path = key_path
        self.map_children(lambda child, rel: child.set_key_path(key_path + rel) or child)


class _Composite(NodeBase):
    """A node whose structural key holds a list of child nodes."""

    def map_children(self, fn: Callable[[Node, tuple], Node]) -> None:
        children = getattr(self, self.kind)
        setattr(self, self.kind, [fn(child, (self.kind, i)) for i, child in enumerate(children)])


class _Decorator(NodeBase):
    """A node whose structural key holds its one child node."""

    def map_children(self, fn: Callable[[Node, tuple], Node]) -> None:
        setattr(self, self.kind, fn(getattr(self, self.kind), (self.kind,)))


class SequenceNode(_Composite):
    """`sequence: [nodes]` — tick the children in order; fails at the first failure, succeeds when all succeed."""

    kind: ClassVar[str] = "sequence"
    sequence: list[Node] = Field(min_length=1, description="Children, ticked in order.")
    memory: bool = Field(True, description="Resume at the running child (true) or restart from the first each tick.")


class SelectorNode(_Composite):
    """`selector: [nodes]` — fallback: tick the children in order until one does not fail."""

    kind: ClassVar[str] = "selector"
    selector: list[Node] = Field(min_length=1, description="Children, tried in order.")
    memory: bool = Field(False, description="Resume at the running child (true) or re-check from the first each tick.")


class ParallelNode(_Composite):
    """`parallel: [nodes]` — tick all children every tick; succeed when all (or one) succeed."""

    kind: ClassVar[str] = "parallel"
    parallel: list[Node] = Field(min_length=1, description="Children, all ticked every tick.")
    success_on: Literal["all", "one"] = Field("all", description="Succeed when all children or any one succeeds.")


def _as_guard_list(value: Any) -> Any:
    return [value] if isinstance(value, Mapping) else value


class Guard(BaseModel):
    """Compact condition: exactly one condition key (its value is the condition's primary argument),
    plus optional `robot` and `params`, e.g. `{battery_below: 0.2, robot: uav}` or `{operator: dock}`."""

    model_config = ConfigDict(extra="allow", json_schema_extra={"minProperties": 1})

    robot: str | None = Field(None, description="Team member the condition looks at.")
    params: dict[str, Any] = Field(default_factory=dict, description="Further condition parameters.")
    _key_path: KeyPath = PrivateAttr(default_factory=KeyPath)

    @model_validator(mode="after")
    def _one_condition(self) -> Guard:
        keys = list(self.model_extra or {})
        if len(keys) != 1:
            near = next(filter(None, (suggest(k, ("robot", "params")) for k in keys)), None)
            found = ", ".join(f"'{k}'" for k in keys) or "none"
            raise PydanticCustomError(
                "guard_shape",
                f"a guard needs exactly one condition key, found {found}",
                {"expected": "a mapping such as {battery_below: 0.2, robot: uav}", "suggestion": near},
            )
        return self

    @property
    def condition(self) -> str:
        """Name of the condition (the guard's one non-``robot``/``params`` key)."""
        return str(next(iter(self.model_extra)))

    @property
    def argument(self) -> Any:
        """The condition's primary argument (the value of the condition key)."""
        return next(iter(self.model_extra.values()))

    @property
    def key_path(self) -> KeyPath:
        """Where this guard was written; its condition key is at ``key_path + (guard.condition,)``."""
        return self._key_path


class _OneOrList:
    """JSON Schema of a list field that also accepts a single item (``when: {…}`` or ``when: [{…}, …]``)."""

    @classmethod
    def __get_pydantic_json_schema__(cls, core_schema: Any, handler: Callable[[Any], dict]) -> dict:
        as_list = handler(core_schema)
        return {"anyOf": [as_list["items"], as_list]}


class PriorityEntry(BaseModel):
    """One entry of `priorities`: run `do` while its `when` guard(s) all hold."""

    model_config = ConfigDict(extra="forbid")

    when: Annotated[list[Guard], BeforeValidator(_as_guard_list), _OneOrList] = Field(
        default_factory=list,
        description="Guard, or list of guards that must all hold (only the last entry may omit it).",
    )
    do: Node = Field(description="Node run while the guards hold.")
    _key_path: KeyPath = PrivateAttr(default_factory=KeyPath)
    _when_single: bool = PrivateAttr(False)

    @model_validator(mode="wrap")
    @classmethod
    def _remember_form(cls, data: Any, handler: Callable[[Any], PriorityEntry]) -> PriorityEntry:
        entry = handler(data)
        entry._when_single = isinstance(data, Mapping) and isinstance(data.get("when"), Mapping)
        return entry

    @property
    def key_path(self) -> KeyPath:
        """Where this entry was written."""
        return self._key_path


class PrioritiesNode(NodeBase):
    """`priorities: [{when: guard, do: node}, …, {do: node}]` — reactive fallback re-evaluated every tick:
    the first entry whose guards hold runs; a lower running entry is preempted."""

    kind: ClassVar[str] = "priorities"
    priorities: list[PriorityEntry] = Field(min_length=1, description="Entries, highest priority first.")

    @model_validator(mode="after")
    def _only_last_unguarded(self) -> PrioritiesNode:
        for i, entry in enumerate(self.priorities[:-1]):
            if not entry.when:
                raise PydanticCustomError(
                    "priority_without_guard",
                    "only the last entry of priorities may omit 'when'",
                    {"expected": "a 'when:' guard on this entry", "at": ("priorities", i)},
                )
        return self

    def map_children(self, fn: Callable[[Node, tuple], Node]) -> None:
        for i, entry in enumerate(self.priorities):
            entry.do = fn(entry.do, ("priorities", i, "do"))

    def guards(self) -> list[Guard]:
        """All guards of all entries, in order."""
        return [g for entry in self.priorities for g in entry.when]

    def set_key_path(self, key_path: KeyPath) -> None:
        super().set_key_path(key_path)
        for i, entry in enumerate(self.priorities):
            entry._key_path = key_path + ("priorities", i)
            for j, guard in enumerate(entry.when):
                guard._key_path = entry.key_path + (("when",) if entry._when_single else ("when", j))


def _not_zero(times: int) -> int:
    if times == 0:
        raise PydanticCustomError(
            "repeat_zero", "repeat 0 times does nothing", {"expected": "-1 (forever) or a count >= 1"}
        )
    return times


class RepeatNode(_Decorator):
    """`repeat: node` — run the child again each time it succeeds, `times` successes in all (-1: forever)."""

    kind: ClassVar[str] = "repeat"
    repeat: Node = Field(description="Child to repeat.")
    times: Annotated[int, AfterValidator(_not_zero)] = Field(
        -1, ge=-1, description="Number of successes to reach (-1: forever)."
    )


class RetryNode(_Decorator):
    """`retry: node` — run the child again when it fails, at most `times` attempts."""

    kind: ClassVar[str] = "retry"
    retry: Node = Field(description="Child to retry.")
    times: int = Field(ge=1, description="Maximum number of attempts.")


class TimeoutNode(_Decorator):
    """`timeout: node` — fail the child if it runs longer than `seconds` of simulated time."""

    kind: ClassVar[str] = "timeout"
    timeout: Node = Field(description="Child to bound in time.")
    seconds: float = Field(gt=0, description="Time limit (simulated seconds).")


class InvertNode(_Decorator):
    """`invert: node` — swap the child's success and failure."""

    kind: ClassVar[str] = "invert"
    invert: Node = Field(description="Child whose result is inverted.")


class UntilNode(_Decorator):
    """`until: node` + `condition: guard` — tick the child until the guard holds, then succeed."""

    kind: ClassVar[str] = "until"
    until: Node = Field(description="Child ticked while the guard does not hold.")
    condition: Guard = Field(description="Guard that ends the node with success.")

    def guards(self) -> list[Guard]:
        """The stopping guard."""
        return [self.condition]

    def set_key_path(self, key_path: KeyPath) -> None:
        super().set_key_path(key_path)
        self.condition._key_path = key_path + ("condition",)


class SkillNode(NodeBase):
    """`skill: name` — run a skill (a plug-in behaviour) on a robot with parameters."""

    kind: ClassVar[str] = "skill"
    skill: str = Field(description="Skill name (entry point in the marsupial.skills group, or a pinned plugin).")
    robot: str | None = Field(None, description="Team member that runs the skill.")
    params: dict[str, Any] = Field(default_factory=dict, description="Skill parameters (see `marsupial skills`).")


class ConditionNode(NodeBase):
    """`condition: name` — check a condition: success while it holds, failure otherwise."""

    kind: ClassVar[str] = "condition"
    condition: str = Field(description="Condition name (entry point in the marsupial.conditions group).")
    robot: str | None = Field(None, description="Team member the condition looks at.")
    params: dict[str, Any] = Field(default_factory=dict, description="Condition parameters.")


class SubtreeNode(NodeBase):
    """`subtree: name` — include a reusable tree (missions/subtrees/<name>.yaml or a path) with parameters."""

    kind: ClassVar[str] = "subtree"
    subtree: str = Field(description="Subtree name (missions/subtrees/<name>.yaml) or path relative to this file.")
    params: dict[str, Any] = Field(default_factory=dict, description="Values of the subtree's declared parameters.")


NODE_CLASSES: dict[str, type[NodeBase]] = {
    cls.kind: cls
    for cls in (SequenceNode, SelectorNode, ParallelNode, PrioritiesNode, RepeatNode, RetryNode,
                TimeoutNode, InvertNode, UntilNode, SkillNode, ConditionNode, SubtreeNode)
}

Node = Annotated[
    Union[tuple(Annotated[cls, Tag(kind)] for kind, cls in NODE_CLASSES.items())],
    Discriminator(node_kind),
]

for _cls in (*NODE_CLASSES.values(), PriorityEntry):
    _cls.model_rebuild()

# ------------------------------------------------------------------------ mission


class TeamLinkSpec(BaseModel):
    """The team's radio: one-way latency, its jitter, message loss and the estimate telemetry rate."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    latency_s: float = Field(0.02, ge=0, le=5.0, description="One-way latency of a message (s).")
    jitter_s: float = Field(0.01, ge=0, le=5.0, description="Standard deviation of the extra delay (s).")
    drop: float = Field(0.02, ge=0, le=1, description="Probability that a message is lost.")
    telemetry_hz: float = Field(20.0, gt=0, le=240, description="Rate at which every robot broadcasts its estimate (Hz).")


class SensingSpec(BaseModel):
    """How the robots sense: one knob scaling every noise figure, and the team link."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    noise_scale: float = Field(
        1.0,
        ge=0,
        le=100,
        description=(
            "Multiplies every sensor noise, bias, drift, latency and loss figure (docs/world.md lists them with "
            "their sources); 1: the sourced values, 0: perfect sensing (for debugging only)."
        ),
    )
    team_link: TeamLinkSpec = Field(default_factory=TeamLinkSpec)


class WorldSpec(BaseModel):
    """The world to run in: scene name, seed of every noise source, sensing, disturbances."""

    model_config = ConfigDict(extra="forbid")
    scene: str | None = Field(None, description="Scene name (world/scenes/<name>.yaml); none: an empty floor.")
    seed: int = Field(0, description="Seed of all randomness in the world.")
    sensing: SensingSpec = Field(default_factory=SensingSpec)
    disturbances: dict[str, Any] = Field(default_factory=dict, description="Disturbances (wind, sensor faults …).")


class TeamMember(BaseModel):
    """A robot of the team: its kind, start pose and options."""

    model_config = ConfigDict(extra="forbid")
    robot: str = Field(description="Robot kind (see world/robots ROBOT_KINDS).")
    pose: list[float] | None = Field(None, description="Start pose [x, y], [x, y, yaw] (ground robots) or [x, y, z, yaw] (m, rad, world frame).")
    stored_on: str | None = Field(None, description="Team member that carries this robot at the start.")
    sensors: dict[str, Any] = Field(default_factory=dict, description="Sensor configurations by sensor name.")
    options: dict[str, Any] = Field(default_factory=dict, description="Options passed to the robot constructor.")


class OperatorEvent(BaseModel):
    """A scripted operator command at a simulated time."""

    model_config = ConfigDict(extra="forbid")
    at: float = Field(ge=0, description="Simulated time of the command (s).")
    say: str = Field(min_length=1, description="Command: abort, pause, resume or a mission-defined word (dock …).")
    why: str = Field("", description="Reason, recorded with the command.")


class RunSpec(BaseModel):
    """How the tree is ticked: tick rate and time limit (simulated)."""

    model_config = ConfigDict(extra="forbid")
    tick_hz: float = Field(10.0, gt=0, description="Tree tick rate (Hz, simulated time).")
    until: float | None = Field(None, gt=0, description="Stop the run at this simulated time (s); none: no limit.")


def _plugin_ref(value: str) -> str:
    module, _, attr = value.partition(":")
    if not module or not attr or not all(p.isidentifier() for p in module.split(".") + attr.split(".")):
        raise PydanticCustomError("plugin_ref", "malformed plugin reference", {"expected": "'package.module:Class'"})
    return value


class MissionSpec(BaseModel):
    """A marsupial mission: world, team, scripted operator, plugins, parameters, run settings and the tree."""

    model_config = ConfigDict(extra="forbid", title="marsupial mission")

    mission: str = Field(description="Mission name.")
    description: str = Field("", description="What the mission does.")
    world: WorldSpec = Field(default_factory=WorldSpec)
    team: dict[str, TeamMember] = Field(default_factory=dict, description="Robots by name.")
    operator: list[OperatorEvent] = Field(default_factory=list, description="Scripted operator commands.")
    plugins: dict[str, Annotated[str, AfterValidator(_plugin_ref)]] = Field(
        default_factory=dict, description="Pinned skill/condition implementations: name -> 'package.module:Class'."
    )
    params: dict[str, Any] = Field(default_factory=dict, description="Mission parameters, referenced as ${name}.")
    run: RunSpec = Field(default_factory=RunSpec)
    tree: Node = Field(description="The behaviour tree.")

    @model_validator(mode="after")
    def _carriers_exist(self) -> MissionSpec:
        for name, member in self.team.items():
            others = set(self.team) - {name}
            if member.stored_on is not None and member.stored_on not in others:
                raise PydanticCustomError(
                    "unknown_carrier",
                    f"'{member.stored_on}' cannot carry '{name}'",
                    {"expected": f"another team member ({one_of(others)})",
                     "suggestion": suggest(member.stored_on, others), "at": ("team", name, "stored_on")},
                )
        return self


# ------------------------------------------------------- validation errors -> MissionError

_EXPECTATIONS = {
    "int_type": "an integer", "int_parsing": "an integer", "int_from_float": "an integer",
    "float_type": "a number", "float_parsing": "a number", "string_type": "a string",
    "bool_type": "true or false", "bool_parsing": "true or false", "list_type": "a list",
    "dict_type": "a mapping", "model_type": "a mapping", "model_attributes_type": "a mapping",
    "literal_error": "{expected}", "greater_than": "a value > {gt}", "greater_than_equal": "a value >= {ge}",
    "less_than": "a value < {lt}", "less_than_equal": "a value <= {le}",
    "too_short": "at least {min_length} item(s)", "too_long": "at most {max_length} item(s)",
    "string_too_short": "a non-empty string", "none_required": "null",
}


def _unwrap(tp: Any) -> Any:
    """``X | None`` -> ``X``; ``Annotated[X, …]`` -> ``X``."""
    while True:
        if get_origin(tp) is Annotated:
            tp = get_args(tp)[0]
        elif get_origin(tp) in (Union, types.UnionType):
            members = [m for m in get_args(tp) if m is not type(None)]
            if len(members) != 1 or _tag_map(tp):
                return tp
            tp = members[0]
        else:
            return tp


def _tag_map(tp: Any) -> dict[str, Any]:
    """Tag -> member type of a tagged (discriminated) union, ``{}`` for any other type."""
    if get_origin(tp) is Annotated:
        tp = get_args(tp)[0]
    tags = {}
    if get_origin(tp) in (Union, types.UnionType):
        for member in get_args(tp):
            if get_origin(member) is Annotated:
                tags.update({m.tag: get_args(member)[0] for m in get_args(member)[1:] if isinstance(m, Tag)})
    return tags


def _describe(tp: Any) -> str:
    """What a value of type ``tp`` looks like, in words ("an integer", "a node …")."""
    if _tag_map(tp):
        return f"a node ({one_of(_tag_map(tp))})"
    tp = _unwrap(tp)
    origin = get_origin(tp)
    if origin is Literal:
        return one_of(repr(a) for a in get_args(tp))
    if origin is list:
        return "a list"
    if origin is dict:
        return "a mapping"
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        required = [n for n, f in tp.model_fields.items() if f.is_required()]
        return f"a mapping with {', '.join(required)}" if required else "a mapping"
    return {int: "an integer", float: "a number", str: "a string", bool: "true or false"}.get(tp, "a value")


@dataclass
class _LocWalk:
    """A pydantic error location mapped back onto the YAML document."""

    path: tuple  # key path as written in the YAML (union tags dropped)
    model: type[BaseModel] | None  # the model that holds the last key
    annotation: Any  # declared type at the path
    value: Any  # the YAML value at the path (None if absent)


_ABSENT = object()


def _walk_loc(loc: tuple, root: Any, data: Any) -> _LocWalk:
    path: list = []
    tp, value, model = root, data, None
    for item in loc:
        tags = _tag_map(tp)
        if item in tags:  # a tagged-union member: not a YAML key
            tp = tags[item]
            continue
        tp = _unwrap(tp)
        origin = get_origin(tp)
        if isinstance(tp, type) and issubclass(tp, BaseModel):
            model = tp
            tp = tp.model_fields[item].annotation if item in tp.model_fields else Any
        elif origin is list:
            tp = get_args(tp)[0]
            if item == 0 and not isinstance(value, list):  # a single item written without a list
                continue
        elif origin is dict:
            tp = get_args(tp)[1]
        else:
            tp = Any
        path.append(item)
        try:
            value = value[item]
        except (KeyError, IndexError, TypeError):
            value = _ABSENT
    return _LocWalk(tuple(path), model, tp, None if value is _ABSENT else value)


def _node_error(walk: _LocWalk) -> tuple[tuple, str, str, str | None]:
    """(key path, message, expected, suggestion) for a mapping whose node type cannot be told."""
    value, kinds = walk.value, one_of(NODE_KINDS)
    if not isinstance(value, Mapping):
        expected = f"a mapping with one of {', '.join(NODE_KINDS)} (e.g. {{skill: wait}})"
        return walk.path, f"expected a node, got {_show(value)}", expected, None
    present = [k for k in NODE_KINDS if k in value]
    if len(present) > 1:
        found = ", ".join(f"'{k}'" for k in present)
        return walk.path, f"a node has exactly one node type key, found {found}", kinds, None
    known_fields = {f for cls in NODE_CLASSES.values() for f in cls.model_fields}
    unknown = [k for k in value if k not in known_fields]
    for key in unknown:
        if suggest(key, NODE_KINDS):
            return walk.path + (key,), f"unknown node type '{key}'", kinds, suggest(key, NODE_KINDS)
    if unknown:
        return walk.path + (unknown[0],), f"unknown node type '{unknown[0]}'", kinds, None
    return walk.path, "node has no node type key", kinds, None


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _convert(err: Mapping[str, Any], root: Any, data: Any) -> tuple[tuple, str, str | None, str | None]:
    """(key path, message, expected, suggestion) of one pydantic error."""
    walk = _walk_loc(tuple(err["loc"]), root, data)
    kind, ctx = err["type"], err.get("ctx") or {}
    if kind in ("union_tag_not_found", "union_tag_invalid"):
        return _node_error(walk)
    if kind == "extra_forbidden":
        key = walk.path[-1]
        known = list(walk.model.model_fields) if walk.model else []
        return walk.path, f"unknown key '{key}'", one_of(known), suggest(key, known)
    if kind == "missing":
        return walk.path, f"missing required key '{walk.path[-1]}'", _describe(walk.annotation), None
    if "expected" in ctx and kind not in _EXPECTATIONS:  # our own checks (PydanticCustomError)
        return walk.path + tuple(ctx.get("at", ())), err["msg"], ctx["expected"], ctx.get("suggestion")
    if kind in _EXPECTATIONS:
        limits = {k: f"{v:g}" if isinstance(v, float) else v for k, v in ctx.items()}
        return walk.path, f"invalid value {_show(err['input'])}", _EXPECTATIONS[kind].format(**limits), None
    return walk.path, err["msg"], None, None


def validation_errors(
    exc: ValidationError,
    source: SourceDoc,
    base_path: KeyPathLike = (),
    root: Any = None,
    data: Any = None,
    notes: Mapping[tuple, str] | None = None,
    note: str | None = None,
) -> list[MissionError]:
    """A :class:`MissionError` for each error of a pydantic ``ValidationError``.

    ``exc`` came from validating ``data`` (found at ``base_path`` of ``source``)
    against ``root`` (a model class or type; ``None``: locations are taken as
    they are). Each error names the YAML key path (union tags dropped), its
    file:line:column, what was expected and, for unknown keys, the closest
    known key. ``notes`` adds lines to errors at or under given key paths
    (values set by overrides or ``${name}`` references); ``note`` to all
    (inside a subtree).
    """
    errors = []
    for err in exc.errors():
        rel, message, expected, suggestion = _convert(err, root if root is not None else Any, data)
        path = tuple(base_path) + rel
        lines = [n for p, n in (notes or {}).items() if path[: len(p)] == p] + ([note] if note else [])
        errors.append(source.error(path, message, expected, suggestion, "; ".join(lines) or None))
    return errors


def errors_from_validation(
    exc: ValidationError,
    source: SourceDoc,
    base_path: KeyPathLike = (),
    root: Any = None,
    data: Any = None,
    notes: Mapping[tuple, str] | None = None,
    note: str | None = None,
) -> MissionError:
    """:func:`validation_errors` as one :class:`MissionError` (a :class:`MissionErrors` if several)."""
    return combine_errors(validation_errors(exc, source, base_path, root, data, notes, note), MAX_REPORTED_ERRORS)


@functools.cache
def _adapter(model: Any) -> TypeAdapter:
    return TypeAdapter(model)


def validate_source(
    model: Any,
    data: Any,
    source: SourceDoc,
    base_path: KeyPathLike = (),
    pending: Sequence[MissionError] = (),
    notes: Mapping[tuple, str] | None = None,
    note: str | None = None,
) -> Any:
    """``data`` (found at ``base_path`` of ``source``) validated against ``model`` (a type).

    ``pending`` errors found before (unknown ``${name}`` references, whose
    strings were left as written) are raised together with the validation
    errors, in file order; validation errors under a pending error's key path
    are dropped as its consequences.
    """
    errors, value = list(pending), None
    try:
        value = _adapter(model).validate_python(data)
    except ValidationError as exc:
        found = validation_errors(exc, source, base_path, model, data, notes, note)
        errors += [e for e in found if not any(e.key_path[: len(p.key_path)] == p.key_path for p in pending)]
    if errors:
        raise combine_errors(errors, MAX_REPORTED_ERRORS)
    return value


# ----------------------------------------------------------------------- missions


@dataclass
class Mission:
    """A loaded, validated mission: its spec, original text, file and source positions.

    ``spec.tree`` has its subtrees inlined and every node knows its ``key_path``;
    ``overrides`` are the ``--set`` values applied (as given); ``references``
    records where the values of ``${name}`` references were set, so that a
    later error at such a place (a wrong skill parameter) says it.
    """

    spec: MissionSpec
    text: str
    path: Path | None
    source: SourceDoc
    overrides: dict[str, str] = field(default_factory=dict)
    references: dict[tuple, str] = field(default_factory=dict, repr=False)  # (file, include note, key path) -> note

    @property
    def name(self) -> str:
        """The mission's name (its ``mission:`` key)."""
        return self.spec.mission

    def _place(self, where: KeyPathLike | NodeBase | Guard | PriorityEntry) -> tuple[SourceDoc, tuple, str | None]:
        """(source document, key path, include note) of a key path or node."""
        key_path = getattr(where, "key_path", where)
        return getattr(key_path, "source", None) or self.source, tuple(key_path), getattr(key_path, "note", None)

    def reference_notes(self, source: SourceDoc, note: str | None) -> dict[tuple, str]:
        """Key path -> where its ``${name}`` values were set, for the strings of ``source`` reached via ``note``."""
        return {path: text for (file, via, path), text in self.references.items() if (file, via) == (source.file, note)}

    def error_at(
        self,
        where: KeyPathLike | NodeBase | Guard | PriorityEntry,
        message: str,
        expected: str | None = None,
        suggestion: str | None = None,
    ) -> MissionError:
        """A :class:`MissionError` at a key path (or node/guard) of the mission or of the subtree file it came from.

        Returns the error; the caller raises it. ``node.key_path + ("params", "speed")`` points inside a node.
        """
        source, key_path, note = self._place(where)
        lines = [text for path, text in self.reference_notes(source, note).items() if key_path[: len(path)] == path]
        lines += [note] if note else []
        return source.error(key_path, message, expected, suggestion, "; ".join(lines) or None)

    def validation_error(self, exc: ValidationError, where: KeyPathLike | NodeBase, model: Any = None) -> MissionError:
        """A :class:`MissionError` for ``exc``, raised validating the value at ``where`` (e.g. a node's
        ``params`` against a skill's ``Params`` model given as ``model``)."""
        source, key_path, note = self._place(where)
        data = source.data
        for item in key_path:
            data = data[item] if isinstance(data, (dict, list)) and _has(data, item) else None
        notes = self.reference_notes(source, note)
        return errors_from_validation(exc, source, key_path, model, data, notes, note)

    def param_origins(self) -> dict[str, str]:
        """Where each mission parameter got its value: ``"set at file:line:column"`` or ``"set by --set …"``."""
        return _param_origins(self.source, self.spec.params, self.overrides)

    def nodes(self) -> Iterator[Node]:
        """Every node of the tree, depth first."""
        return self.spec.tree.walk()


def _param_origins(source: SourceDoc, params: Mapping[str, Any], overrides: Mapping[str, str]) -> dict[str, str]:
    set_by = {key.removeprefix("params."): f"set by --set {key}={value}" for key, value in overrides.items()}
    return {name: set_by.get(name) or f"set at {source.where(('params', name))}" for name in params}


def _has(container: dict | list, item: Any) -> bool:
    if isinstance(container, dict):
        return item in container
    return isinstance(item, int) and -len(container) <= item < len(container)


def display_path(path: Path) -> str:
    """``path`` as shown in errors: relative to the working directory when it is below it."""
    try:
        return str(path.resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def mission_dir() -> Path:
    """Folder of the missions shipped with the package (``missions/``)."""
    return Path(str(files("marsupial.missions")))


def known_missions() -> list[str]:
    """Names of the missions shipped with the package."""
    return sorted(p.stem for p in mission_dir().glob("*.yaml"))


def find_mission(name_or_path: str | Path) -> Path:
    """Path of a mission given by package name (``landing``) or by file path."""
    path = Path(name_or_path)
    looks_like_path = isinstance(name_or_path, Path) or path.suffix in (".yaml", ".yml") or len(path.parts) > 1
    if not looks_like_path:
        shipped = mission_dir() / f"{name_or_path}.yaml"
        if shipped.is_file():
            return shipped
    if path.is_file():
        return path
    known = known_missions()
    what = f"mission file '{path}' not found" if looks_like_path else f"unknown mission '{name_or_path}'"
    names = f"a mission name ({one_of(known)}) or " if known else ""
    raise MissionError(what, expected=f"{names}a path to a mission .yaml file", suggestion=suggest(path.stem, known))


# ------------------------------------------------------------------------ overrides

_SECTIONS = {name: f.annotation for name, f in MissionSpec.model_fields.items()}


def _override_keys(data: Any, tp: Any) -> list:
    """Keys an override may set in ``data`` (declared type ``tp``): model fields, else existing keys."""
    tp = _unwrap(tp)
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return list(tp.model_fields)
    if isinstance(data, dict):
        return list(data)
    if isinstance(data, list):
        return list(range(len(data)))
    return []


def _is_mapping_type(tp: Any) -> bool:
    tp = _unwrap(tp)
    return get_origin(tp) is dict or (isinstance(tp, type) and issubclass(tp, BaseModel))


def apply_overrides(data: dict, overrides: Mapping[str, str], file: str | None = None) -> dict[tuple, str]:
    """Set ``--set key=value`` overrides in mission ``data`` (in place); values are parsed as YAML.

    A key is a dotted path (``params.cruise_height``, ``world.seed``,
    ``run.until``, ``team.uav.pose.2``) or a bare mission parameter name
    (``cruise_height``). Returns key path -> ``"--set key=value"`` of each
    override (to annotate later validation errors). An unknown key raises a
    :class:`MissionError` listing the close names.
    """
    applied: dict[tuple, str] = {}
    params = data.get("params") if isinstance(data.get("params"), dict) else {}
    for key, text in overrides.items():
        shown = f"--set {key}={text}"
        parts: list[Any] = key.split(".") if "." in key else ["params", key]
        if "." not in key and key not in params:
            names = [f"params.{p}" for p in params] + [f"{s}." for s in _SECTIONS]
            raise MissionError(
                f"{shown}: '{key}' is not a mission parameter", file,
                expected=f"a mission parameter ({one_of(params)}) or a dotted key such as world.seed",
                suggestion=suggest(key, list(params) + names),
            )
        target, tp = data, MissionSpec
        for depth, part in enumerate(parts):
            if isinstance(target, list) and part.lstrip("-").isdigit():
                part = parts[depth] = int(part)
            allowed = _override_keys(target, tp) if isinstance(target, (dict, list)) else []
            if part not in allowed:
                prefix = ".".join(str(p) for p in parts[:depth])
                full = [f"{prefix}.{a}" if prefix else str(a) for a in allowed]
                key_text = ".".join(str(p) for p in parts[: depth + 1])
                raise MissionError(
                    f"{shown}: unknown key '{key_text}'", file,
                    expected=one_of(full) if full else f"'{prefix}' to hold a mapping or a list",
                    suggestion=suggest(key_text, full),
                )
            tp = _walk_loc((part,), tp, None).annotation
            if depth == len(parts) - 1:
                target[part] = parse_scalar(text)
            else:
                if isinstance(target, dict) and target.get(part) is None and _is_mapping_type(tp):
                    target[part] = {}  # a section left out of the file (run:, world: …)
                target = target.get(part) if isinstance(target, dict) else target[part]
        applied[tuple(parts)] = shown
    return applied


# ---------------------------------------------------------------------- loading


def parse_mission(
    text: str, file: str = "<string>", overrides: Mapping[str, str] | None = None, path: Path | None = None
) -> Mission:
    """Validate mission ``text`` (shown as ``file`` in errors; ``path`` locates relative subtrees)."""
    from .subtrees import expand_subtrees, resolve_references  # subtrees build on this module's models

    source = load_yaml(text, file)
    if not isinstance(source.data, dict):
        raise source.error((), "a mission must be a mapping", expected="keys mission, world, team, params, tree …")
    data = copy.deepcopy(source.data)
    overridden = apply_overrides(data, overrides or {}, source.file)
    notes = {path: f"value set by {shown}" for path, shown in overridden.items()}
    unknown: list[MissionError] = []
    params = data.get("params", {})
    if "tree" in data and isinstance(params, dict):
        origins = _param_origins(source, params, overrides or {})
        resolved = resolve_references(data["tree"], params, source, ("tree",), origins)
        data["tree"], unknown = resolved.data, resolved.unknown
        notes.update(resolved.notes)
    spec = validate_source(MissionSpec, data, source, (), unknown, notes)
    spec.tree.set_key_path(KeyPath(("tree",), source))
    mission = Mission(spec, text, path, source, dict(overrides or {}))
    mission.references.update({(source.file, None, p): n for p, n in notes.items()})
    expand_subtrees(mission)
    _check_robots(mission)
    return mission


def load_mission(name_or_path: str | Path, overrides: Mapping[str, str] | None = None) -> Mission:
    """Load a mission by name (package ``marsupial.missions``) or path, apply overrides, validate, inline subtrees."""
    path = find_mission(name_or_path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise MissionError(f"cannot read mission file: {exc}", str(path)) from None
    return parse_mission(text, display_path(path) if path.is_absolute() else str(path), overrides, path)


def _robot_refs(node: NodeBase) -> Iterator[tuple[KeyPath, str]]:
    """(key path of the ``robot`` key, robot name) of a node and its guards."""
    for holder in [node, *node.guards()]:
        robot = getattr(holder, "robot", None)
        if robot is not None:
            yield holder.key_path + ("robot",), robot


def _check_robots(mission: Mission) -> None:
    team = mission.spec.team
    for node in mission.nodes():
        for key_path, robot in _robot_refs(node):
            if robot not in team:
                raise mission.error_at(
                    key_path, f"unknown robot '{robot}'", expected=f"a team member ({one_of(team)})",
                    suggestion=suggest(robot, team),
                )


def mission_schema() -> dict[str, Any]:
    """JSON Schema (draft 2020-12) of a mission file, with the node union as ``$defs/Node``."""
    schema = MissionSpec.model_json_schema()
    refs = [{"$ref": f"#/$defs/{cls.__name__}"} for cls in NODE_CLASSES.values()]

    def name_union(value: Any) -> None:
        if isinstance(value, dict):
            if value.get("oneOf") == refs:
                del value["oneOf"]
                value["$ref"] = "#/$defs/Node"
            for item in value.values():
                name_union(item)
        elif isinstance(value, list):
            for item in value:
                name_union(item)

    name_union(schema)
    schema["$defs"]["Node"] = {
        "title": "Node",
        "description": f"A tree node: a mapping with exactly one of {', '.join(NODE_KINDS)}.",
        "oneOf": refs,
    }
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", **schema}
