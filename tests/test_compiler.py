"""Compiler: every node type runs as specified against the real world; whole-tree checks at compile time."""

import textwrap

import numpy as np
import py_trees
import pytest

from marsupial.trees.compiler import compile_mission
from marsupial.trees.errors import MissionError
from marsupial.trees.mission import load_mission
from marsupial.trees.replay import read_log
from marsupial.trees.runner import run_mission

UAV_TEAM = "team:\n  uav: {robot: bebop2, pose: [0, 0, 0]}\n"
UGV_TEAM = "team:\n  ugv: {robot: summit_xl, pose: [0, 0, 0]}\n"


def mission_file(tmp_path, tree, team="", extra="", name="m.yaml"):
    """Write a mission whose tree is ``tree`` (YAML text) and return its path."""
    text = f"mission: test\n{team}{extra}tree:\n" + textwrap.indent(textwrap.dedent(tree).strip(), "  ") + "\n"
    path = tmp_path / name
    path.write_text(text)
    return path


def run(tmp_path, tree, team="", extra="", log=True, **kwargs):
    path = mission_file(tmp_path, tree, team, extra)
    log_path = tmp_path / "run.mcap" if log else None
    result = run_mission(str(path), log_path=log_path, progress=False, **kwargs)
    return result, (read_log(log_path) if log else None)


def outcomes(log, status=None):
    """(t, node, status) of every skill outcome event."""
    return [
        (round(e["t"], 3), e["node"], e["status"]) for e in log.events_of("outcome") if status in (None, e["status"])
    ]


# ---------------------------------------------------------------- node types
def test_sequence_runs_children_in_order(tmp_path):
    result, log = run(tmp_path, """
        sequence:
          - {skill: wait, name: a, params: {seconds: 1.0}}
          - {skill: wait, name: b, params: {seconds: 0.5}}
    """)
    assert result.outcome == "success"
    assert outcomes(log) == [(1.0, "a", "SUCCESS"), (1.5, "b", "SUCCESS")]
    assert result.sim_time == pytest.approx(1.5)


def test_selector_falls_back_to_the_next_child(tmp_path):
    result, log = run(tmp_path, """
        selector:
          - {condition: timer, params: {seconds: 5}}
          - {skill: wait, name: fallback, params: {seconds: 0.3}}
    """)
    assert result.outcome == "success"
    assert outcomes(log) == [(0.3, "fallback", "SUCCESS")]


@pytest.mark.parametrize("success_on, end", [("all", 2.0), ("one", 1.0)])
def test_parallel_success_policy(tmp_path, success_on, end):
    result, log = run(tmp_path, f"""
        parallel:
          - {{skill: wait, name: short, params: {{seconds: 1.0}}}}
          - {{skill: wait, name: long, params: {{seconds: 2.0}}}}
        success_on: {success_on}
    """)
    assert result.outcome == "success"
    assert result.sim_time == pytest.approx(end)
    if success_on == "one":  # the other child is stopped when the parallel succeeds
        assert (1.0, "long", "INVALID") in outcomes(log)


def test_priorities_reevaluate_guards_every_tick(tmp_path):
    result, log = run(tmp_path, """
        priorities:
          - when: {timer: 1.0}
            do: {skill: wait, name: urgent, params: {seconds: 0.5}}
          - do: {skill: wait, name: routine, params: {seconds: 10}}
    """)
    assert result.outcome == "success"
    assert outcomes(log) == [(1.0, "routine", "INVALID"), (1.5, "urgent", "SUCCESS")]
    [event] = log.events_of("preemption")
    assert (event["t"], event["preempted"], event["by"], event["why"]) == (1.0, "routine", "urgent", "timer(1.0)")


def test_repeat_restarts_the_child_after_each_success(tmp_path):
    result, log = run(tmp_path, """
        repeat: {skill: wait, name: w, params: {seconds: 0.5}}
        times: 3
    """)
    assert result.outcome == "success"
    # a child that succeeded is restarted at the next tick (tick period 0.1 s)
    assert outcomes(log) == [(0.5, "w", "SUCCESS"), (1.1, "w", "SUCCESS"), (1.7, "w", "SUCCESS")]


def test_retry_gives_up_after_the_attempts(tmp_path):
    result, log = run(tmp_path, """
        retry:
          timeout: {skill: wait, name: slow, params: {seconds: 5}}
          seconds: 0.5
        times: 2
    """)
    assert result.outcome == "failure"
    assert outcomes(log) == [(0.5, "slow", "INVALID"), (1.1, "slow", "INVALID")]


def test_timeout_counts_simulated_seconds(tmp_path):
    result, _ = run(tmp_path, """
        timeout: {skill: wait, params: {seconds: 30}}
        seconds: 2.5
    """, log=False)
    assert (result.outcome, result.sim_time) == ("failure", pytest.approx(2.5))
    result, _ = run(tmp_path, """
        timeout: {skill: wait, params: {seconds: 20}}
        seconds: 30
    """, log=False)
    assert (result.outcome, result.sim_time) == ("success", pytest.approx(20.0))


def test_invert_swaps_success_and_failure(tmp_path):
    result, _ = run(tmp_path, "invert: {skill: wait, params: {seconds: 0.2}}", log=False)
    assert result.outcome == "failure"
    result, _ = run(tmp_path, "invert: {condition: timer, params: {seconds: 9}}", log=False)
    assert result.outcome == "success"


def test_until_ticks_the_child_until_the_guard_holds(tmp_path):
    result, log = run(tmp_path, """
        until: {skill: wait, name: lap, params: {seconds: 0.3}}
        condition: {timer: 1.0}
    """)
    assert (result.outcome, result.sim_time) == ("success", pytest.approx(1.0))
    # restarted after each success; the third lap is stopped when the guard holds
    assert outcomes(log) == [(0.3, "lap", "SUCCESS"), (0.7, "lap", "SUCCESS"), (1.0, "lap", "INVALID")]


def test_condition_leaf_and_time_limit(tmp_path):
    result, _ = run(tmp_path, """
        sequence:
          - {condition: timer, params: {seconds: 0.5}}
          - {skill: wait}
    """, log=False)
    assert (result.outcome, result.sim_time) == ("failure", 0.0)
    result, log = run(tmp_path, "skill: wait\nparams: {seconds: 100}", until=0.7)
    assert (result.outcome, result.sim_time) == ("time_limit", pytest.approx(0.7))
    assert log.outcome == "time_limit"
    assert outcomes(log) == [(0.7, "wait", "INVALID")]  # the running skill was stopped


def test_subtree_with_parameters(tmp_path):
    (tmp_path / "pause_twice.yaml").write_text(textwrap.dedent("""
        subtree: pause_twice
        params: {pause: ~}
        tree:
          sequence:
            - {skill: wait, name: first, params: {seconds: "${pause}"}}
            - {skill: wait, name: second, params: {seconds: "${pause}"}}
    """))
    result, log = run(tmp_path, "subtree: pause_twice.yaml\nparams: {pause: 0.3}")
    assert result.outcome == "success"
    assert outcomes(log) == [(0.3, "first", "SUCCESS"), (0.6, "second", "SUCCESS")]


def test_goto_flies_a_uav_to_its_target(tmp_path):
    result, _ = run(tmp_path, """
        sequence:
          - {skill: goto, robot: uav, params: {target: [0, 0, 1.0]}}
          - {skill: goto, robot: uav, params: {target: [1.5, -1.0, 1.0], speed: 2.0, tolerance: 0.1}}
    """, team=UAV_TEAM, log=False, until=20)
    assert result.outcome == "success"
    assert result.robots["uav"]["position"] == pytest.approx([1.5, -1.0, 1.0], abs=0.12)


def test_drive_to_brings_a_ground_robot_to_its_target(tmp_path):
    result, _ = run(tmp_path, "skill: drive_to\nrobot: ugv\nparams: {target: [2.0, 1.5], speed: 1.0}",
                    team=UGV_TEAM, log=False, until=20)
    assert result.outcome == "success"
    assert result.robots["ugv"]["position"][:2] == pytest.approx([2.0, 1.5], abs=0.2)


def test_the_demo_mission_flies_and_lands(tmp_path):
    result = run_mission("demo_hover", progress=False, log_path=tmp_path / "run.mcap")
    assert result.outcome == "success"
    log = read_log(tmp_path / "run.mcap")
    _, estimate = log.poses("uav", estimate=True)
    _, truth = log.poses("uav")
    # where the UAV believes it landed (goto's tolerance)
    assert estimate[-1] == pytest.approx([2.0, 2.0, 0.15], abs=0.1)
    assert truth[-1, 2] == pytest.approx(0.09, abs=0.02)  # on the floor
    assert np.linalg.norm(truth[-1, :2] - [2.0, 2.0]) < 0.35  # where it is: optical-flow drift over 13 s of flight


# ---------------------------------------------------------------- compile-time checks
def compile_error(tmp_path, tree, team=UAV_TEAM, extra=""):
    with pytest.raises(MissionError) as info:
        compile_mission(load_mission(str(mission_file(tmp_path, tree, team, extra))))
    return info.value


def test_unknown_condition_is_reported_with_the_closest_name(tmp_path):
    err = compile_error(tmp_path, """
        priorities:
          - when: {battery_bellow: 0.2, robot: uav}
            do: {skill: wait}
          - do: {skill: wait}
    """)
    assert (err.line, err.suggestion) == (6, "battery_below")
    assert "unknown condition 'battery_bellow'" in str(err)


def test_robot_kind_and_robot_presence_are_checked(tmp_path):
    err = compile_error(tmp_path, "skill: drive_to\nrobot: uav\nparams: {target: [1, 1]}")
    assert "cannot run on 'uav' (a bebop2)" in str(err) and err.line == 6
    err = compile_error(tmp_path, "until: {skill: wait}\ncondition: {battery_below: 0.2, robot: ugv}", team=UGV_TEAM)
    assert str(err).endswith("condition 'battery_below' cannot run on 'ugv' (a summit_xl); "
                             "expected a robot with capability HasBattery (none in this team)")  # no battery
    err = compile_error(tmp_path, "until: {skill: wait}\ncondition: {obstacle_ahead: 1.0, robot: ugv}", team=UGV_TEAM)
    assert str(err).endswith("condition 'obstacle_ahead' cannot run on 'ugv' (a summit_xl); "
                             "expected a robot with capability HasBase and HasLidar (none in this team)")  # no LiDAR
    err = compile_error(tmp_path, "skill: navigate\nrobot: ugv", team=UGV_TEAM)
    assert "cannot run on 'ugv' (a summit_xl)" in str(err)  # navigate avoids obstacles with a LiDAR
    err = compile_error(tmp_path, "skill: explore\nrobot: uav", team="team:\n  uav: {robot: ardrone2}\n")
    assert str(err).endswith("skill 'explore' reads sensor 'front_camera', which 'uav' (a ardrone2) does not have; "
                             "expected a robot with the sensors front_camera")  # no front camera
    err = compile_error(tmp_path, "skill: wait\nrobot: uav")
    assert "takes no robot" in str(err)
    two = "team:\n  a: {robot: bebop2}\n  b: {robot: tello}\n"
    err = compile_error(tmp_path, "skill: hover", team=two)
    assert "needs a robot" in str(err) and "a, b" in str(err)


def test_blackboard_reads_must_have_a_writer(tmp_path):
    err = compile_error(tmp_path, """
        until: {skill: hover, robot: uav}
        condition: {area_explored: 0.8}
    """)
    assert "reads blackboard key 'coverage' that no node writes" in str(err)
    assert err.line == 6


def test_priorities_compile_to_a_memoryless_selector_of_guarded_sequences(tmp_path):
    path = mission_file(tmp_path, """
        priorities:
          - when: [{battery_below: 0.3, robot: uav}, {operator: dock}]
            do: {skill: hover, robot: uav}
          - do: {skill: wait}
    """, UAV_TEAM)
    tree = compile_mission(load_mission(str(path)))
    root = tree.root
    assert isinstance(root, py_trees.composites.Selector) and root.memory is False
    branch = root.children[0]
    assert isinstance(branch, py_trees.composites.Sequence) and branch.memory is False
    assert [c.name for c in branch.children] == ["battery_below@uav", "operator", "hover@uav"]
    assert branch.name == "when battery_below(0.3, robot=uav) and operator(dock)"
    assert tree.listens == {"dock"}
