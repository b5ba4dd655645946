"""A py_trees tree as BehaviorTree.CPP v4 XML (for Groot2 and Foxglove behaviour-tree panels).

:func:`to_btcpp_xml` writes ``<root BTCPP_format="4">`` with one
``<BehaviorTree ID=...>`` and a ``<TreeNodesModel>`` declaring every custom
node, so Groot2 opens the file. py_trees nodes map onto BehaviorTree.CPP
built-ins where the semantics match:

=====================================  =========================================
py_trees                               BehaviorTree.CPP v4
=====================================  =========================================
``Sequence(memory=True)``              ``Sequence``
``Sequence(memory=False)``             ``ReactiveSequence``
``Selector(memory=True)``              ``Fallback``
``Selector(memory=False)``             ``ReactiveFallback``
``Parallel(SuccessOnAll)``             ``Parallel success_count="-1" failure_count="1"``
``Parallel(SuccessOnOne)``             ``Parallel success_count="1" failure_count="1"``
``Parallel(SuccessOnSelected)``        ``Parallel success_count="<selected>" failure_count="1"``
``Inverter``                           ``Inverter``
``Repeat(num_success)``                ``Repeat num_cycles``
``Retry(num_failures)``                ``RetryUntilSuccessful num_attempts``
``Timeout(duration)``                  ``Timeout msec``
``FailureIsSuccess``                   ``ForceSuccess``
``SuccessIsFailure``                   ``ForceFailure``
``OneShot``                            ``RunOnce then_skip="false"``
``behaviours.Success`` / ``Failure``   ``AlwaysSuccess`` / ``AlwaysFailure``
=====================================  =========================================

Any other node is written in BehaviorTree.CPP's compact form, its class
name as the tag (``<DriveTo name="to dock"/>``), and declared in the
``TreeNodesModel`` as an ``Action``, ``Condition``, ``Decorator`` or
``Control``. A node class may steer its export with three optional
attributes:

- ``btcpp_kind``: ``"Action"`` (default for leaves) or ``"Condition"``;
- ``btcpp_tag``: the name of a BehaviorTree.CPP built-in it behaves like
  (then it is not declared in the model);
- ``btcpp_ports()``: a method returning the node's port values
  ``{name: value}``, written as XML attributes.

Without ``btcpp_ports()``, a node whose ``params`` attribute is a pydantic
model exports its field values as ports, and the model declares them as
``input_port`` elements (type and description from the field); a
``robot_name`` attribute becomes a ``robot`` port.

Node uids: nodes are numbered 1, 2, 3 … in depth-first pre-order
(:func:`walk`), as BehaviorTree.CPP numbers the nodes it creates; with
``with_uids=True`` the number is written as the ``_uid`` attribute that the
Foxglove panel matches against the ``uid`` of ``/tree`` event-log entries.
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from typing import Any

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import ParallelPolicy, Status

from marsupial.api.ticks import TreeStatus

__all__ = ["BTCPP_BUILTINS", "STATUS_NAMES", "root_of", "status_name", "to_btcpp_xml", "walk"]

#: py_trees status -> BehaviorTree.CPP status name (a node never ticked, or halted, is IDLE)
STATUS_NAMES: dict[Status, str] = {
    Status.INVALID: "IDLE",
    Status.RUNNING: "RUNNING",
    Status.SUCCESS: "SUCCESS",
    Status.FAILURE: "FAILURE",
}

#: node IDs BehaviorTree.CPP v4 and Groot2 know without a model declaration
BTCPP_BUILTINS = frozenset(
    {
        "AlwaysFailure", "AlwaysSuccess", "Delay", "Fallback", "ForceFailure", "ForceSuccess",
        "IfThenElse", "Inverter", "KeepRunningUntilFailure", "Parallel", "ParallelAll",
        "Precondition", "ReactiveFallback", "ReactiveSequence", "Repeat", "RetryUntilSuccessful",
        "RunOnce", "Script", "ScriptCondition", "Sequence", "SequenceWithMemory", "SetBlackboard",
        "Sleep", "SubTree", "Switch2", "Switch3", "Switch4", "Switch5", "Switch6", "Timeout",
        "WasEntryUpdated", "WhileDoElse",
    }
)

# py_trees leaves that only test the blackboard: BehaviorTree.CPP conditions
_CONDITION_LEAVES: tuple[type, ...] = (
    py_trees.behaviours.CheckBlackboardVariableExists,
    py_trees.behaviours.CheckBlackboardVariableValue,
    py_trees.behaviours.CheckBlackboardVariableValues,
    py_trees.behaviours.CompareBlackboardVariables,
    py_trees.behaviours.WaitForBlackboardVariable,
    py_trees.behaviours.WaitForBlackboardVariableValue,
)


def root_of(tree: Behaviour | py_trees.trees.BehaviourTree) -> Behaviour:
    """The root behaviour of ``tree`` (a behaviour or a ``py_trees.trees.BehaviourTree``)."""
    root = getattr(tree, "root", tree)
    if not isinstance(root, Behaviour):
        raise TypeError(
            f"expected a py_trees Behaviour or BehaviourTree, got {type(tree).__name__}"
        )
    return root


def walk(tree: Behaviour | py_trees.trees.BehaviourTree) -> list[Behaviour]:
    """Every node of ``tree`` in depth-first pre-order; node ``i`` of the list has uid ``i + 1``."""
    nodes = []
    stack = [root_of(tree)]
    while stack:  # iterative: this runs after every tick of a run
        node = stack.pop()
        nodes.append(node)
        if node.children:
            stack.extend(reversed(node.children))
    return nodes


def status_name(status: Status) -> str:
    """BehaviorTree.CPP name of a py_trees status: IDLE, RUNNING, SUCCESS or FAILURE."""
    return STATUS_NAMES[status]


def _port_text(value: Any) -> str:
    """A port value as BehaviorTree.CPP attribute text (numbers plain, lists/dicts as JSON)."""
    if isinstance(value, str):
        return value
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if hasattr(value, "tolist"):  # numpy scalars and arrays
        value = value.tolist()
    return json.dumps(value, default=str)


def _params_model(node: Behaviour) -> Any | None:
    params = getattr(node, "params", None)
    return params if hasattr(type(params), "model_fields") and hasattr(params, "model_dump") else None


def _ports(node: Behaviour) -> dict[str, Any]:
    custom = getattr(node, "btcpp_ports", None)
    if callable(custom):
        return dict(custom())
    params = _params_model(node)
    ports = params.model_dump() if params is not None else {}
    robot = getattr(node, "robot_name", None)
    if isinstance(robot, str):
        ports["robot"] = robot
    return ports


def _builtin(node: Behaviour) -> tuple[str, dict[str, Any]] | None:
    """BehaviorTree.CPP built-in (tag, ports) equivalent to ``node``, or ``None``."""
    tag = getattr(type(node), "btcpp_tag", None)
    if tag:
        return str(tag), _ports(node)
    return _builtin_control(node) or _builtin_decorator(node) or _builtin_leaf(node)


def _builtin_control(node: Behaviour) -> tuple[str, dict[str, Any]] | None:
    """The BehaviorTree.CPP control node (tag, ports) of a py_trees sequence, selector or parallel, else ``None``."""
    c = py_trees.composites
    if isinstance(node, c.Sequence):
        return ("Sequence" if node.memory else "ReactiveSequence"), {}
    if isinstance(node, c.Selector):
        return ("Fallback" if node.memory else "ReactiveFallback"), {}
    if isinstance(node, c.Parallel):
        policy = node.policy
        if isinstance(policy, ParallelPolicy.SuccessOnOne):
            success = 1
        elif isinstance(policy, ParallelPolicy.SuccessOnSelected):
            success = len(policy.children)
        else:
            success = -1
        return "Parallel", {"success_count": success, "failure_count": 1}
    return None


def _builtin_decorator(node: Behaviour) -> tuple[str, dict[str, Any]] | None:
    """The BehaviorTree.CPP decorator (tag, ports) of a py_trees decorator, else ``None``."""
    d = py_trees.decorators
    if isinstance(node, d.Inverter):
        return "Inverter", {}
    if isinstance(node, d.Repeat):
        return "Repeat", {"num_cycles": node.num_success}
    if isinstance(node, d.Retry):
        return "RetryUntilSuccessful", {"num_attempts": node.num_failures}
    if isinstance(node, d.Timeout):
        return "Timeout", {"msec": int(round(node.duration * 1000.0))}
    if isinstance(node, d.FailureIsSuccess):
        return "ForceSuccess", {}
    if isinstance(node, d.SuccessIsFailure):
        return "ForceFailure", {}
    if isinstance(node, d.OneShot):
        return "RunOnce", {"then_skip": False}
    return None


def _builtin_leaf(node: Behaviour) -> tuple[str, dict[str, Any]] | None:
    """``AlwaysSuccess`` or ``AlwaysFailure`` for py_trees' plain success and failure leaves, else ``None``."""
    b = py_trees.behaviours
    if type(node) is b.Success:
        return "AlwaysSuccess", {}
    if type(node) is b.Failure:
        return "AlwaysFailure", {}
    return None


def _model_kind(node: Behaviour) -> str:
    """TreeNodesModel element of a custom node: Action, Condition, Decorator or Control."""
    if isinstance(node, py_trees.decorators.Decorator):
        return "Decorator"
    if isinstance(node, py_trees.composites.Composite):
        return "Control"
    kind = getattr(node, "btcpp_kind", None)
    if kind is None:
        kind = "Condition" if isinstance(node, _CONDITION_LEAVES) else "Action"
    if kind not in ("Action", "Condition"):
        raise ValueError(
            f"{type(node).__name__}.btcpp_kind must be 'Action' or 'Condition', got {kind!r}"
        )
    return kind


def _declare(model: ET.Element, declared: set[str], tag: str, node: Behaviour) -> None:
    """Add ``tag`` to the TreeNodesModel (once), with the input ports of its parameter model."""
    if tag in declared or tag in BTCPP_BUILTINS:
        return
    declared.add(tag)
    entry = ET.SubElement(model, _model_kind(node), ID=tag)
    params = _params_model(node)
    fields = type(params).model_fields if params is not None else {}
    for name, info in fields.items():
        annotation = info.annotation
        type_name = {float: "double", int: "int", bool: "bool", str: "std::string"}.get(
            annotation, getattr(annotation, "__name__", str(annotation))
        )
        port = ET.SubElement(entry, "input_port", name=name, type=type_name)
        if not info.is_required() and info.default_factory is None and info.default is not None:
            port.set("default", _port_text(info.default))
        port.text = info.description or ""
    if hasattr(node, "robot_name"):
        ET.SubElement(entry, "input_port", name="robot", type="std::string").text = "team robot the node acts on"


def to_btcpp_xml(
    tree: Behaviour | py_trees.trees.BehaviourTree,
    tree_id: str = "MainTree",
    with_uids: bool = False,
) -> str:
    """BehaviorTree.CPP v4 XML text of a py_trees tree (see the module docstring for the mapping).

    Args:
        tree: the root behaviour, or a ``BehaviourTree``.
        tree_id: ``ID`` of the ``<BehaviorTree>`` (also ``main_tree_to_execute``).
        with_uids: write each node's pre-order number as a ``_uid`` attribute
            (what live viewers match status events against).
    """
    nodes = walk(tree)
    uid_of = {id(node): uid for uid, node in enumerate(nodes, start=1)}
    root_el = ET.Element("root", BTCPP_format="4", main_tree_to_execute=tree_id)
    tree_el = ET.SubElement(root_el, "BehaviorTree", ID=tree_id)
    model = ET.Element("TreeNodesModel")
    declared: set[str] = set()

    def emit(node: Behaviour, parent: ET.Element) -> None:
        builtin = _builtin(node)
        if builtin is None:
            tag, ports = type(node).__name__, _ports(node)
            _declare(model, declared, tag, node)
        else:
            tag, ports = builtin
        element = ET.SubElement(parent, tag, name=node.name)
        for key, value in ports.items():
            element.set(str(key), _port_text(value))
        if with_uids:
            element.set("_uid", str(uid_of[id(node)]))
        for child in node.children:
            emit(child, element)

    emit(nodes[0], tree_el)
    root_el.append(model)
    ET.indent(root_el, space="  ")
    return ET.tostring(root_el, encoding="unicode") + "\n"


class TreeTracker:
    """Follows a tree's statuses from tick to tick, for the log (:class:`~marsupial.api.ticks.TreeStatus`)."""

    def __init__(self) -> None:
        self._walked: list[Behaviour] = []
        self._statuses: tuple[str, ...] = ()

    def status(self, tree: Behaviour | py_trees.trees.BehaviourTree) -> TreeStatus | None:
        """The nodes' statuses if they changed since the last call (with names and XML when the structure did)."""
        nodes = walk(tree)
        statuses = tuple(STATUS_NAMES[node.status] for node in nodes)
        fresh = nodes != self._walked  # list equality compares nodes by identity
        if not fresh and statuses == self._statuses:
            return None
        self._statuses = statuses
        if not fresh:
            return TreeStatus(statuses)
        self._walked = nodes
        return TreeStatus(statuses, tuple(node.name for node in nodes), to_btcpp_xml(nodes[0], with_uids=True))
