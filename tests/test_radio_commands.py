"""Commands computed on one robot's computer for another robot cross the team link (docs/sensing.md).

Piloting commands are streamed unacknowledged (a lost one is gone); one-shot commands are acknowledged and
retried (a loss costs a retry timeout) and keep their order. A node declares where it runs with ``runs_on``.
"""

import pytest

from marsupial.api.commands import FlyVelocity, LinkSend, SafeStop, SetJointTargets, SetMotors
from marsupial.api.ticks import TickOutput
from marsupial.api.views import QuadrotorView
from marsupial.trees.arbitration import Arbiter
from marsupial.trees.bridge import WorldBridge
from marsupial.trees.registry import Registry
from marsupial.world import World
from marsupial.world.team_link import TeamLinkConfig


def test_a_command_for_another_robot_leaves_as_the_computers_radio_message():
    arbiter = Arbiter()
    arbiter.new_tick()
    arbiter.command("rotors", FlyVelocity("uav", 0.5, 0.0, 0.0), 1, "track", computer="carrier")
    arbiter.command("rotors", SetMotors("uav", True), 1, "track", computer="carrier")
    arbiter.command("arm", SetJointTargets("carrier", "stow"), 1, "track", computer="carrier")
    arbiter.new_tick()
    arbiter.safe_stop(QuadrotorView, "uav", 2, "deploy", computer="carrier")
    sent = [command for _, command in arbiter.take()]
    assert sent[0] == LinkSend("carrier", "uav/pilot", FlyVelocity("uav", 0.5, 0.0, 0.0), reliable=False)
    assert sent[1] == LinkSend("carrier", "uav/command", SetMotors("uav", True), reliable=True)
    assert sent[2] == SetJointTargets("carrier", "stow")  # its own arm: no radio
    assert sent[3] == LinkSend("carrier", "uav/command", SafeStop("uav", "rotors"), reliable=True)


@pytest.mark.parametrize("kind", ["rendezvous", "relative_hold", "track", "contact", "deploy"])
def test_the_uav_docking_skills_run_on_the_carrier(kind):
    """Narváez §V-B-2: the computation is on the mobile manipulator; the UAV only stabilises itself."""
    node = Registry({}).resolve("skill", kind)
    assert node.runs_on == "carrier"


def test_a_one_shot_command_reaches_the_uav_only_after_the_radio_has_carried_it():
    link = TeamLinkConfig(latency_s=0.1, jitter_s=0.0, drop=0.0)
    with World(seed=2, team_link=link) as world:
        world.add_robot("bebop2", name="uav", pose=[0.0, 0.0, 0.0, 0.0])
        bridge = WorldBridge(world, None)
        world.step(0.2)
        bridge.apply(TickOutput(commands=(LinkSend("carrier", "uav/command", SetMotors("uav", True), True),)))
        world.step(0.05)
        assert not bridge.tick_input().robots["uav"].motors_on  # still on the air
        world.step(0.1)
        assert bridge.tick_input().robots["uav"].motors_on
        heard = [m for m in world.team_link.take_delivered() if m.topic == "uav/command"]
        assert not heard  # the firmware's, no node's


def test_reliable_messages_survive_losses_late_and_in_order_and_piloting_ones_do_not():
    link = TeamLinkConfig(latency_s=0.02, jitter_s=0.01, drop=0.3, retry_s=0.5, max_retries=100)
    with World(seed=11, team_link=link) as world:
        heard: list[tuple[float, int]] = []
        world.team_link.listen("uav/command", lambda n: heard.append((world.now, n)))
        sent_at = {}
        for n in range(60):
            sent_at[n] = world.now
            world.team_link.send("carrier", "uav/command", n, reliable=True)
            world.team_link.send("carrier", "uav/pilot", n)
            world.step(0.05)
        world.step(60 * 0.5)
        assert [n for _, n in heard] == list(range(60))  # none lost, in the order sent
        delays = [t - sent_at[n] for t, n in heard]
        assert max(delays) >= 0.5  # a loss cost a retry timeout
        assert world.team_link.retried >= 10  # about 0.3 / 0.7 of 60
        piloting = {m.payload for m in world.team_link.take_delivered() if m.topic == "uav/pilot"}
        assert 30 <= len(piloting) <= 52  # about 30 % of 60 lost for good
        assert world.team_link.dropped == 60 - len(piloting)


def test_a_reliable_message_is_lost_after_its_retries():
    link = TeamLinkConfig(drop=1.0, max_retries=3)
    with World(seed=1, team_link=link) as world:
        world.team_link.send("carrier", "uav/command", "arm", reliable=True)
        world.step(3.0)
        assert (world.team_link.retried, world.team_link.dropped) == (0, 1)


def test_runs_on_must_name_a_parameter():
    from marsupial.trees.skill import NodeParams, Skill

    with pytest.raises(TypeError, match="runs_on names 'carrier', which is not one of its parameters"):
        class Remote(Skill[NodeParams]):
            """A skill that says it runs on a member it has no parameter for."""

            runs_on = "carrier"
