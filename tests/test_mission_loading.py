"""Mission files that are valid: every node type, defaults, key paths, overrides, lookup, JSON Schema."""

from pathlib import Path

import pytest
import yaml

from marsupial.trees.errors import MissionError
from marsupial.trees.mission import (
    ConditionNode,
    Guard,
    InvertNode,
    ParallelNode,
    PrioritiesNode,
    RepeatNode,
    RetryNode,
    SelectorNode,
    SequenceNode,
    SkillNode,
    TimeoutNode,
    UntilNode,
    display_path,
    find_mission,
    load_mission,
    mission_schema,
    parse_mission,
)
from marsupial.trees.mission import loading as mission_module
from marsupial.trees.yaml_source import load_yaml, parse_scalar

DATA = Path(__file__).parent / "data" / "missions"
ALL_NODES = DATA / "all_nodes.yaml"
SHOWN = display_path(ALL_NODES)  # how error messages name the file


def test_every_node_type_loads_nested_with_its_fields():
    m = load_mission(ALL_NODES)
    spec = m.spec
    assert m.name == "all_nodes" and m.path == ALL_NODES and m.text == ALL_NODES.read_text()
    assert (spec.world.scene, spec.world.seed) == ("open_field", 7)
    assert spec.world.disturbances.given() == {"wind": {"gust": 2.0}}  # what the file says ...
    assert spec.world.disturbances.wind is not None and spec.world.disturbances.wind.gust_period_s == 2.0  # ... typed
    assert spec.team["uav"].stored_on == "carrier" and spec.team["carrier"].pose == [0.0, 0.0, 0.0]
    assert spec.operator[0].say == "dock" and spec.operator[0].why == "corridor ahead"
    assert spec.plugins == {"land": "my_pkg.landing:SoftLand"}
    assert (spec.run.tick_hz, spec.run.until) == (20.0, 120.0)

    root = spec.tree
    assert isinstance(root, ParallelNode) and root.success_on == "one"
    idle, prio = root.parallel
    assert isinstance(idle, SkillNode) and idle.name == "idle carrier" and idle.params == {"seconds": 1}
    assert isinstance(prio, PrioritiesNode) and len(prio.priorities) == 3
    dock, battery, default = prio.priorities
    assert [(g.condition, g.argument) for g in dock.when] == [("operator", "dock")]
    assert [(g.condition, g.argument, g.robot) for g in battery.when] == [
        ("battery_below", 0.2, "uav"), ("timer", 30, None)]
    assert default.when == []
    seq = default.do
    assert isinstance(seq, SequenceNode) and seq.memory is False
    selector, repeat, timeout, until = seq.sequence
    assert isinstance(selector, SelectorNode) and selector.memory is False
    cond, retry = selector.selector
    assert isinstance(cond, ConditionNode) and cond.params == {"fraction": 0.9} and cond.robot == "uav"
    assert isinstance(retry, RetryNode) and retry.times == 3  # "${attempts}" keeps the int type
    assert isinstance(repeat, RepeatNode) and repeat.times == 2 and isinstance(repeat.repeat, InvertNode)
    assert isinstance(timeout, TimeoutNode) and timeout.seconds == 4.5
    assert isinstance(until, UntilNode) and (until.condition.condition, until.condition.argument) == ("timer", 3)
    assert [n.kind for n in m.nodes()].count("subtree") == 0  # inlined


def test_defaults_of_nodes_and_sections():
    m = parse_mission("mission: m\ntree:\n  sequence:\n    - {selector: [{skill: a}]}\n"
                      "    - {parallel: [{skill: b}]}\n    - {repeat: {skill: c}}\n")
    seq = m.spec.tree
    assert seq.memory is True
    selector, parallel, repeat = seq.sequence
    assert selector.memory is False and parallel.success_on == "all" and repeat.times == -1
    assert (m.spec.world.scene, m.spec.world.seed, m.spec.run.tick_hz, m.spec.run.until) == (None, 0, 10.0, None)
    assert m.spec.team == {} and m.spec.operator == [] and m.spec.params == {}


def test_every_node_and_guard_knows_where_it_was_written():
    m = load_mission(ALL_NODES)
    land = next(n for n in m.nodes() if isinstance(n, SkillNode) and n.skill == "land")
    assert land.key_path == ("tree", "parallel", 1, "priorities", 1, "do")
    error = m.error_at(land.key_path + ("skill",), "unknown skill 'land'", expected="a skill", suggestion="hover")
    assert str(error) == (f"{SHOWN}:19:16: tree.parallel[1].priorities[1].do.skill: unknown skill 'land'; "
                          "expected a skill; did you mean 'hover'?")
    prio = m.spec.tree.parallel[1]
    single, listed = prio.priorities[0].when[0], prio.priorities[1].when[1]
    assert single.key_path == ("tree", "parallel", 1, "priorities", 0, "when")
    assert listed.key_path == ("tree", "parallel", 1, "priorities", 1, "when", 1)
    assert m.error_at(listed.key_path + (listed.condition,), "x").line == 18
    until = next(n for n in m.nodes() if isinstance(n, UntilNode))
    assert m.error_at(until.condition, "bad guard").location == f"{SHOWN}:31:17"


def test_validation_error_of_skill_params_points_into_the_node():
    from pydantic import BaseModel, ConfigDict, ValidationError

    class Params(BaseModel):
        model_config = ConfigDict(extra="forbid")
        seconds: float = 1.0

    m = load_mission(ALL_NODES)
    idle = m.spec.tree.parallel[0]
    with pytest.raises(ValidationError) as caught:
        Params.model_validate({"secnds": 2})
    error = m.validation_error(caught.value, idle.key_path + ("params",), Params)
    assert str(error).startswith(f"{SHOWN}:14:41: tree.parallel[0].params.secnds: unknown key 'secnds'")
    assert error.suggestion == "seconds"


def test_overrides_set_params_world_run_and_items():
    m = load_mission(ALL_NODES, {"params.cruise_height": "3.5", "world.seed": "9", "run.until": "60",
                                 "attempts": "5", "team.carrier.pose.2": "0.25"})
    assert m.spec.params == {"cruise_height": 3.5, "attempts": 5}
    assert (m.spec.world.seed, m.spec.run.until, m.spec.team["carrier"].pose) == (9, 60.0, [0.0, 0.0, 0.25])
    retry = next(n for n in m.nodes() if isinstance(n, RetryNode))
    goto = next(n for n in m.nodes() if isinstance(n, SkillNode) and n.skill == "goto")
    assert retry.times == 5 and goto.params["target"] == [0, 0, 3.5]  # overrides apply before ${} substitution
    assert m.overrides["world.seed"] == "9"


def test_override_of_a_section_left_out_of_the_file():
    m = parse_mission("mission: m\ntree: {skill: wait}\n", overrides={"run.until": "30", "world.scene": "open_field"})
    assert (m.spec.run.until, m.spec.world.scene) == (30.0, "open_field")


def test_scalars_follow_yaml_1_2():
    doc = load_yaml("a: yes\nb: no\nc: on\nd: true\ne: 1e3\nf: 2.5\ng: 7\nh: ~\n")
    assert doc.data == {"a": "yes", "b": "no", "c": "on", "d": True, "e": 1000.0, "f": 2.5, "g": 7, "h": None}
    scalars = ("3.5", "false", "[1, 2]", "hover", "a: b: c")
    assert [parse_scalar(v) for v in scalars] == [3.5, False, [1, 2], "hover", "a: b: c"]


def test_positions_are_one_based_key_starts():
    doc = load_yaml("top:\n  list:\n    - {a: 1}\n    - b\n")
    assert doc.locate(("top",)) == (1, 1)
    assert doc.locate(("top", "list", 0, "a")) == (3, 8)
    assert doc.locate(("top", "list", 1)) == (4, 7)
    assert doc.locate(("top", "list", 5, "x")) == (2, 3)  # nearest existing ancestor


def test_missions_are_found_by_package_name_or_path(tmp_path, monkeypatch):
    (tmp_path / "patrol.yaml").write_text("mission: patrol\ntree: {skill: wait}\n")
    monkeypatch.setattr(mission_module, "mission_dir", lambda: tmp_path)
    assert load_mission("patrol").name == "patrol"
    assert find_mission(tmp_path / "patrol.yaml") == tmp_path / "patrol.yaml"
    with pytest.raises(MissionError) as caught:
        load_mission("patroll")
    assert "unknown mission 'patroll'" in str(caught.value)
    assert "a mission name (patrol)" in str(caught.value) and "did you mean 'patrol'?" in str(caught.value)


def test_json_schema_describes_missions_and_accepts_a_valid_one():
    schema = mission_schema()
    defs = schema["$defs"]
    assert schema["$schema"].endswith("2020-12/schema")
    assert set(schema["properties"]) == {"mission", "description", "world", "team", "operator", "plugins",
                                         "params", "run", "tree"}
    assert schema["properties"]["tree"]["$ref"] == "#/$defs/Node"
    assert len(defs["Node"]["oneOf"]) == 15
    assert defs["SequenceNode"]["additionalProperties"] is False
    assert defs["ParallelNode"]["properties"]["success_on"]["enum"] == ["all", "one"]
    assert {"$ref": "#/$defs/Guard"} in defs["PriorityEntry"]["properties"]["when"]["anyOf"]
    jsonschema = pytest.importorskip("jsonschema")
    validator = jsonschema.Draft202012Validator(schema)
    data = yaml.safe_load(ALL_NODES.read_text())
    data["tree"]["parallel"][1]["priorities"][2]["do"]["sequence"][0]["selector"][1]["times"] = 3  # no ${} in ints
    validator.validate(data)
    data["tree"]["parallel"][0] = {"sequense": [{"skill": "wait"}]}
    assert not validator.is_valid(data)


def test_guard_exposes_condition_argument_robot_and_params():
    guard = Guard.model_validate({"battery_below": 0.2, "robot": "uav", "params": {"hysteresis": 0.05}})
    assert (guard.condition, guard.argument, guard.robot, guard.params) == (
        "battery_below", 0.2, "uav", {"hysteresis": 0.05})
