"""Tree nodes of a mission file (sequence, selector, …, skill, condition, subtree) and their key paths.

Every node model keeps the key path it was written at (:class:`KeyPath`, which
also knows its source document), so later stages report problems there.
``Node`` is the discriminated union of every node model.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from typing import Annotated, Any, ClassVar, Literal, TypeAlias, cast, get_args

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Discriminator,
    Field,
    PrivateAttr,
    Tag,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticCustomError

from marsupial.api.config import OneOrList

from ..errors import KeyPathLike, suggest
from ..yaml_source import SourceDoc


class KeyPath(tuple[Any, ...]):
    """A key path (keys and list indices) that also remembers the document it points into.

    ``source`` is the :class:`SourceDoc` (the mission, or a subtree file for
    inlined nodes) and ``note`` says through which include it was reached.
    Adding a tuple keeps both: ``node.key_path + ("params", "speed")``.
    """

    source: SourceDoc | None
    note: str | None

    def __new__(cls, items: KeyPathLike = (), source: SourceDoc | None = None, note: str | None = None) -> KeyPath:
        self = super().__new__(cls, tuple(items))
        self.source = source
        self.note = note
        return self

    def __add__(self, other: KeyPathLike) -> KeyPath:
        return KeyPath(tuple(self) + tuple(other), self.source, self.note)


# --------------------------------------------------------------------------- nodes

NODE_KINDS = (
    "sequence", "selector", "parallel", "priorities", "repeat", "retry", "timeout", "invert", "until",
    "run_for", "wait_until", "idle", "skill", "condition", "subtree",
)  # the structural keys: a node mapping has exactly one of them

#: node type -> structural key it also carries as an ordinary field (``until``'s guard, ``wait_until``'s time limit)
_SHARED_KEYS = {"until": "condition", "wait_until": "timeout"}


def structural_keys(value: Mapping[str, Any]) -> list[str]:
    """The node-type keys of a node mapping, ``until``'s ``condition`` and ``wait_until``'s ``timeout`` left out."""
    kinds = [k for k in NODE_KINDS if k in value]
    for kind, field_name in _SHARED_KEYS.items():
        if kind in kinds and field_name in kinds:
            kinds.remove(field_name)
    return kinds


def node_kind(value: Any) -> str | None:
    """The node type of a node mapping (its single structural key), or ``None`` if it has none or several."""
    if isinstance(value, NodeBase):
        return value.kind
    if not isinstance(value, Mapping):
        return None
    kinds = structural_keys(value)
    return kinds[0] if len(kinds) == 1 else None


class NodeBase(BaseModel):
    """Common part of every tree node: an optional display ``name`` and the key path it was written at."""

    model_config = ConfigDict(extra="forbid")
    kind: ClassVar[str]

    name: str | None = Field(
        None, min_length=1, max_length=200, pattern=r"^[^\x00-\x1f\x7f]+$",
        description="Display name of the node (in logs, tree drawings): printable text, no control characters.",
    )
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

    def map_children(self, fn: Callable[[Node, tuple[Any, ...]], Node]) -> None:
        """Replace each child ``c`` (at relative key path ``rel``) with ``fn(c, rel)``; leaves have none."""

    @property
    def children(self) -> list[Node]:
        """The child nodes, in order."""
        found: list[Node] = []

        def keep(child: Node, _: tuple[Any, ...]) -> Node:
            found.append(child)
            return child

        self.map_children(keep)
        return found

    def guards(self) -> list[Guard]:
        """The guards of this node (``priorities`` and ``until`` have some)."""
        return []

    def walk(self) -> Iterator[Node]:
        """This node and all its descendants, depth first."""
        yield cast("Node", self)
        for child in self.children:
            yield from child.walk()

    def set_key_path(self, key_path: KeyPath) -> None:
        """Record ``key_path`` on this node and, below it, on its children and guards."""
        self._key_path = key_path
        self.map_children(lambda child, rel: child.set_key_path(key_path + rel) or child)


class _Composite(NodeBase):
    """A node whose structural key holds a list of child nodes."""

    def map_children(self, fn: Callable[[Node, tuple[Any, ...]], Node]) -> None:
        children = getattr(self, self.kind)
        setattr(self, self.kind, [fn(child, (self.kind, i)) for i, child in enumerate(children)])


class _Decorator(NodeBase):
    """A node whose structural key holds its one child node."""

    def map_children(self, fn: Callable[[Node, tuple[Any, ...]], Node]) -> None:
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
        return str(next(iter(self.model_extra or {})))

    @property
    def argument(self) -> Any:
        """The condition's primary argument (the value of the condition key)."""
        return next(iter((self.model_extra or {}).values()))

    @property
    def key_path(self) -> KeyPath:
        """Where this guard was written; its condition key is at ``key_path + (guard.condition,)``."""
        return self._key_path


class PriorityEntry(BaseModel):
    """One entry of `priorities`: run `do` while its `when` guard(s) all hold."""

    model_config = ConfigDict(extra="forbid")

    when: OneOrList[Guard] = Field(
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

    def map_children(self, fn: Callable[[Node, tuple[Any, ...]], Node]) -> None:
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


#: a duration in simulated seconds: a finite number > 0 (not a boolean, not a string)
Seconds = Annotated[float, Field(gt=0, allow_inf_nan=False, strict=True)]


class RunForNode(_Decorator):
    """`run_for: node` — run the child for `seconds` of simulated time: success if it is still running then
    (it is stopped), else the child's own result (a failure stays a failure)."""

    kind: ClassVar[str] = "run_for"
    run_for: Node = Field(description="Child to run.")
    seconds: Seconds = Field(description="How long to run it (simulated seconds).")


class WaitUntilNode(NodeBase):
    """`wait_until: guard` — running (commanding nothing) until the guard holds, then success;
    with `timeout`, failure when it has not held after that many simulated seconds."""

    kind: ClassVar[str] = "wait_until"
    wait_until: Guard = Field(description="Guard to wait for, e.g. {stored: carrier, robot: uav}.")
    timeout: Seconds | None = Field(None, description="Fail after this many simulated seconds (none: wait forever).")

    @property
    def label(self) -> str:
        """``name`` if given, else ``"wait until <condition>"``."""
        return self.name or f"wait until {self.wait_until.condition}"

    def guards(self) -> list[Guard]:
        """The guard waited for."""
        return [self.wait_until]

    def set_key_path(self, key_path: KeyPath) -> None:
        super().set_key_path(key_path)
        self.wait_until._key_path = key_path + ("wait_until",)


class IdleNode(NodeBase):
    """`idle: true` — running forever, commanding nothing (a branch that only waits to be stopped)."""

    kind: ClassVar[str] = "idle"
    idle: bool = Field(description="Always true.", json_schema_extra={"const": True})

    @field_validator("idle", mode="before")
    @classmethod
    def _only_true(cls, value: Any) -> bool:
        if value is not True:
            raise PydanticCustomError(
                "idle_true", f"idle takes true, got {value!r}", {"expected": "true (idle: true)"}
            )
        return value


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


#: every tree node, as a discriminated union on its node-type key (what :func:`node_kind` finds)
Node: TypeAlias = Annotated[
    Annotated[SequenceNode, Tag("sequence")]
    | Annotated[SelectorNode, Tag("selector")]
    | Annotated[ParallelNode, Tag("parallel")]
    | Annotated[PrioritiesNode, Tag("priorities")]
    | Annotated[RepeatNode, Tag("repeat")]
    | Annotated[RetryNode, Tag("retry")]
    | Annotated[TimeoutNode, Tag("timeout")]
    | Annotated[InvertNode, Tag("invert")]
    | Annotated[UntilNode, Tag("until")]
    | Annotated[RunForNode, Tag("run_for")]
    | Annotated[WaitUntilNode, Tag("wait_until")]
    | Annotated[IdleNode, Tag("idle")]
    | Annotated[SkillNode, Tag("skill")]
    | Annotated[ConditionNode, Tag("condition")]
    | Annotated[SubtreeNode, Tag("subtree")],
    Discriminator(node_kind),
]

#: node-type key -> node model, in the union's order
NODE_CLASSES: dict[str, type[NodeBase]] = {
    get_args(member)[0].kind: get_args(member)[0] for member in get_args(get_args(Node)[0])
}

_MODELS: tuple[type[BaseModel], ...] = (*NODE_CLASSES.values(), PriorityEntry)
for _cls in _MODELS:
    _cls.model_rebuild()
