"""BehaviorTree.CPP v4 XML export of py_trees trees (Groot2 / Foxglove behaviour-tree panels)."""

import xml.etree.ElementTree as ET

import py_trees
import pytest
from py_trees.common import ParallelPolicy
from pydantic import BaseModel, Field

from marsupial.trees.btxml import root_of, status_name, to_btcpp_xml, walk


class Leaf(py_trees.behaviour.Behaviour):
    def update(self):
        return py_trees.common.Status.RUNNING


class DriveTo(Leaf):
    """A leaf with typed parameters and a robot, as mission skills have."""

    class Params(BaseModel):
        goal: list[float] = Field(default_factory=lambda: [0.0, 0.0])
        speed: float = Field(0.5, description="cruise speed (m/s)")
        label: str = Field(..., description="where to")

    def __init__(self, name, robot):
        super().__init__(name)
        self.params = self.Params(goal=[1.0, 2.0], label="dock")
        self.robot_name = robot


class BatteryLow(Leaf):
    btcpp_kind = "Condition"


class PassOn(py_trees.decorators.Decorator):
    def update(self):
        return self.decorated.status


class SimTimeout(PassOn):
    btcpp_tag = "Timeout"

    def __init__(self, name, child, seconds):
        super().__init__(name=name, child=child)
        self.seconds = seconds

    def btcpp_ports(self):
        return {"msec": int(self.seconds * 1000)}


class Until(PassOn):
    """A custom decorator without a BehaviorTree.CPP equivalent."""


def small_tree():
    c, d, b = py_trees.composites, py_trees.decorators, py_trees.behaviours
    return c.Sequence(
        "mission",
        memory=True,
        children=[
            d.Retry("retry", DriveTo("to dock", "carrier"), num_failures=3),
            c.Selector(
                "priorities",
                memory=False,
                children=[
                    c.Sequence("guard", memory=False, children=[BatteryLow("low"), b.Success("ok")]),
                    c.Parallel(
                        "both",
                        policy=ParallelPolicy.SuccessOnOne(),
                        children=[
                            d.Repeat("again", b.Running("spin"), num_success=-1),
                            d.Inverter("not", b.Failure("no")),
                        ],
                    ),
                ],
            ),
            d.Timeout("limit", SimTimeout("sim limit", Until("until", DriveTo("back", "uav")), 2.5), duration=1.5),
        ],
    )


def test_xml_structure_maps_py_trees_nodes_to_btcpp_builtins():
    root = small_tree()
    doc = ET.fromstring(to_btcpp_xml(root, tree_id="Demo"))
    assert doc.tag == "root" and doc.get("BTCPP_format") == "4" and doc.get("main_tree_to_execute") == "Demo"
    (bt,) = doc.findall("BehaviorTree")
    assert bt.get("ID") == "Demo"
    (top,) = list(bt)
    assert (top.tag, top.get("name")) == ("Sequence", "mission")
    retry, priorities, limit = list(top)
    assert (retry.tag, retry.get("num_attempts")) == ("RetryUntilSuccessful", "3")
    (drive,) = list(retry)
    assert drive.tag == "DriveTo" and drive.get("name") == "to dock"
    assert drive.get("speed") == "0.5" and drive.get("goal") == "[1.0, 2.0]" and drive.get("label") == "dock"
    assert drive.get("robot") == "carrier"
    assert priorities.tag == "ReactiveFallback"
    guard, both = list(priorities)
    assert guard.tag == "ReactiveSequence" and [n.tag for n in guard] == ["BatteryLow", "AlwaysSuccess"]
    assert (both.tag, both.get("success_count"), both.get("failure_count")) == ("Parallel", "1", "1")
    again, inverter = list(both)
    assert (again.tag, again.get("num_cycles")) == ("Repeat", "-1")
    assert inverter.tag == "Inverter" and list(inverter)[0].tag == "AlwaysFailure"
    assert (limit.tag, limit.get("msec")) == ("Timeout", "1500")
    (sim,) = list(limit)
    assert (sim.tag, sim.get("msec"), sim.get("name")) == ("Timeout", "2500", "sim limit")
    assert list(sim)[0].tag == "Until"
    assert not any(e.get("_uid") for e in doc.iter())  # uids only on request


def test_tree_nodes_model_declares_each_custom_node_once():
    doc = ET.fromstring(to_btcpp_xml(small_tree()))
    model = doc.find("TreeNodesModel")
    declared = {(e.tag, e.get("ID")) for e in model}
    assert declared == {
        ("Action", "DriveTo"),
        ("Condition", "BatteryLow"),
        ("Decorator", "Until"),
        ("Action", "Running"),
    }
    assert len(list(model)) == 4  # DriveTo is used twice, declared once
    ports = {p.get("name"): p for p in model.find("Action[@ID='DriveTo']")}
    assert set(ports) == {"goal", "speed", "label", "robot"}
    speed = ports["speed"]
    assert (speed.get("type"), speed.get("default"), speed.text) == ("double", "0.5", "cruise speed (m/s)")
    assert ports["label"].get("default") is None and ports["goal"].get("default") is None


def test_uids_number_nodes_in_depth_first_preorder():
    root = small_tree()
    nodes = walk(root)
    assert nodes[0] is root and len(nodes) == 16
    doc = ET.fromstring(to_btcpp_xml(root, with_uids=True))
    elements = [e for e in doc.find("BehaviorTree").iter() if e.tag != "BehaviorTree"]
    assert [int(e.get("_uid")) for e in elements] == list(range(1, 17))
    assert [e.get("name") for e in elements] == [n.name for n in nodes]
    # the same numbering through a BehaviourTree wrapper
    assert walk(py_trees.trees.BehaviourTree(root)) == nodes


def test_statuses_and_bad_input():
    assert [status_name(s) for s in py_trees.common.Status] == ["SUCCESS", "FAILURE", "RUNNING", "IDLE"]
    with pytest.raises(TypeError, match="py_trees Behaviour or BehaviourTree"):
        root_of("not a tree")

    class Odd(Leaf):
        btcpp_kind = "Script"

    with pytest.raises(ValueError, match="Odd.btcpp_kind must be 'Action' or 'Condition'"):
        to_btcpp_xml(Odd("odd"))
