"""Docking device of Narváez et al. (§IV-C): magnet capture within D_c, lever lock, rigid carry, release."""

import math

import numpy as np
import pybullet
import pytest

from marsupial.world import World
from marsupial.world.robots import ROBOT_KINDS
from marsupial.world.robots.base import Robot
from marsupial.world.robots.docking_device import CAPTURE_DISTANCE, CONTACT_DISTANCE, LOCK_TIME, DockingDevice
from marsupial.world.world import GRAVITY

STAND_IN_URDF = """<?xml version="1.0"?>
<robot name="stand_in">
  <link name="base_link">
    <inertial><mass value="0.45"/><inertia ixx="0.0016" iyy="0.0016" izz="0.003" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><box size="0.2 0.2 0.05"/></geometry></visual>
    <collision><geometry><box size="0.2 0.2 0.05"/></geometry></collision>
  </link>
  <link name="part_b">
    <inertial><origin xyz="0 0 0.0125"/><mass value="0.01"/>
      <inertia ixx="1e-6" iyy="1e-6" izz="1e-6" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><origin xyz="0 0 0.0125"/><geometry><cylinder radius="0.016" length="0.025"/></geometry></visual>
    <collision><origin xyz="0 0 0.0125"/><geometry><cylinder radius="0.016" length="0.025"/></geometry></collision>
  </link>
  <joint name="part_b_joint" type="fixed">
    <parent link="base_link"/><child link="part_b"/><origin xyz="0 0 -0.05"/>
  </joint>
</robot>
"""


class StandIn(Robot):
    """A box hovering on an ideal lift force with a Part B adapter underneath; records docking calls."""

    kind = "stand_in"

    def __init__(self, world, name, urdf, position):
        super().__init__(world, name)
        self.load_urdf(str(urdf), position)
        cid = self.cid
        self.mass = sum(pybullet.getDynamicsInfo(self.body_id, i, physicsClientId=cid)[0] for i in self.links.values())
        self.hovering = True
        self.calls = []

    def pre_physics(self, dt):
        if self.hovering:
            p, _ = pybullet.getBasePositionAndOrientation(self.body_id, physicsClientId=self.cid)
            pybullet.applyExternalForce(
                self.body_id, -1, [0, 0, self.mass * GRAVITY], p, pybullet.WORLD_FRAME, physicsClientId=self.cid
            )

    def on_docked(self, charger):
        self.calls.append(("docked", charger))
        self.hovering = False  # motors off

    def on_released(self):
        self.calls.append(("released",))

    def safe_stop(self):
        pass


@pytest.fixture
def scene(tmp_path):
    urdf = tmp_path / "stand_in.urdf"
    urdf.write_text(STAND_IN_URDF)
    with World(seed=2) as world:
        mm = world.add_robot("mobile_manipulator", arm_pose="docking_ready")
        uav = StandIn(world, "stand_in", urdf, [1.0, 1.0, 1.0])
        world.robots[uav.name] = uav
        world.add_actor(uav)
        yield world, mm, uav


def _place(mm, uav, gap, lateral=0.0, tilt=0.0):
    """Put the stand-in's Part B ``gap`` m above Part A's face, ``lateral`` m off its axis, tilted about x."""
    cid = mm.cid
    p_a, q_a = mm.link_pose("part_a")
    R_a = np.array(pybullet.getMatrixFromQuaternion(q_a)).reshape(3, 3)
    q = pybullet.getQuaternionFromEuler([tilt, 0.0, 0.0])
    R = np.array(pybullet.getMatrixFromQuaternion(q)).reshape(3, 3)
    p_b_base = np.array([0.0, 0.0, -0.05])  # Part B in the stand-in's base frame
    p_b = p_a + gap * R_a[:, 2] + lateral * R_a[:, 0]
    pybullet.resetBasePositionAndOrientation(uav.body_id, (p_b - R @ p_b_base).tolist(), q, physicsClientId=cid)
    pybullet.resetBaseVelocity(uav.body_id, [0, 0, 0], [0, 0, 0], physicsClientId=cid)


def _relative(mm, uav):
    p_a, q_a = mm.link_pose("part_a")
    p_b, q_b = uav.link_pose("part_b")
    R_a = np.array(pybullet.getMatrixFromQuaternion(q_a)).reshape(3, 3)
    R_b = np.array(pybullet.getMatrixFromQuaternion(q_b)).reshape(3, 3)
    return R_a.T @ (p_b - p_a), R_a.T @ R_b


def test_magnet_pulls_part_b_within_the_capture_distance_into_contact(scene):
    world, mm, uav = scene
    dock = mm.docking
    assert dock.capture_distance == CAPTURE_DISTANCE == 0.010  # D_c, §IV-C
    _place(mm, uav, CAPTURE_DISTANCE + 0.005)
    dock.magnet_on()
    assert dock.state == "magnet"
    world.step(0.5)
    assert dock.distance_to(uav) == pytest.approx(CAPTURE_DISTANCE + 0.005, abs=1e-3)  # out of reach: no pull
    _place(mm, uav, CAPTURE_DISTANCE - 0.003)
    assert dock.aligned(uav) and not dock.in_contact(uav)
    world.step(0.3)
    assert dock.in_contact(uav) and dock.distance_to(uav) <= CONTACT_DISTANCE
    assert dock.aligned(uav)


def test_contact_is_the_gap_between_the_faces_within_the_cone_s_tolerances(scene):
    world, mm, uav = scene
    dock = mm.docking
    _place(mm, uav, 0.002, lateral=0.008)  # faces touching, 8 mm off the axis: the cone centres it
    assert dock.distance_to(uav) > CONTACT_DISTANCE and dock.in_contact(uav)
    _place(mm, uav, 0.002, lateral=dock.lateral_tolerance + 0.005)  # beside the cone
    assert not dock.in_contact(uav)
    _place(mm, uav, -0.5)  # on the axis, half a metre below Part A
    assert not dock.in_contact(uav)
    _place(mm, uav, 0.002, lateral=0.008)
    assert dock.lock() is True
    world.step(LOCK_TIME + 0.05)
    assert dock.state == "locked" and dock.docked is uav


def test_lock_refuses_without_contact(scene):
    world, mm, uav = scene
    dock = mm.docking
    _place(mm, uav, 0.02)
    constraints = pybullet.getNumConstraints(physicsClientId=world.client_id)
    assert dock.lock() is False
    world.step(LOCK_TIME + 0.1)
    assert dock.state == "open" and not dock.locking and dock.docked is None
    assert pybullet.getNumConstraints(physicsClientId=world.client_id) == constraints
    assert uav.calls == []


def test_lock_holds_the_uav_rigidly_while_driving_and_moving_the_arm_and_release_frees_it(scene):
    world, mm, uav = scene
    dock = mm.docking
    _place(mm, uav, 0.005)
    dock.magnet_on()
    world.step(0.2)
    assert dock.lock() is True
    assert dock.locking and dock.state == "magnet"
    for _ in range(3):  # a skill may repeat the command every tick: the levers keep closing
        world.step((LOCK_TIME - 0.1) / 3)
        assert dock.lock() is True
    assert dock.state == "magnet" and uav.calls == []  # the levers are still closing
    world.step(0.15)
    assert dock.state == "locked" and dock.docked is uav and not dock.locking
    assert uav.calls == [("docked", True)]  # the carrier's 12.6 V / 3.5 A charger, §V-A
    assert mm.state()["docking"] == {"state": "locked", "docked": "stand_in", "locking": False}
    dock.magnet_off()
    assert dock.state == "locked"  # the levers hold without the magnet

    p_rel, R_rel = _relative(mm, uav)
    start = mm.pose()[0]
    mm.set_joint_targets("storage")
    mm.drive(1.0, 0.5)
    worst = 0.0
    for _ in range(8):
        world.step(0.25)
        p_now, R_now = _relative(mm, uav)
        worst = max(worst, np.linalg.norm(p_now - p_rel))
        angle = math.acos(min(1.0, (np.trace(R_rel.T @ R_now) - 1) / 2))
        assert angle < math.radians(1.0)
    assert worst < 0.002
    assert np.linalg.norm(mm.pose()[0] - start) > 1.2 and mm.arm_at_target(0.01)

    mm.stop()
    world.step(1.2)  # the base comes to rest
    assert np.linalg.norm(_relative(mm, uav)[0] - p_rel) < 0.002
    constraints = pybullet.getNumConstraints(physicsClientId=world.client_id)
    dock.release()
    assert dock.state == "open" and dock.docked is None
    assert uav.calls[-1] == ("released",)
    assert pybullet.getNumConstraints(physicsClientId=world.client_id) == constraints - 1
    uav.hovering = True  # it takes off from Part A
    pybullet.resetBaseVelocity(uav.body_id, [0, 0, 0.5], [0, 0, 0], physicsClientId=world.client_id)
    world.step(0.5)
    assert dock.distance_to(uav) == pytest.approx(0.25, abs=0.02)


def test_alignment_measures_offset_and_tilt(scene):
    _, mm, uav = scene
    dock = mm.docking
    _place(mm, uav, 0.02, lateral=0.005)
    axial, lateral, tilt = dock.offset_to(uav)
    assert (axial, lateral, tilt) == pytest.approx((0.02, 0.005, 0.0), abs=1e-5)
    assert dock.aligned(uav)
    _place(mm, uav, 0.02, lateral=0.03)
    assert not dock.aligned(uav)
    _place(mm, uav, 0.02, tilt=math.radians(25))
    assert not dock.aligned(uav)
    with pytest.raises(ValueError, match="contact_distance"):
        DockingDevice(mm, capture_distance=0.002, contact_distance=0.004)


@pytest.mark.skipif("bebop2" not in ROBOT_KINDS, reason="needs the bebop2 robot kind")
def test_bebop2_docks_charges_is_stored_clear_of_the_front_sensors_and_deploys():
    with World(seed=5) as world:
        mm = world.add_robot(
            "mobile_manipulator", arm_pose="docking_ready", sensors={"front_rgbd": {"segmentation": True}}
        )
        p_a, _ = mm.link_pose("part_a")
        # Part B sits at (0.11, 0, -0.08) in the Bebop 2's base frame: hover it 6 mm above Part A
        uav = world.add_robot("bebop2", pose=[p_a[0] - 0.11, p_a[1], p_a[2] + 0.086, 0.0], battery_soc=0.5)
        dock = mm.docking
        assert dock.aligned(uav) and dock.distance_to(uav) == pytest.approx(0.006, abs=1e-3)
        dock.magnet_on()
        world.step(0.3)
        assert dock.in_contact(uav)
        assert dock.lock()
        world.step(LOCK_TIME + 0.05)
        assert dock.state == "locked" and uav.docked and uav.charging and not uav.motors_on

        mm.set_joint_targets("storage")
        world.step(1.5)
        assert mm.arm_at_target(0.01)
        assert uav.body_id not in mm.lidar.read().data.hit_bodies
        assert mm.front_rgbd.read() is None  # its first frame arrives 50 ms later
        world.step(0.05)
        assert uav.body_id not in np.unique(mm.front_rgbd.read().data.segmentation)
        p_rel, _ = _relative(mm, uav)
        mm.drive(1.5, 0.0)
        world.step(1.5)
        assert np.linalg.norm(_relative(mm, uav)[0] - p_rel) < 0.002

        mm.stop()
        mm.set_joint_targets("docking_ready")
        world.step(2.0)
        uav.set_motors(True)  # armed while docked, so it hovers when released (deploy)
        z_release = uav.pose()[0][2]
        dock.release()
        world.step(1.0)
        assert not uav.docked and dock.state == "open"
        assert uav.pose()[0][2] == pytest.approx(z_release, abs=0.05)
