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

from marsupial.api.config import TeamMember

from .loading import (
    Mission,
    display_path,
    find_mission,
    known_missions,
    load_mission,
    mission_dir,
    parse_mission,
)
from .nodes import (
    NODE_CLASSES,
    NODE_KINDS,
    ConditionNode,
    Guard,
    IdleNode,
    InvertNode,
    KeyPath,
    Node,
    NodeBase,
    ParallelNode,
    PrioritiesNode,
    PriorityEntry,
    RepeatNode,
    RetryNode,
    RunForNode,
    SelectorNode,
    SequenceNode,
    SkillNode,
    SubtreeNode,
    TimeoutNode,
    UntilNode,
    WaitUntilNode,
    node_kind,
    structural_keys,
)
from .overrides import apply_overrides
from .schema import mission_schema
from .spec import (
    MissionSpec,
    OperatorEvent,
    RunSpec,
    SensingSpec,
    TeamLinkSpec,
    WorldSpec,
)
from .validation import (
    MAX_REPORTED_ERRORS,
    errors_from_validation,
    validate_source,
    validation_errors,
)

__all__ = [
    "MAX_REPORTED_ERRORS", "NODE_CLASSES", "NODE_KINDS", "ConditionNode", "Guard", "IdleNode", "InvertNode",
    "KeyPath", "Mission", "MissionSpec", "Node", "NodeBase", "OperatorEvent", "ParallelNode", "PrioritiesNode",
    "PriorityEntry", "RepeatNode", "RetryNode", "RunForNode", "RunSpec", "SelectorNode", "SensingSpec",
    "SequenceNode", "SkillNode", "SubtreeNode", "TeamLinkSpec", "TeamMember", "TimeoutNode", "UntilNode",
    "WaitUntilNode", "WorldSpec", "apply_overrides", "display_path", "errors_from_validation", "find_mission",
    "known_missions", "load_mission", "mission_dir", "mission_schema", "node_kind", "parse_mission",
    "structural_keys", "validate_source", "validation_errors",
]
