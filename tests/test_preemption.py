"""Preemption: command arbitration inside one tick, preemption by battery/operator/obstacle, the operator channel."""

import io
import textwrap

import numpy as np
import pytest
from py_trees.common import Status
from py_trees.composites import Selector

from marsupial.api.commands import Drive as Drive_
from marsupial.api.commands import SafeStop
from marsupial.api.model import RobotModel
from marsupial.api.views import RobotState, WheeledView
from marsupial.trees.arbitration import Arbiter
from marsupial.trees.composites import GuardedBranch, Priorities
from marsupial.trees.operator import OperatorChannel, OperatorLatch, parse_line
from marsupial.trees.replay import read_log
from marsupial.trees.runner import run_mission
from marsupial.trees.skill import Condition, RunContext, Skill


# ---------------------------------------------------------------- arbitration
class Drive(Skill):
    """Drives robot ``r`` (a wheeled base) at its ``speed`` every tick."""

    speed = 0.0
    claims = ("base",)

    def step(self):
        self.robot.drive(self.speed, 0.0)
        return Status.RUNNING


class Idle(Skill):
    """Runs without commanding anything."""

    uses_robot = False

    def step(self):
        return Status.RUNNING


class Flag(Condition):
    uses_robot = False
    up = False

    def check(self):
        return Flag.up


def stub_context():
    """A run context with one wheeled robot ``r`` (its view: readings in, commands to the arbiter's outbox)."""
    return RunContext(robots={"r": RobotState(RobotModel("r", "stub"))}, views={"r": WheeledView})


def tick(root, context, n=1):
    """Tick ``n`` times; the commands sent, in order."""
    sent = []
    for _ in range(n):
        context.arbiter.new_tick()
        root.tick_once()
        sent.extend(command for _, command in context.arbiter.take())
    return sent


def test_preempting_command_survives_the_safe_stop_of_the_preempted_skill():
    context = stub_context()
    high, low = Drive("high", context=context, robot="r"), Drive("low", context=context, robot="r")
    high.speed, low.speed = 1.0, 0.5
    root = Selector(
        "root", memory=False, children=[GuardedBranch("guarded", [Flag("flag", context=context)], high, context), low]
    )
    Flag.up = False
    assert tick(root, context, 2) == [Drive_("r", 0.5, 0.0)] * 2
    Flag.up = True
    # tick 3: py_trees initialises and ticks "high" before terminating "low": low's safe-stop is dropped
    assert tick(root, context) == [Drive_("r", 1.0, 0.0)]
    assert low.status == Status.INVALID and low.stopped_by.node_name == "high" and low.stopped_by.tick == 3
    assert context.arbiter.last("r").node_name == "high"
    Flag.up = False
    # tick 4: "high" loses its guard, is stopped first, then "low" starts
    assert tick(root, context) == [SafeStop("r", "base"), Drive_("r", 0.5, 0.0)]
    assert high.stopped_by is None


def test_safe_stop_applies_when_the_preempting_branch_leaves_the_robot_alone():
    context = stub_context()
    low = Drive("low", context=context, robot="r")
    root = Selector("root", memory=False, children=[
        GuardedBranch("guarded", [Flag("flag", context=context)], Idle("idle", context=context), context), low])
    Flag.up = False
    sent = tick(root, context)
    Flag.up = True
    assert sent + tick(root, context) == [Drive_("r", 0.0, 0.0), SafeStop("r", "base")]
    assert low.stopped_by is None


def test_a_safe_stop_in_a_later_tick_is_applied():
    arbiter = Arbiter()
    arbiter.new_tick()
    arbiter.command("base", Drive_("r", 1.0, 0.0), "a", "a")
    assert arbiter.safe_stop(WheeledView, "r", "b", "b").node_name == "a"  # same tick, other node: dropped
    assert arbiter.safe_stop(WheeledView, "r", "a", "a") is None  # the commanding node itself may stop it
    arbiter.new_tick()
    arbiter.command("base", Drive_("r", 1.0, 0.0), "a", "a")
    arbiter.new_tick()
    assert arbiter.safe_stop(WheeledView, "r", "b", "b") is None
    assert arbiter.take() == (
        ("a", Drive_("r", 1.0, 0.0)), ("a", SafeStop("r", "base")), ("a", Drive_("r", 1.0, 0.0)),
        ("b", SafeStop("r", "base")),
    )


def test_priorities_record_who_preempted_whom():
    context = stub_context()
    low = Drive("low", context=context, robot="r")
    root = Priorities(
        "p", [GuardedBranch("b", [Flag("flag", context=context)], Idle("idle", context=context), context), low], context
    )
    Flag.up = False
    tick(root, context)
    Flag.up = True
    tick(root, context)
    [preemption] = [r.fields for r in context.records if r.kind == "event" and r.name == "preemption"]
    assert preemption == {"preempted": "low", "by": "idle", "why": "flag()", "robot": "r", "stop": "safe_stop"}


# ---------------------------------------------------------------- missions
def run_text(tmp_path, text, **kwargs):
    path = tmp_path / "m.yaml"
    path.write_text(textwrap.dedent(text))
    log = tmp_path / "run.mcap"
    result = run_mission(str(path), log_path=log, progress=False, **kwargs)
    return result, read_log(log)


def speed_between(log, robot, t0, t1):
    """Mean speed (m/s) of ``robot`` between the first logged pose at or after t0 and the last at or before t1."""
    t, xyz = log.poses(robot)
    i0, i1 = np.searchsorted(t, t0), np.searchsorted(t, t1, side="right") - 1
    assert i1 > i0, f"no logged poses between {t0} and {t1}"
    return float(np.linalg.norm(xyz[i1] - xyz[i0]) / (t[i1] - t[i0]))


def test_low_battery_preempts_the_flight_and_the_uav_is_left_hovering(tmp_path):
    result, log = run_text(tmp_path, """
        mission: battery
        team:
          uav: {robot: bebop2, pose: [0, 0, 1.0, 0], options: {battery_soc: 0.2015}}
        tree:
          priorities:
            - when: {battery_below: 0.2, robot: uav}
              do: {skill: hover, robot: uav, name: hold, params: {seconds: 3}}
            - do: {skill: goto, robot: uav, name: survey, params: {target: [30, 0, 1.0], speed: 2.0}}
    """, until=30)
    assert result.outcome == "success"
    [event] = log.events_of("preemption")
    assert event["preempted"] == "survey" and event["by"] == "hold" and event["robot"] == "uav"
    assert event["why"] == "battery_below(0.2, robot=uav)"
    assert event["stop"] == "kept by hold"  # the preempting hover commanded the UAV in that very tick
    t = event["t"]
    assert 0.5 < t < 10
    assert speed_between(log, "uav", t - 1.0, t) > 1.0  # flying before
    assert speed_between(log, "uav", t + 1.5, t + 2.5) < 0.05  # hovering after
    soc_t, soc = log.metric("battery_soc", robot="uav")
    assert soc[0] > 0.2 and soc[-1] < 0.2


def test_operator_command_preempts_and_the_safe_stop_stops_the_ground_robot(tmp_path):
    result, log = run_text(tmp_path, """
        mission: operator
        team:
          ugv: {robot: summit_xl, pose: [0, 0, 0]}
        operator:
          - {at: 2.0, say: halt, why: person ahead}
        tree:
          priorities:
            - when: {operator: halt}
              do: {skill: wait, name: stand by, params: {seconds: 2}}
            - do: {skill: drive_to, robot: ugv, name: patrol, params: {target: [20, 0], speed: 1.0}}
    """, until=20)
    assert (result.outcome, result.sim_time) == ("success", pytest.approx(4.0))
    [said] = log.events_of("operator")
    assert (said["t"], said["command"], said["source"], said["why"]) == (2.0, "halt", "script", "person ahead")
    [event] = log.events_of("preemption")
    assert (event["t"], event["preempted"], event["by"], event["robot"]) == (2.0, "patrol", "stand by", "ugv")
    assert event["why"] == "operator(halt): person ahead" and event["stop"] == "safe_stop"
    assert speed_between(log, "ugv", 1.0, 2.0) > 0.8
    assert speed_between(log, "ugv", 3.1, 4.0) < 0.005


def test_obstacle_ahead_preempts_driving(tmp_path):
    result, log = run_text(tmp_path, """
        mission: obstacle
        world: {scene: open_field}
        team:
          ugv: {robot: mobile_manipulator, pose: [54, 60, 0]}
        tree:
          priorities:
            - when: {obstacle_ahead: 1.0, robot: ugv}
              do: {skill: wait, name: blocked, params: {seconds: 2}}
            - do: {skill: drive_to, robot: ugv, name: cross, params: {target: [70, 60], speed: 1.0}}
    """, until=30)
    assert result.outcome == "success"
    [event] = log.events_of("preemption")
    assert (event["preempted"], event["by"], event["stop"]) == ("cross", "blocked", "safe_stop")
    assert event["why"] == "obstacle_ahead(1.0, robot=ugv)"
    x = result.robots["ugv"]["position"][0]
    assert 57.5 < x < 59.85  # stopped short of the marker post (radius 0.15 m at x = 60)
    assert speed_between(log, "ugv", event["t"] + 1.1, result.sim_time) < 0.005  # braked at 1 m/s²


def test_difficult_area_uses_scene_zones(tmp_path):
    mission = """
        mission: zone
        world: {scene: collapsed_mockup}
        team:
          ugv: {robot: summit_xl, pose: [%s, 0]}
        tree: {condition: difficult_area, robot: ugv, params: {distance: 0.5}}
    """
    near, _ = run_text(tmp_path, mission % "0, 0.5")
    far, _ = run_text(tmp_path, mission % "6, -6")
    assert (near.outcome, far.outcome) == ("success", "failure")


def test_abort_pause_and_resume(tmp_path):
    text = """
        mission: control
        team:
          ugv: {robot: summit_xl, pose: [0, 0, 0]}
        operator: [%s]
        tree: {skill: drive_to, robot: ugv, params: {target: [30, 0], speed: 1.0}}
    """
    result, log = run_text(tmp_path, text % "{at: 1.0, say: abort}", until=20)
    assert (result.outcome, result.exit_code, result.sim_time) == ("aborted", 1, 1.0)
    assert log.outcome == "aborted"
    result, log = run_text(tmp_path, text % "{at: 1.0, say: pause}, {at: 3.0, say: resume}", until=5)
    assert result.outcome == "time_limit"
    assert [e["state"] for e in log.events_of("state_change") if "state" in e] == ["paused", "running"]
    assert speed_between(log, "ugv", 2.1, 3.0) < 0.005  # stopped (1 m/s² braking) while paused
    assert speed_between(log, "ugv", 4.0, 5.0) > 0.8  # driving again after resume


# ---------------------------------------------------------------- operator channel
def test_operator_channel_stamps_commands_and_the_tree_latches_them():
    channel, latch = OperatorChannel([(1.0, "dock", "corridor"), (0.5, "pause", "")]), OperatorLatch()
    channel.say("deploy", "now")
    first = channel.poll(0.0)
    assert [(c.say, c.at, c.source) for c in first] == [("deploy", 0.0, "api")]
    assert channel.poll(0.4) == []
    said = channel.poll(1.0)
    assert [c.say for c in said] == ["pause", "dock"]  # scripted ones in time order
    for command in said:
        latch.latch(command)
    assert latch.latched("pause") is None  # control commands are handled by the runner
    assert latch.latched("dock").why == "corridor"
    assert latch.handle("dock").at == 1.0 and latch.latched("dock") is None


def test_operator_commands_from_a_stream():
    channel = OperatorChannel()
    channel.read_from(io.StringIO("dock corridor ahead\n\n  abort \n")).join(timeout=5)
    commands = channel.poll(2.5)
    assert [(c.say, c.why, c.source, c.at) for c in commands] == [
        ("dock", "corridor ahead", "stdin", 2.5), ("abort", "", "stdin", 2.5)]
    assert parse_line("   ") is None


def test_live_operator_api_command_is_recorded_at_the_tick_that_consumed_it(tmp_path):
    channel = OperatorChannel()
    channel.say("abort", "test")
    result, log = run_text(tmp_path, """
        mission: api
        tree: {skill: wait, params: {seconds: 5}}
    """, operator=channel)
    assert result.outcome == "aborted"
    [said] = log.events_of("operator")
    assert (said["t"], said["source"], said["command"]) == (0.0, "api", "abort")
