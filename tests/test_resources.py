"""Resources and capabilities: claims checked at compile time, team-member parameters, per-resource arbitration.

The preemption test covers every shipped skill that acts on a robot: in the
tick a preempting node takes the skill's resources over, the skill's
``finish()`` (its stop, its arm hold, its magnet switch-off, its safe stop)
is dropped on each of them, so the preempting command is what the robot
keeps.
"""

from __future__ import annotations

import textwrap

import pytest
from click.testing import CliRunner
from py_trees.common import Status
from skill_harness import Harness

from marsupial.api.capabilities import Carrier, HasBase, Rotorcraft, provides
from marsupial.api.views import CarrierView, QuadrotorView
from marsupial.trees.arbitration import Arbiter, UnclaimedResourceError
from marsupial.trees.cli import cli
from marsupial.trees.registry import Registry
from marsupial.trees.skill import Skill
from marsupial.world import World
from marsupial.world.robots.attachment import place_link_at

TEAM = """\
mission: m
team:
  carrier: {robot: mobile_manipulator, pose: [0, 0, 0]}
  uav: {robot: bebop2, stored_on: carrier}
"""


def tree(tmp_path, text):
    """``marsupial tree`` of a mission with TEAM and ``text`` as its tree; (exit code, output)."""
    path = tmp_path / "m.yaml"
    path.write_text(TEAM + "tree:\n" + textwrap.indent(textwrap.dedent(text), "  "))
    result = CliRunner().invoke(cli, ["tree", str(path)], env={"COLUMNS": "200"})
    return result.exit_code, result.output, path


def test_a_misspelt_team_member_parameter_fails_at_compile_time_with_a_suggestion(tmp_path):
    code, out, path = tree(tmp_path, "skill: rendezvous\nrobot: uav\nparams: {carrier: carier}\n")
    assert code == 2
    assert f"{path}:8:" in out and "parameter 'carrier' names 'carier', which is not a team member" in out
    assert "did you mean 'carrier'?" in out and "Traceback" not in out


def test_a_team_member_parameter_must_have_the_capability(tmp_path):
    code, out, _ = tree(tmp_path, "skill: rendezvous\nrobot: uav\nparams: {carrier: uav}\n")
    assert code == 2
    assert "names 'uav' (a bebop2), which lacks capability Carrier; expected a team member with capability " \
           "Carrier (carrier)" in out


def test_two_parallel_branches_driving_one_base_are_rejected_naming_both(tmp_path):
    code, out, path = tree(tmp_path, """\
        parallel:
          - {skill: drive_to, name: east, robot: carrier, params: {target: [5, 0]}}
          - sequence:
              - {skill: wait, params: {seconds: 1}}
              - {skill: navigate, name: along, robot: carrier, params: {path: [[0, 0], [0, 5]]}}
    """)
    assert code == 2 and "Traceback" not in out
    assert f"{path}:10" in out  # the second node
    assert f"'along' and 'east' ({path}:7" in out and "both command carrier's base from parallel branches" in out


def test_parallel_branches_on_different_resources_of_one_robot_compile(tmp_path):
    code, out, _ = tree(tmp_path, """\
        parallel:
          - {skill: navigate, robot: carrier, params: {path: [[0, 0], [0, 5]]}}
          - {skill: store, robot: carrier}
    """)
    assert code == 0, out


def test_capabilities_are_the_robot_views():
    assert provides(CarrierView, Carrier) and provides(CarrierView, HasBase)
    assert provides(QuadrotorView, Rotorcraft) and not provides(QuadrotorView, HasBase)
    assert CarrierView.resources() == {"base", "arm", "docking"}


class RecordingArbiter(Arbiter):
    """An arbiter that lists the commands it let through: (tick, node, robot, resource, method)."""

    def __init__(self) -> None:
        super().__init__()
        self.sent: list[tuple[int, str, str, str, str]] = []

    def command(self, resource, command, node_id, node_name, yielding=False, computer=None):
        kept = super().command(resource, command, node_id, node_name, yielding, computer)
        if kept is None:
            self.sent.append((self.tick, node_name, command.robot, resource, type(command).__name__))
        return kept


def take_over(port, resource):
    """The preempting node's command to ``resource`` (one per resource)."""
    {
        "rotors": lambda: port.hover(),
        "base": lambda: port.drive(0.2, 0.0),
        "arm": lambda: port.hold_arm(),
        "docking": lambda: port.docking.magnet_on(),
        "lift": lambda: port.lower_platform(),
        "gripper": lambda: port.close_gripper(),
    }[resource]()


DOCKING = {"scene": "usar_building", "carrier": [-13, -7, 0.73], "uav": [-13.2, -6.9, 2.1, 0.0]}
LANDING = {"scene": None}
#: skill -> (world, robot, parameters)
CASES = {
    "goto": (DOCKING, "uav", {"target": [-12.0, -6.0, 2.0]}),
    "hover": (DOCKING, "uav", {"seconds": 5.0}),
    "drive_to": (DOCKING, "carrier", {"target": [-10.0, -7.0]}),
    "navigate": (DOCKING, "carrier", {"path": [[-13, -7], [-10, -7]]}),
    "explore": (DOCKING, "uav", {}),
    "rendezvous": (DOCKING, "uav", {}),
    "relative_hold": (DOCKING, "uav", {}),
    "track": (DOCKING, "uav", {}),
    "contact": (DOCKING, "uav", {"authorization": None}),
    "store": ("stored", "carrier", {}),
    "deploy": ("stored", "uav", {}),
    "takeoff": (LANDING, "uav", {}),
    "follow": (LANDING, "uav", {}),
    "track_reactive": (LANDING, "uav", {}),
    "track_predictive": (LANDING, "uav", {}),
    "land": (LANDING, "uav", {}),
    "relocalize": (LANDING, "uav", {}),
    "drive_pattern": (LANDING, "ugv", {}),
    "explore_volume": ("mms", "mms", {"bounds": [[-1.6, -3.0, 0.0], [1.6, 0.5, 1.6]]}),
    "aperture_scan": ("mms", "mms", {}),
    "child_link": ("yard_away", "child", {}),
    "child_approach": ("yard_facing", "child", {}),
    "child_match": ("yard_facing", "child", {}),
    "child_direct": ("yard_facing", "child", {}),
    "child_reposition": ("yard_facing", "child", {}),
    "mother_link": ("yard_away", "mother", {}),
    "mother_align": ("yard_facing", "mother", {}),
    "mother_direct": ("yard_facing", "mother", {}),
    "lift": ("yard_boarded", "mother", {}),
    "carry": ("yard_stored", "mother", {"target": (1.0, 0.0)}),
    "release": ("yard_stored", "mother", {}),
    "approach_aperture": ("mms", "mms", {}),
    "analyze_aperture": ("mms", "mms", {}),
    "insert_scout": ("mms", "mms", {}),
    "launch_scout": ("mms", "mms", {"scout": "mms_tello_1"}),
    "scout_takeoff": ("mms_released", "mms_tello_1", {"carrier": "mms"}),
    "scout": ("scout", "scout", {}),
    "scout_land": ("scout", "scout", {}),
    "scout_return": ("scout", "scout", {"home": [0.3, 1.0, 0.85]}),
}


def world_for(setup):
    """A world with the team the case needs."""
    if setup == "stored":
        world = World(seed=3)
        carrier = world.add_robot("mobile_manipulator", "carrier", arm_pose="docking_ready")
        uav = world.add_robot("bebop2", "uav", pose=[3.0, 0.0, 0.0])
        world.bullet.resetBasePositionAndOrientation(uav.body_id, [0.0, 0.0, 1.2], [0, 0, 0, 1])
        carrier.docking.attach_now(uav)
        return world
    if str(setup).startswith("yard"):  # the child 0.6 m before the entrance (x = -0.45 m)
        world = World(scene="marsupial_yard", seed=3)
        mother = world.add_robot("mother_ugv", "mother", pose=[0.0, 0.0, 0.0])
        child = world.add_robot("child_ugv", "child", pose=[-1.15, 0.0, 3.1416 if setup == "yard_away" else 0.0])
        if setup == "yard_stored":
            mother.store(child)
        if setup == "yard_boarded":  # on the platform, down at the floor
            place_link_at(child, "base_footprint", *mother.platform_pose())
        return world
    if setup in ("mms", "mms_released"):
        world = World(scene="collapsed_mockup", seed=3)
        mms = world.add_robot("mms", "mms", pose=[0.3, -2.4, 1.5708])
        if setup == "mms_released":  # the right tello let go in its holster: it takes off
            mms.launch_apparatus("holster_right").release_mav()
        return world
    if setup == "scout":  # a Tello hovering past the amoeba aperture, the MMS before the wall
        world = World(scene="collapsed_mockup", seed=3)
        world.add_robot("mms", "mms", pose=[0.3, -2.4, 1.5708], mavs=False)
        world.add_robot("tello", "scout", pose=[0.3, 0.4, 0.85, 1.5708])
        return world
    if setup["scene"] is None:
        world = World(seed=3)
        world.add_robot("summit_xl", "ugv", pose=[0, 0, 0])
        world.add_robot("ardrone2", "uav", pose=[0, 0, 1.5, 0])
        return world
    world = World(scene=setup["scene"], seed=3)
    world.add_robot("mobile_manipulator", "carrier", pose=setup["carrier"], arm_pose="docking_ready")
    uav = world.add_robot("bebop2", "uav", pose=setup["uav"])
    uav.set_motors(True)
    return world


def test_every_shipped_skill_with_a_robot_is_covered():
    registry = Registry({})
    shipped = set(registry.names("skill"))
    with_robot = {name for name in shipped if registry.resolve("skill", name).uses_robot}
    assert with_robot == set(CASES)


@pytest.mark.parametrize("name", sorted(CASES))
def test_a_preempting_command_survives_the_finish_of_the_preempted_skill(name):
    setup, robot, params = CASES[name]
    cls = Registry({}).resolve("skill", name)
    with world_for(setup) as world:
        harness = Harness(world)
        arbiter = harness.context.arbiter = RecordingArbiter()
        skill = harness.node(cls, robot, **params)
        host, bridge = harness.host(skill), harness.bridge
        for _ in range(3):  # the skill runs and commands its resources
            bridge.apply(host.tick(bridge.tick_input()))
            world.step(0.1)
        assert skill.status == Status.RUNNING, skill.feedback_message
        claims = skill.claimed(skill.params, robot)
        resources = sorted({(r, res) for r, res in claims if res != "*"} | {
            (r, res) for r, res in claims if res == "*" for res in harness.context.views[r].resources()
        })
        takeover_cls = type("Takeover", (Skill,), {"claims": tuple(f"{r}/{res}" for r, res in resources)})
        takeover = harness.node(takeover_cls, robot, name="takeover")
        harness.feed(skill)
        tick = arbiter.tick
        for member, resource in resources:
            take_over(takeover.member(member), resource)
        skill.stop(Status.INVALID)  # preempted in the tick the other node took its resources over
        after = [s for s in arbiter.sent if s[0] == tick and s[1] == skill.name]
        assert after == [], f"{name}'s finish() overwrote the preempting command: {after}"
        assert skill.stopped_by is not None and skill.stopped_by.node_name == "takeover"
        for member, resource in resources:
            assert arbiter.last(member, resource).node_name == "takeover"


def test_a_command_to_a_resource_not_claimed_is_refused():
    class Sneaky(Skill):
        claims = ("rotors",)

        def step(self):
            self.member("carrier").drive(1.0, 0.0)
            return Status.RUNNING

    with World(seed=1) as world:
        world.add_robot("mobile_manipulator", "carrier")
        world.add_robot("bebop2", "uav", pose=[0, 0, 1, 0])
        harness = Harness(world)
        with pytest.raises(UnclaimedResourceError, match="commands Drive of 'carrier' \\(resource 'base'\\)"):
            harness.run(harness.node(Sneaky, robot="uav"), 0.2)
