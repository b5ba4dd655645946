"""Bad mission input: each error names file:line:column, the key path, what was expected and the closest name."""

from pathlib import Path

import pytest

from marsupial.trees.errors import MissionError, MissionErrors, format_key_path, suggest
from marsupial.trees.mission import display_path, load_mission, parse_mission

ALL_NODES = Path(__file__).parent / "data" / "missions" / "all_nodes.yaml"
SHOWN = display_path(ALL_NODES)  # how error messages name the file


def error_of(text: str, **kwargs) -> MissionError:
    with pytest.raises(MissionError) as caught:
        parse_mission(text, "bad.yaml", **kwargs)
    return caught.value


def test_error_text_has_location_key_path_expectation_and_suggestion():
    error = MissionError("unknown key 'tre'", "m.yaml", 3, 1, ("tree", "sequence", 2), "a node", "tree")
    assert str(error) == "m.yaml:3:1: tree.sequence[2]: unknown key 'tre'; expected a node; did you mean 'tree'?"
    assert str(MissionError("no such file")) == "no such file"
    assert format_key_path(("team", "uav", "pose", 0)) == "team.uav.pose[0]"
    assert suggest("sequense", ["selector", "sequence"]) == "sequence" and suggest("zzz", ["sequence"]) is None


def test_malformed_yaml_gives_the_parser_position():
    error = error_of("mission: m\ntree: {skill: wait\nteam: {}\n")
    assert str(error).startswith("bad.yaml:3:5: malformed YAML: expected ',' or '}'")


def test_tab_indentation_is_reported_with_its_position():
    error = error_of("mission: m\ntree:\n\tskill: wait\n")
    assert error.location == "bad.yaml:3:1" and "tabs" in str(error)


def test_duplicate_key_names_both_lines():
    error = error_of("mission: m\ntree: {skill: a}\nworld: {seed: 1}\ntree: {skill: b}\n")
    assert str(error) == ("bad.yaml:4:1: tree: duplicate key 'tree' (first defined on line 2); "
                          "expected each key once per mapping")


def test_unknown_top_level_key_suggests_the_closest():
    error = error_of("mission: m\ntree: {skill: wait}\nplugin: {}\n")
    assert str(error) == ("bad.yaml:3:1: plugin: unknown key 'plugin'; expected one of description, mission, "
                          "operator, params, plugins, run, team, tree, world; did you mean 'plugins'?")


def test_unknown_key_in_a_node_suggests_the_closest():
    error = error_of("mission: m\ntree:\n  sequence:\n    - {skill: wait, robt: uav}\n")
    assert error.location == "bad.yaml:4:21" and error.key_path == ("tree", "sequence", 0, "robt")
    assert error.suggestion == "robot" and "expected one of name, params, robot, skill" in str(error)


def test_unknown_node_type_suggests_the_closest():
    error = error_of("mission: m\ntree:\n  sequence:\n    - skill: wait\n    - sequense:\n        - skill: hover\n")
    assert str(error).startswith(
        "bad.yaml:5:7: tree.sequence[1].sequense: unknown node type 'sequense'; expected one of"
    )
    assert str(error).endswith("did you mean 'sequence'?")


def test_node_with_two_types_or_none():
    assert "found 'sequence', 'skill'" in str(error_of("mission: m\ntree: {skill: a, sequence: [{skill: b}]}\n"))
    error = error_of("mission: m\ntree:\n  sequence:\n    - wait\n")
    assert error.location == "bad.yaml:4:7" and "expected a node, got 'wait'" in str(error)


def test_wrong_type_names_the_expected_type():
    error = error_of("mission: m\ntree:\n  retry: {skill: wait}\n  times: three\n")
    assert str(error) == "bad.yaml:4:3: tree.times: invalid value 'three'; expected an integer"
    error = error_of("mission: m\ntree: {parallel: [{skill: a}], success_on: any}\n")
    assert str(error) == "bad.yaml:2:32: tree.success_on: invalid value 'any'; expected 'all' or 'one'"
    error = error_of("mission: m\ntree: {timeout: {skill: a}, seconds: -2}\n")
    assert error.key_path == ("tree", "seconds") and error.expected == "a value > 0"


def test_missing_required_key_names_it_and_its_type():
    error = error_of("mission: m\ntree:\n  - retry: {skill: wait}\n")
    assert "expected a node" in str(error)
    error = error_of("mission: m\ntree:\n  sequence:\n    - retry: {skill: wait}\n")
    assert str(error) == "bad.yaml:4:7: tree.sequence[0].times: missing required key 'times'; expected an integer"
    error = error_of("tree: {skill: wait}\n")
    assert str(error) == "bad.yaml:1:1: mission: missing required key 'mission'; expected a string"


def test_guards_need_exactly_one_condition_key():
    error = error_of("mission: m\ntree:\n  priorities:\n    - when: {operator: dock, robt: uav}\n"
                     "      do: {skill: a}\n    - do: {skill: b}\n")
    assert error.location == "bad.yaml:4:7" and error.key_path == ("tree", "priorities", 0, "when")
    assert "found 'operator', 'robt'" in str(error) and error.suggestion == "robot"
    error = error_of("mission: m\ntree:\n  priorities:\n    - do: {skill: a}\n    - do: {skill: b}\n")
    assert str(error) == ("bad.yaml:4:7: tree.priorities[0]: only the last entry of priorities may omit 'when'; "
                          "expected a 'when:' guard on this entry")


def test_unknown_robot_and_carrier_suggest_team_members():
    team = "team:\n  carrier: {robot: mobile_manipulator}\n  uav: {robot: bebop2, stored_on: carier}\n"
    error = error_of(f"mission: m\n{team}tree: {{skill: a}}\n")
    assert error.location == "bad.yaml:4:24" and error.suggestion == "carrier"
    team = team.replace("carier", "carrier")
    error = error_of(f"mission: m\n{team}tree:\n  priorities:\n    - when: {{battery_below: 0.2, robot: uva}}\n"
                     "      do: {skill: land, robot: uav}\n    - do: {skill: explore, robot: uav}\n")
    assert str(error) == ("bad.yaml:7:34: tree.priorities[0].when.robot: unknown robot 'uva'; "
                          "expected a team member (one of carrier, uav); did you mean 'uav'?")


def test_unknown_reference_suggests_a_parameter():
    error = error_of("mission: m\nparams: {height: 2}\ntree:\n  skill: goto\n  params: {z: '${heigth}'}\n")
    assert str(error) == ("bad.yaml:5:12: tree.params.z: unknown parameter reference '${heigth}'; "
                          "expected a parameter (height); did you mean 'height'?")


def test_bad_plugin_reference():
    error = error_of("mission: m\nplugins: {land: my_pkg.landing}\ntree: {skill: land}\n")
    assert str(error) == "bad.yaml:2:11: plugins.land: malformed plugin reference; expected 'package.module:Class'"


def test_several_errors_are_reported_together_in_file_order():
    error = error_of("mission: m\nrun: {tick_hz: fast}\nworld: {sed: 1}\ntree: {skill: a}\n")
    assert isinstance(error, MissionErrors) and len(error.errors) == 2
    assert [e.location for e in error.errors] == ["bad.yaml:2:7", "bad.yaml:3:9"]
    assert str(error).splitlines()[1].endswith("did you mean 'seed'?")


def test_not_a_mapping():
    assert str(error_of("- a\n- b\n")).startswith("bad.yaml:1:1: a mission must be a mapping")
    assert str(error_of("")).startswith("bad.yaml:1:1: a mission must be a mapping")


def test_bad_overrides_list_close_names():
    with pytest.raises(MissionError) as caught:
        load_mission(ALL_NODES, {"cruise_hieght": "3"})
    assert "'cruise_hieght' is not a mission parameter" in str(caught.value)
    assert caught.value.suggestion == "cruise_height"
    with pytest.raises(MissionError) as caught:
        load_mission(ALL_NODES, {"world.sed": "3"})
    assert str(caught.value) == (
        f"{SHOWN}: --set world.sed=3: unknown key 'world.sed'; "
        "expected one of world.disturbances, world.scene, world.seed, world.sensing; did you mean 'world.seed'?"
    )


def test_an_override_reaches_a_node_of_the_tree_by_its_index():
    # the path walks the data as written: tree.sequence is the node's list of children (it raised a TypeError)
    from marsupial.trees.mission.overrides import apply_overrides

    data = {"mission": "m", "tree": {"sequence": [{"skill": "wait"}, {"skill": "goto", "name": "go"}]}}
    apply_overrides(data, {"tree.sequence.1.params": "{x: 2}"})
    assert data["tree"]["sequence"][1] == {"skill": "goto", "name": "go", "params": {"x": 2}}
    with pytest.raises(MissionError, match="unknown key 'tree.sequence.sequence'; expected one of tree.sequence.0, "
                                           "tree.sequence.1"):
        apply_overrides(data, {"tree.sequence.sequence.1.params": "{x: 2}"})


def test_override_with_a_wrong_type_points_at_the_key_and_names_the_override():
    with pytest.raises(MissionError) as caught:
        load_mission(ALL_NODES, {"world.seed": "abc"})
    assert str(caught.value) == (f"{SHOWN}:3:28: world.seed: invalid value 'abc'; expected an integer\n"
                                 "  value set by --set world.seed=abc")


def test_missing_mission_file_lists_known_missions(tmp_path):
    with pytest.raises(MissionError) as caught:
        load_mission(tmp_path / "nowhere.yaml")
    assert f"mission file '{tmp_path / 'nowhere.yaml'}' not found" in str(caught.value)
    assert "a path to a mission .yaml file" in str(caught.value)


def test_unknown_reference_does_not_hide_other_errors():
    error = error_of("mission: m\nparmas: {h: 2}\ntree: {retry: {skill: goto, params: {z: '${h}'}}, times: '${n}'}\n")
    assert isinstance(error, MissionErrors)
    assert [(e.location, e.message) for e in error.errors] == [
        ("bad.yaml:2:1", "unknown key 'parmas'"),
        ("bad.yaml:3:38", "unknown parameter reference '${h}'"),
        ("bad.yaml:3:51", "unknown parameter reference '${n}'"),
    ]


def test_a_list_too_short_for_its_tuple_names_what_was_expected():
    from marsupial.trees.compiler import compile_mission

    text = "mission: m\nteam:\n  uav: {robot: bebop2}\ntree: {skill: goto, robot: uav, params: {target: [2, 0]}}\n"
    with pytest.raises(MissionError) as caught:
        compile_mission(parse_mission(text, "bad.yaml"))
    assert str(caught.value) == "bad.yaml:4:42: tree.params.target: 2 items given; expected a list of 3 numbers"
