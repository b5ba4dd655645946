"""The landing missions and the landing_cycle subtree.

They load and compile, --set reaches every number, bad values exit 2.
"""

import pytest
from click.testing import CliRunner

from marsupial.skills.landing.conditions import FlightTime, Landed, PlatformLost
from marsupial.skills.landing.skills import (
    DrivePattern,
    Follow,
    Land,
    Relocalize,
    Takeoff,
    TrackPredictive,
    TrackReactive,
)
from marsupial.trees.cli import cli
from marsupial.trees.compiler import compile_mission
from marsupial.trees.errors import MissionError
from marsupial.trees.mission import load_mission, parse_mission
from marsupial.trees.subtrees import known_subtrees

MISSIONS = ("landing_linear", "landing_circular", "landing_lifelong")


def _nodes(mission, overrides=None):
    tree = compile_mission(load_mission(mission, overrides))
    return {type(n): n for n in tree.nodes}


@pytest.mark.parametrize("name", MISSIONS)
def test_missions_load_and_compile_with_the_five_state_cycle(name):
    nodes = _nodes(name)
    assert {Takeoff, Follow, Land, Relocalize, DrivePattern, PlatformLost, Landed, FlightTime} <= set(nodes)
    assert nodes[Land].params.mode == "predictive" and nodes[Land].params.gain_schedule == "table1"
    land = nodes[Land].params
    assert (land.descent_speed, land.final_height, land.final_speed) == (0.3, 0.7, 2.0)
    assert (nodes[PlatformLost].params.seconds, nodes[PlatformLost].params.max_error) == (0.5, 0.25)  # §3.1
    assert nodes[DrivePattern].params.v == 0.5
    assert "landing_cycle" in known_subtrees()


def test_set_overrides_reach_the_skills():
    nodes = _nodes("landing_lifelong", {
        "cycles": "3", "v": "0.7", "omega": "0.07", "tracker.mode": "reactive", "tracker.gain_schedule": "manual_fit",
        "tracker.nominal_height": "3.0", "cycle.land_after": "6", "cycle.final_height": "0.6", "run.tick_hz": "10",
    })
    assert (nodes[DrivePattern].params.v, nodes[DrivePattern].params.omega) == (0.7, 0.07)
    for skill in (Takeoff, Follow, Land, Relocalize):
        assert (nodes[skill].params.mode, nodes[skill].params.gain_schedule) == ("reactive", "manual_fit")
        assert nodes[skill].params.nominal_height == 3.0
    assert nodes[Land].params.final_height == 0.6 and nodes[PlatformLost].params.final_height == 0.6
    assert nodes[FlightTime].params.seconds == 6.0 and nodes[FlightTime].params.since == "takeoff"
    mission = load_mission("landing_lifelong", {"cycles": "3"})
    assert mission.spec.tree.parallel[1].times == 3
    linear = _nodes("landing_linear", {"tracker.velocity_feedforward": "false"})
    assert linear[DrivePattern].params.pattern == "linear" and linear[FlightTime].params.since == "tracking"
    assert linear[Follow].params.tracker_config().path_time_s == 0.1  # the paper's predictive controller


def test_a_mission_swaps_the_tracking_skill_by_name():
    team = "team: {ugv: {robot: summit_xl}, uav: {robot: ardrone2}}\n"
    for name, cls, mode in (
        ("track_reactive", TrackReactive, "reactive"),
        ("track_predictive", TrackPredictive, "predictive"),
    ):
        mission = parse_mission(
            f"mission: m\n{team}tree: {{skill: {name}, robot: uav, params: {{seconds: 5}}}}\n", "m.yaml"
        )
        (node,) = compile_mission(mission).nodes
        assert isinstance(node, cls) and node.params.tracker_config().mode == mode
    text = load_mission("landing_circular").text.replace(
        "tree:", "plugins: {follow: marsupial.skills.landing.skills:TrackReactive}\ntree:", 1)
    follow = next(n for n in compile_mission(parse_mission(text, "swap.yaml", {"tracker.mode": "reactive"})).nodes
                  if isinstance(n, Follow))
    assert isinstance(follow, TrackReactive)
    with pytest.raises(MissionError, match="mode: invalid value 'predictive'"):  # the pinned skill is reactive only
        compile_mission(parse_mission(text, "swap.yaml"))


@pytest.mark.parametrize(
    "override, message",
    [
        ("tracker.mode=fast", "mode: invalid value 'fast'"),
        ("tracker.nominal_height=high", "nominal_height: invalid value 'high'; expected a number"),
        ("tracker.gain_schedule=fitted", "gain_schedule: invalid value 'fitted'"),
        ("cycles=many", "times: invalid value 'many'; expected an integer"),
        ("tracker.velocity_feedforward=maybe", "velocity_feedforward: invalid value 'maybe'"),
        ("cycle.final_hight=0.6", "unknown key 'params.cycle.final_hight'"),
    ],
)
def test_wrong_parameter_types_exit_2_at_compile_time(override, message):
    result = CliRunner().invoke(cli, ["run", "landing_lifelong", "--set", override], env={"COLUMNS": "300"})
    assert result.exit_code == 2, result.output
    assert message in result.output
