"""The waiting nodes (wait_until, run_for, idle) and settings groups (<<: "${group}", subtree group defaults,
--set group.key): behaviour read back from the log, and their located errors."""

import textwrap

import pytest

from marsupial.trees.btxml import to_btcpp_xml
from marsupial.trees.compiler import compile_mission
from marsupial.trees.errors import MissionError
from marsupial.trees.mission import (
    IdleNode,
    RunForNode,
    WaitUntilNode,
    display_path,
    mission_schema,
    parse_mission,
)
from marsupial.trees.replay import read_log
from marsupial.trees.runner import run_mission
from marsupial.trees.yaml_source import load_yaml


def mission_text(tree, extra=""):
    """A mission (no robots) whose tree is ``tree`` (YAML text)."""
    return f"mission: test\n{extra}tree:\n" + textwrap.indent(textwrap.dedent(tree).strip(), "  ") + "\n"


def run(tmp_path, tree, extra=""):
    path = tmp_path / "m.yaml"
    path.write_text(mission_text(tree, extra))
    result = run_mission(str(path), log_path=tmp_path / "run.mcap", progress=False)
    return result, read_log(tmp_path / "run.mcap")


def outcomes(log):
    """(t, node, status) of every skill outcome event."""
    return [(round(e["t"], 3), e["node"], e["status"]) for e in log.events_of("outcome")]


def error_of(text, overrides=None, path=None):
    with pytest.raises(MissionError) as caught:
        compile_mission(parse_mission(text, "m.yaml", overrides, path))
    return str(caught.value)


# ---------------------------------------------------------------- wait_until
def test_wait_until_runs_until_the_guard_holds_and_commands_nothing(tmp_path):
    result, log = run(tmp_path, "{wait_until: {timer: 1.0}, name: wait for it}")
    assert (result.outcome, result.sim_time) == ("success", pytest.approx(1.0))
    assert outcomes(log) == []  # no skill ran: nothing was commanded


def test_wait_until_with_a_timeout_fails_when_the_guard_does_not_hold_in_time(tmp_path):
    result, _ = run(tmp_path, "{wait_until: {timer: 5.0}, timeout: 2.0}")
    assert (result.outcome, result.sim_time) == ("failure", pytest.approx(2.0))
    result, _ = run(tmp_path, "{wait_until: {timer: 1.5}, timeout: 2.0}")
    assert (result.outcome, result.sim_time) == ("success", pytest.approx(1.5))


# ------------------------------------------------------------------- run_for
def test_run_for_succeeds_when_the_child_is_still_running_and_stops_it(tmp_path):
    result, log = run(tmp_path, """
        run_for: {skill: wait, name: long, params: {seconds: 30}}
        seconds: 2.5
    """)
    assert (result.outcome, result.sim_time) == ("success", pytest.approx(2.5))
    assert outcomes(log) == [(2.5, "long", "INVALID")]


def test_run_for_keeps_the_childs_own_result(tmp_path):
    result, _ = run(tmp_path, """
        run_for: {skill: wait, params: {seconds: 1.0}}
        seconds: 5
    """)
    assert (result.outcome, result.sim_time) == ("success", pytest.approx(1.0))
    failing = "{condition: timer, params: {seconds: 9}}"
    result, _ = run(tmp_path, f"run_for: {failing}\nseconds: 5")
    assert (result.outcome, result.sim_time) == ("failure", pytest.approx(0.0))
    result, _ = run(tmp_path, f"invert: {{timeout: {failing}, seconds: 5}}")  # the idiom it replaces hides the failure
    assert result.outcome == "success"


# ---------------------------------------------------------------------- idle
def test_idle_runs_until_its_parent_stops_it(tmp_path):
    result, log = run(tmp_path, """
        parallel:
          - {idle: true, name: stand by}
          - {skill: wait, name: work, params: {seconds: 1.2}}
        success_on: one
    """)
    assert (result.outcome, result.sim_time) == ("success", pytest.approx(1.2))
    assert outcomes(log) == [(1.2, "work", "SUCCESS")]
    result, _ = run(tmp_path, "{idle: true}", extra="run: {until: 3}\n")
    assert result.sim_time == pytest.approx(3.0) and result.outcome not in ("success", "failure")


def test_waiting_nodes_in_the_models_schema_and_export():
    mission = parse_mission(mission_text("""
        sequence:
          - {wait_until: {timer: 1}, timeout: 4}
          - {run_for: {idle: true, name: rest}, seconds: 2, name: a while}
    """), "m.yaml")
    wait, run_for = mission.spec.tree.sequence
    assert isinstance(wait, WaitUntilNode) and (wait.label, wait.timeout, wait.guards()[0].argument) == (
        "wait until timer", 4.0, 1)
    assert isinstance(run_for, RunForNode) and isinstance(run_for.run_for, IdleNode)
    assert wait.guards()[0].key_path == ("tree", "sequence", 0, "wait_until")
    xml = to_btcpp_xml(compile_mission(mission).root)
    assert '<WaitUntil name="wait until timer(1.0)" timeout="4.0">' in xml
    assert '<RunFor name="a while" seconds="2.0">' in xml and '<Idle name="rest" />' in xml
    defs = mission_schema()["$defs"]
    assert defs["RunForNode"]["required"] == ["run_for", "seconds"]
    assert defs["IdleNode"]["properties"]["idle"]["const"] is True
    assert defs["WaitUntilNode"]["properties"]["wait_until"]["$ref"] == "#/$defs/Guard"


@pytest.mark.parametrize("tree, message", [
    ("{idle: false}", "m.yaml:3:4: tree.idle: idle takes true, got False; expected true (idle: true)"),
    ("{idle: {}}", "m.yaml:3:4: tree.idle: idle takes true, got {}; expected true (idle: true)"),
    ("{wait_until: {timer: 1}, timeout: -1}", "m.yaml:3:28: tree.timeout: invalid value -1; expected a value > 0"),
    ("{wait_until: {timer: 1}, timeout: true}", "m.yaml:3:28: tree.timeout: invalid value True; expected a number"),
    ("{wait_untill: {timer: 1}}", "m.yaml:3:4: tree.wait_untill: unknown node type 'wait_untill'; expected one of "
     "condition, idle, invert, parallel, priorities, repeat, retry, run_for, selector, sequence, skill, subtree, "
     "timeout, until, wait_until; did you mean 'wait_until'?"),
    ("{wait_until: {timer: 1}, timout: 3}", "m.yaml:3:28: tree.timout: unknown key 'timout'; expected one of name, "
     "timeout, wait_until; did you mean 'timeout'?"),
    ("{wait_until: {timr: 1}}", "m.yaml:3:17: tree.wait_until.timr: unknown condition 'timr'; expected one of "
     "area_explored, battery_below, benchmark_captured, difficult_area, entrance_matched, exploration_stuck, "
     "features_lost, flight_time, landed, object_found, obstacle_ahead, operator, platform_lost, stored, timer, "
     "within_criterion; did you mean 'timer'?"),
    ("{run_for: {idle: true}, secnds: 2, seconds: 1}", "m.yaml:3:27: tree.secnds: unknown key 'secnds'; expected one "
     "of name, run_for, seconds; did you mean 'seconds'?"),
    ("{run_for: {idle: true}}", "m.yaml:2:1: tree.seconds: missing required key 'seconds'; expected a number"),
    ("{run_for: {idle: true}, seconds: .inf}",
     "m.yaml:3:27: tree.seconds: invalid value inf; expected a finite number"),
    ("{run_for: {idle: true}, idle: true, seconds: 1}",
     "a node has exactly one node type key, found 'run_for', 'idle'"),
])
def test_waiting_node_errors_are_located(tree, message):
    assert message in error_of(mission_text(tree))


# -------------------------------------------------------------- settings groups
GROUPED = """\
mission: test
params:
  wait: {seconds: 2.0, name_unused: 1}
  short: {seconds: 0.5}
tree:
  sequence:
    - {skill: wait, name: a, params: {<<: "${short}"}}
    - {skill: wait, name: b, params: {<<: "${short}", seconds: 0.25}}
"""


def test_a_group_merges_into_a_mapping_and_keys_written_beside_it_win():
    a, b = compile_mission(parse_mission(GROUPED, "m.yaml")).nodes
    assert (a.params.seconds, b.params.seconds) == (0.5, 0.25)
    text = GROUPED.replace('"${short}"}}\n    - {skill: wait, name: b', '"${wait}"}}\n    - {skill: wait, name: b')
    assert error_of(text).splitlines() == [
        "m.yaml:7:39: tree.sequence[0].params.name_unused: unknown key 'name_unused'; expected seconds",
        "  '${wait}' set at m.yaml:3:3",
    ]


@pytest.mark.parametrize("value, message", [
    ('"${shrt}"', "m.yaml:8:39: tree.sequence[0].params.<<: unknown parameter reference '${shrt}'; expected a "
                  "parameter (one of n, short, wait); did you mean 'short'?"),
    ('"${short} s"', "m.yaml:8:39: tree.sequence[0].params.<<: '<<' merges a mapping of settings, '${short} s' is "
                     "\"{'seconds': 0.5} s\"; expected '<<: \"${name}\"' naming a parameter whose value is a mapping"),
    ('"${n}"', "'<<' merges a mapping of settings, '${n}' is 3"),
])
def test_a_merge_needs_one_reference_to_a_mapping(value, message):
    text = GROUPED.replace('{<<: "${short}"}}', f"{{<<: {value}}}}}", 1).replace("params:\n", "params:\n  n: 3\n", 1)
    assert message in error_of(text)


def test_yaml_anchors_still_merge():
    doc = load_yaml("a: &x {p: 1, q: 2}\nb: {<<: *x, q: 3}\n")
    assert doc.data["b"] == {"p": 1, "q": 3}
    with pytest.raises(MissionError, match="duplicate key '<<'"):
        load_yaml('b: {<<: "${x}", <<: "${y}"}\n')


def _with_subtrees(tmp_path, include):
    """A mission in ``tmp_path`` including ``include``, beside subtrees ``waits`` (flat) and ``grouped`` (a group)."""
    (tmp_path / "subtrees").mkdir(exist_ok=True)
    (tmp_path / "subtrees" / "waits.yaml").write_text(
        'subtree: waits\nparams: {seconds: 1.0, label: pause}\n'
        'tree: {skill: wait, name: "${label}", params: {seconds: "${seconds}"}}\n')
    (tmp_path / "subtrees" / "grouped.yaml").write_text(
        'subtree: grouped\nparams:\n  timing: {seconds: 0.5}   # a settings group\n'
        'tree: {skill: wait, params: {<<: "${timing}"}}\n')
    path = tmp_path / "m.yaml"
    path.write_text(f"mission: test\nparams:\n  pause: {{seconds: 2.0}}\ntree: {include}\n")
    return path


def _compiled(path):
    return compile_mission(parse_mission(path.read_text(), "m.yaml", path=path)).nodes


def test_a_group_is_passed_to_an_include_at_once(tmp_path):
    (node,) = _compiled(_with_subtrees(tmp_path, '{subtree: waits, params: {<<: "${pause}", label: p}}'))
    assert (node.name, node.params.seconds) == ("p", 2.0)


def test_a_subtree_group_default_is_updated_key_by_key(tmp_path):
    (node,) = _compiled(_with_subtrees(tmp_path, "{subtree: grouped, params: {timing: {}}}"))
    assert node.params.seconds == 0.5  # the declared group's value, not the skill's default (1.0)
    (node,) = _compiled(_with_subtrees(tmp_path, "{subtree: grouped, params: {timing: {seconds: 0.75}}}"))
    assert node.params.seconds == 0.75
    path = _with_subtrees(tmp_path, "{subtree: grouped, params: {timing: {secnds: 0.75}}}")
    assert error_of(path.read_text(), path=path) == (
        "m.yaml:4:44: tree.params.timing.secnds: unknown setting 'secnds' in group 'timing' of subtree 'grouped'; "
        "expected a setting of the group (seconds); did you mean 'seconds'?")
    path = _with_subtrees(tmp_path, "{subtree: grouped, params: {timing: 3}}")
    assert error_of(path.read_text(), path=path) == (
        "m.yaml:4:35: tree.params.timing: 'timing' of subtree 'grouped' is a settings group, got 3; "
        "expected a mapping with some of seconds")


def test_unknown_parameter_merged_into_an_include_points_at_the_merge(tmp_path):
    path = _with_subtrees(tmp_path, '{subtree: waits, params: {<<: "${pause}"}}')
    text = path.read_text().replace("pause: {seconds: 2.0}", "pause: {secs: 2.0}")
    assert error_of(text, path=path).splitlines() == [
        "m.yaml:4:33: tree.params.secs: unknown parameter 'secs' of subtree 'waits'; expected a declared parameter "
        "(one of label, seconds); did you mean 'seconds'?",
        "  '${pause}' set at m.yaml:3:3",
    ]


def test_missing_required_subtree_parameter_names_its_declaration(tmp_path):
    path = _with_subtrees(tmp_path, "{subtree: needs}")
    (tmp_path / "subtrees" / "needs.yaml").write_text("subtree: needs\nparams:\n  seconds: ~\ntree: {idle: true}\n")
    assert error_of(path.read_text(), path=path).endswith(
        "m.yaml:4:1: tree.params: subtree 'needs' needs parameter seconds; expected params with seconds "
        f"(declared required: seconds at {display_path(tmp_path / 'subtrees' / 'needs.yaml')}:3:3)")


def test_set_reaches_a_key_of_a_settings_group(tmp_path):
    a, _ = compile_mission(parse_mission(GROUPED, "m.yaml", {"short.seconds": "0.75"})).nodes
    assert a.params.seconds == 0.75
    message = error_of(GROUPED, {"short.secnds": "1"})
    assert message == ("m.yaml: --set short.secnds=1: unknown key 'params.short.secnds'; expected "
                       "params.short.seconds; did you mean 'params.short.seconds'?")
    message = error_of(GROUPED, {"shrt.seconds": "1"})
    assert message == ("m.yaml: --set shrt.seconds=1: 'shrt' is neither a mission section nor a mission parameter; "
                       "expected a section (one of description, mission, operator, params, plugins, run, team, tree, "
                       "world) or a mission parameter (one of short, wait); did you mean 'short'?")
    message = error_of(GROUPED, {"short.seconds": "soon"})
    assert "invalid value 'soon'; expected a number" in message and "set by --set short.seconds=soon" in message


def test_a_preempted_idle_node_is_named_in_the_preemption_event(tmp_path):
    result, log = run(tmp_path, """
        priorities:
          - when: {timer: 1.0}
            do: {skill: wait, name: urgent, params: {seconds: 0.5}}
          - do: {idle: true, name: stand by}
    """)
    assert (result.outcome, result.sim_time) == ("success", pytest.approx(1.5))
    [event] = log.events_of("preemption")
    assert (event["t"], event["preempted"], event["by"], event["robot"], event["stop"]) == (
        1.0, "stand by", "urgent", None, None)
