"""Subtrees: inlining with parameters, ${name} substitution, positions inside subtree files, cycles."""

from pathlib import Path

import pytest

import marsupial.missions
from marsupial.trees.errors import MissionError
from marsupial.trees.mission import SequenceNode, SkillNode, display_path, load_mission, parse_mission
from marsupial.trees.subtrees import known_subtrees, resolve_references
from marsupial.trees.yaml_source import load_yaml

DATA = Path(__file__).parent / "data" / "missions"
SUBTREES = DATA / "subtrees"
TEAM = "team: {uav: {robot: bebop2}}\n"


def mission_here(text: str) -> object:
    """Parse ``text`` as if it were a file in tests/data/missions/ (so its subtrees/ folder is searched)."""
    return parse_mission(text, "here.yaml", path=DATA / "here.yaml")


def error_of(text: str) -> MissionError:
    with pytest.raises(MissionError) as caught:
        mission_here(text)
    return caught.value


def test_substitution_keeps_types_formats_strings_and_escapes_dollars():
    doc = load_yaml("a: '${h}'\nb: 'at ${h} m by ${who}'\nc: ['${xs}', '$${h}']\nd: 4\n")
    resolved = resolve_references(doc.data, {"h": 1.5, "who": "uav", "xs": [1, 2]}, doc, origins={"h": "set at x"})
    assert resolved.data == {"a": 1.5, "b": "at 1.5 m by uav", "c": [[1, 2], "${h}"], "d": 4}
    assert resolved.notes[("a",)] == "'${h}' set at x" and resolved.unknown == []
    assert doc.data["a"] == "${h}"  # the source is left as written
    unknown = resolve_references({"z": "${hh}"}, {"h": 1}, doc).unknown
    assert len(unknown) == 1 and unknown[0].suggestion == "h"


def test_subtree_is_inlined_with_defaults_and_arguments():
    m = mission_here(f"mission: m\n{TEAM}tree:\n  subtree: go_and_hover\n  params: {{robot: uav, target: [1, 2, 3]}}\n")
    root = m.spec.tree
    assert isinstance(root, SequenceNode) and root.name == "go_and_hover"
    goto, hover = root.sequence
    assert (goto.skill, goto.robot, goto.params) == ("goto", "uav", {"target": [1, 2, 3], "speed": 1.0})
    assert (hover.skill, hover.params) == ("hover", {"seconds": 2.0})


def test_nested_subtrees_keep_positions_in_their_own_files():
    m = load_mission(DATA / "all_nodes.yaml")
    inspect = m.spec.tree.parallel[1].priorities[0].do
    assert inspect.name == "inspect"
    goto_inner = inspect.sequence[1].sequence[0]
    assert isinstance(goto_inner, SkillNode) and goto_inner.params["target"] == [1, 0, 2.5]
    error = m.error_at(goto_inner.key_path + ("params", "speed"), "invalid value 'x'", expected="a number")
    lines = str(error).splitlines()
    assert lines[0].endswith("subtrees/go_and_hover.yaml:10:70: tree.sequence[0].params.speed: "
                             "invalid value 'x'; expected a number")
    assert "in subtree 'go_and_hover' included at " in lines[1] and "inspect.yaml:7:7" in lines[1]
    assert f"in subtree 'inspect' included at {display_path(DATA / 'all_nodes.yaml')}:17:16" in lines[1]


def test_subtree_by_relative_path_and_include_name():
    m = mission_here(f"mission: m\n{TEAM}tree: {{subtree: subtrees/inspect.yaml, name: look, params: {{height: 4}}}}\n")
    assert m.spec.tree.name == "look"
    assert m.spec.tree.sequence[0].params == {"target": [0, 0, 4], "note": "at 4 m"}


def test_mission_params_are_visible_inside_subtrees(tmp_path):
    (tmp_path / "subtrees").mkdir()
    (tmp_path / "subtrees" / "climb.yaml").write_text(
        "subtree: climb\nparams: {rate: 0.5}\ntree: {skill: goto, params: {z: '${cruise}', rate: '${rate}'}}\n")
    m = parse_mission("mission: m\nparams: {cruise: 3.0, rate: 9}\ntree: {subtree: climb}\n", path=tmp_path / "m.yaml")
    assert m.spec.tree.params == {"z": 3.0, "rate": 0.5}  # the subtree's own parameter wins


def test_include_cycle_names_the_chain_and_the_include_line():
    with pytest.raises(MissionError) as caught:
        load_mission(DATA / "cycle.yaml")
    first, note = str(caught.value).splitlines()
    assert first.endswith("cycle_b.yaml:5:7: tree.selector[1].subtree: subtree include cycle: "
                          "cycle_a -> cycle_b -> cycle_a; expected subtrees that do not include themselves")
    assert "in subtree 'cycle_b' included at" in note and f"{display_path(DATA / 'cycle.yaml')}:5:8" in note


def test_missing_subtree_lists_known_ones_and_suggests():
    error = error_of("mission: m\ntree:\n  sequence:\n    - {subtree: inspct}\n")
    assert error.location == "here.yaml:4:8" and error.suggestion == "inspect"
    assert "subtree 'inspct' not found" in str(error) and "go_and_hover" in error.expected
    assert "go_and_hover" in known_subtrees()


def test_unknown_subtree_parameter_suggests_a_declared_one():
    error = error_of(f"mission: m\n{TEAM}tree: {{subtree: inspect, params: {{heigth: 3}}}}\n")
    assert str(error) == ("here.yaml:3:35: tree.params.heigth: unknown parameter 'heigth' of subtree 'inspect'; "
                          "expected a declared parameter (one of height, uav); did you mean 'height'?")


def test_missing_required_subtree_parameter():
    error = error_of(f"mission: m\n{TEAM}tree: {{subtree: go_and_hover, params: {{robot: uav}}}}\n")
    declared = display_path(Path(marsupial.missions.__file__).parent / "subtrees" / "go_and_hover.yaml")
    assert str(error) == ("here.yaml:3:31: tree.params: subtree 'go_and_hover' needs parameter target; "
                          f"expected params with target (declared required: target at {declared}:5:3)")


def test_errors_inside_a_subtree_point_into_its_file(tmp_path):
    error = error_of("mission: m\ntree: {subtree: bad_times}\n")
    first, note = str(error).splitlines()
    assert first.endswith("bad_times.yaml:5:3: tree.times: invalid value 'three'; expected an integer")
    assert note.endswith(f"'${{n}}' set at {display_path(SUBTREES / 'bad_times.yaml')}:2:10; "
                         "in subtree 'bad_times' included at here.yaml:2:8")
    error = error_of("mission: m\ntree: {subtree: bad_times, params: {n: 2.5}}\n")
    assert "invalid value 2.5" in str(error) and "'${n}' set at here.yaml:2:37" in str(error)
    (tmp_path / "ref.yaml").write_text(
        "subtree: ref\nparams: {speed: 1}\ntree: {skill: goto, params: {v: '${sped}'}}\n"
    )
    with pytest.raises(MissionError) as caught:
        parse_mission("mission: m\nparams: {height: 2}\ntree: {subtree: ./ref.yaml}\n", path=tmp_path / "m.yaml")
    assert "ref.yaml:3:30: tree.params.v: unknown parameter reference '${sped}'" in str(caught.value)
    assert caught.value.suggestion == "speed" and "one of height, speed" in caught.value.expected


def test_later_errors_in_a_subtree_name_where_the_value_was_set():
    from pydantic import BaseModel, ValidationError

    class GotoParams(BaseModel):
        target: tuple[float, float, float]
        speed: float = 1.0

    m = mission_here(f"mission: m\n{TEAM}tree:\n  subtree: go_and_hover\n"
                     "  params: {robot: uav, target: [1, 2, 3], speed: fast}\n")
    goto = m.spec.tree.sequence[0]
    with pytest.raises(ValidationError) as caught:
        GotoParams.model_validate(goto.params)
    first, note = str(m.validation_error(caught.value, goto.key_path + ("params",), GotoParams)).splitlines()
    assert first.endswith("go_and_hover.yaml:10:70: tree.sequence[0].params.speed: invalid value 'fast'; "
                          "expected a number")
    assert note == "  '${speed}' set at here.yaml:5:43; in subtree 'go_and_hover' included at here.yaml:4:3"
