"""Unintended-contact queries and the contact monitor, on simple bodies."""

import pybullet
import pytest

from marsupial.api.errors import UnknownNameError
from marsupial.world import World
from marsupial.world.contacts import ContactMonitor, contacts_between, resolve_body
from marsupial.world.robots.base import Robot

ARM_URDF = """<robot name="test_arm">
  <link name="base_link">
    <inertial><mass value="5"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><box size="0.2 0.2 0.2"/></geometry></visual>
    <collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision>
  </link>
  <link name="forearm">
    <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><box size="0.2 0.2 0.2"/></geometry></visual>
    <collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision>
  </link>
  <link name="part_a">
    <inertial><mass value="0.2"/><inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><box size="0.2 0.2 0.2"/></geometry></visual>
    <collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision>
  </link>
  <joint name="elbow" type="fixed"><parent link="base_link"/><child link="forearm"/><origin xyz="0.5 0 0"/></joint>
  <joint name="wrist" type="fixed"><parent link="forearm"/><child link="part_a"/><origin xyz="0.5 0 0"/></joint>
</robot>
"""
TOP = 0.6  # m: top face of the arm's boxes (centres at z = 0.5)


@pytest.fixture
def world(tmp_path):
    """A world with a fixed three-link 'arm' robot along +x (base_link, forearm at x=0.5, part_a at x=1)."""
    urdf = tmp_path / "test_arm.urdf"
    urdf.write_text(ARM_URDF)
    with World() as w:
        arm = Robot(w, "arm")
        arm.body_id = pybullet.loadURDF(str(urdf), [0, 0, 0.5], useFixedBase=True, physicsClientId=w.client_id)
        arm.links = {"base_link": -1, "forearm": 0, "part_a": 1}
        w.robots["arm"] = arm
        yield w


def _ball(world, x, z, mass=0.1, radius=0.05, y=0.0):
    shape = pybullet.createCollisionShape(pybullet.GEOM_SPHERE, radius=radius, physicsClientId=world.client_id)
    return pybullet.createMultiBody(mass, shape, -1, [x, y, z], physicsClientId=world.client_id)


def test_monitor_flags_a_forbidden_link_and_ignores_the_allowed_one(world):
    on_part_a = _ball(world, 1.0, TOP + 0.3)  # lands on the allowed docking link
    on_forearm = _ball(world, 0.5, TOP + 0.3)  # lands on a forbidden link
    allowed = ContactMonitor(world, on_part_a, "arm", allowed_links_b=["part_a"])
    forbidden = ContactMonitor(world, on_forearm, "arm", allowed_links_b=["part_a"])
    seen = []
    forbidden.on_contact = seen.append
    world.add_actor(allowed)
    world.add_actor(forbidden)
    world.step(1.0)

    assert allowed.events == []
    assert len(forbidden.events) == 1 and seen == forbidden.events
    event = forbidden.events[0]
    assert (event.body_b, event.link_b, event.link_a) == ("arm", "forearm", "base")
    assert event.body_a == f"body_{on_forearm}"
    fall_time = (2 * (0.3 - 0.05) / 9.81) ** 0.5
    assert event.t_start == pytest.approx(fall_time, abs=0.02)
    assert event.ongoing and event.t_end == pytest.approx(world.now)
    assert event.max_normal_force > 0.1 * 9.81 * 0.5  # carries the ball's weight at least
    assert event.position[0] == pytest.approx(0.5, abs=0.06) and event.position[2] == pytest.approx(TOP, abs=0.01)

    # the allowed contact exists: it is only filtered out
    touching = contacts_between(world, on_part_a, "arm")
    assert {c.link_b for c in touching} == {"part_a"}
    assert contacts_between(world, on_part_a, "arm", allowed_links_b=["part_a"]) == []


def test_a_touch_ends_and_a_new_one_is_a_new_event(world):
    ball = _ball(world, 0.5, TOP + 0.05)
    monitor = ContactMonitor(world, ball, world.robot("arm"))
    world.add_actor(monitor)
    world.step(0.2)
    assert len(monitor.active) == 1
    pybullet.resetBasePositionAndOrientation(ball, [0.0, 0.0, 2.0], [0, 0, 0, 1], physicsClientId=world.client_id)
    world.step(0.1)
    assert monitor.active == [] and not monitor.events[0].ongoing
    assert monitor.events[0].t_end < 0.21
    world.step(0.6)  # falls back onto the base link
    assert [e.link_b for e in monitor.events] == ["forearm", "base_link"]


def test_margin_reports_near_misses_with_their_distance(world):
    ball = _ball(world, 0.5, TOP + 0.05 + 0.02, mass=0.0)  # held 2 cm above the forearm
    world.step()
    assert contacts_between(world, ball, "arm") == []
    near = contacts_between(world, ball, "arm", margin=0.05)
    assert [c.link_b for c in near] == ["forearm"]
    assert near[0].distance == pytest.approx(0.02, abs=1e-3)
    assert near[0].normal_force == 0.0


def test_bodies_are_named_by_robot_scene_label_or_id():
    with World("usar_building") as world:
        target = world.scene.object("target")
        x, y, z = target.position
        ball = _ball(world, x, z + target.size[2] / 2 + 0.1, y=y)
        world.step(0.5)
        (contact, *_) = contacts_between(world, ball, "target")
        assert (contact.body_b, contact.link_b) == ("target", "base")
        assert resolve_body(world, target.body_id).name == "target"


def test_unknown_body_or_link_names_list_the_known_ones(world):
    with pytest.raises(UnknownNameError, match="unknown body name 'uav'.*Known: arm"):
        contacts_between(world, "uav", "arm")
    with pytest.raises(UnknownNameError, match="unknown arm link 'part_b'. Did you mean 'part_a'"):
        ContactMonitor(world, "arm", "arm", allowed_links_a=["part_b"])
