"""store and deploy (Narváez §IV-B, §IV-C, §V-A).

Storage with the ground sensors clear and charging; release once thrust holds.

Skill-level runs in a small harness against the real world; the deploy run is
logged to MCAP and its outcome read back from the log.
"""

import math

import numpy as np
import py_trees
import pybullet
import pytest
from py_trees.common import Status
from skill_harness import Harness

from marsupial.geometry import yaw_of
from marsupial.skills.uav_docking.storage import Deploy, Store
from marsupial.trees.replay import read_log
from marsupial.world import World
from marsupial.world.contacts import ContactMonitor
from marsupial.world.robots.attachment import place_link_at
from marsupial.world.world import GRAVITY

CHARGE_CURRENT = 3.5  # A, the 12.6 V / 3.5 A charger of §V-A
CAPACITY_AH = 2.7  # Bebop 2 battery, §V-B


def test_store_carries_the_uav_clear_of_the_ground_sensors_and_charges_it():
    with World(seed=4) as world:
        carrier = world.add_robot("mobile_manipulator", "carrier", arm_pose="docking_ready",
                                  sensors={"front_rgbd": {"segmentation": True}})
        uav = world.add_robot("bebop2", "uav", pose=[3.0, 0.0, 0.0], battery_soc=0.5)
        world.bullet.resetBasePositionAndOrientation(uav.body_id, [0.0, 0.0, 1.2], [0, 0, 0, 1])
        carrier.docking.attach_now(uav)  # locked on Part A at the end of a contact phase, arm up
        world.step(0.1)
        before = carrier.lidar.read().data
        assert uav.body_id not in before.hit_bodies  # up over the base: above the scan plane too
        harness = Harness(world)
        store = harness.node(Store, "carrier")
        assert harness.run(store, 10.0) == Status.SUCCESS
        assert np.abs(carrier.joint_positions() - carrier.arm_pose("storage")).max() <= 0.02
        assert harness.blackboard("carrier/uav_stored") is True and harness.blackboard("carrier/docking") is False

        # the ground sensors see past the stored UAV: a full LiDAR sweep and the front RGB-D image
        scan = carrier.lidar.read().data
        assert uav.body_id not in scan.hit_bodies
        assert np.isfinite(scan.ranges).sum() == 0  # open floor: no echo at all, nothing of the robot team
        # a frame rendered now (the stream lags by its latency)
        segmentation = carrier.front_rgbd.measure().segmentation
        assert not np.any(segmentation == uav.body_id)
        carrier.drive(1.0, 0.5)  # carried rigidly while driving and turning
        world.step(2.0)
        assert carrier.docking.docked is uav and carrier.docking.distance_to(uav) < 0.005
        assert uav.body_id not in carrier.lidar.read().data.hit_bodies

        # charging while stored: the state of charge rises at 3.5 A
        assert uav.charging and uav.battery.current_A == pytest.approx(-CHARGE_CURRENT)
        soc, t = uav.battery.soc, world.now
        world.step(30.0)
        assert uav.battery.soc - soc == pytest.approx(CHARGE_CURRENT * (world.now - t) / 3600.0 / CAPACITY_AH, rel=0.02)


def test_store_fails_without_a_docked_uav():
    with World() as world:
        world.add_robot("mobile_manipulator", "carrier")
        harness = Harness(world)
        store = harness.node(Store, "carrier")
        assert harness.run(store, 1.0) == Status.FAILURE
        assert "no UAV" in store.feedback_message


@pytest.fixture(scope="module")
def deployment(tmp_path_factory):
    """Deploy a stored UAV from a carrier driving at the docking speed; the run logged to MCAP."""
    path = tmp_path_factory.mktemp("deploy") / "deploy.mcap"
    with World(seed=5) as world:
        carrier = world.add_robot("mobile_manipulator", "carrier")
        uav = world.add_robot("bebop2", "uav", pose=[3.0, 0.0, 0.0], battery_soc=0.8)
        carrier.store(uav)
        monitor = ContactMonitor(world, "uav", "carrier", allowed_links_b=["part_a"])
        world.add_actor(monitor)
        harness = Harness(world, log_path=path)
        deploy = harness.node(Deploy, "uav")
        carrier.drive(0.5, 0.0)  # the carrier drives on at 0.5 m/s (§V-B-1) while the UAV takes off
        samples = []  # (t, docked, thrust, (axial, lateral, tilt) of Part B from Part A)
        weight = uav.mass * GRAVITY

        def record():
            samples.append((world.now, uav.docked, uav.thrust, carrier.docking.offset_to(uav)))

        status = harness.run(deploy, 20.0, record)
        world.step(2.0)
        harness.close()
        final = {"status": status, "arm": carrier.joint_targets(), "stowed": carrier.arm_pose("stowed"),
                 "motors": uav.motors_on}
        yield read_log(path), samples, weight, monitor.events, final


@pytest.mark.slow
def test_deploy_releases_only_once_the_thrust_holds_the_weight(deployment):
    log, samples, weight, _, final = deployment
    assert final["status"] == Status.SUCCESS
    released = [e for e in log.events_of("state_change") if e.get("phase") == "released"]
    assert len(released) == 1
    assert released[0]["thrust"] >= released[0]["weight"] == pytest.approx(weight)
    spin_up = next(e for e in log.events_of("state_change") if e.get("phase") == "spin_up")
    assert released[0]["t"] - spin_up["t"] >= 0.45  # the rotors need ≈ 0.5 s to reach hover thrust
    still_docked = [s for s in samples if s[1]]
    assert all(thrust < weight for t, _, thrust, _ in still_docked if t < released[0]["t"] - 0.05)
    assert final["motors"]


@pytest.mark.slow
def test_deploy_climbs_clear_of_the_arm_without_touching_the_carrier(deployment):
    log, samples, _, contacts, final = deployment
    assert contacts == []  # zero unintended UAV-robot contacts (Part A excepted)
    clear = next(e for e in log.events_of("state_change") if e.get("phase") == "clear")
    t, p_uav = log.poses("uav")
    _, p_carrier = log.poses("carrier")
    after = t >= clear["t"]
    height_above_base = p_uav[after, 2] - p_carrier[after, 2]
    assert height_above_base.min() > 1.1  # 0.95 m (Part A raised) + ≈ 0.6 m clearance - base height
    axial, lateral, _ = np.array([s[3] for s in samples if not s[1]]).T
    assert axial.min() > -0.005 and axial[-1] > 0.55  # always above Part A, finally 0.6 m above it
    # straight up out of Part A's cone though the carrier drives at 0.5 m/s (the UAV flies on its own estimate,
    # handed over at the release, and the carrier's over the team link: 4.3 cm at most in this run)
    assert lateral[axial < 0.1].max() < 0.05
    assert lateral.max() < 0.15  # and kept over it while climbing (the UAV accelerates to the carrier's speed)
    assert np.allclose(final["arm"], final["stowed"])  # the arm folds back for driving


def test_deploy_hands_over_the_heading_the_uav_was_locked_with():
    """A UAV the tracking docked facing the carrier's rear (Part B half a turn on Part A, ``part_b_yaw`` = π, written
    by ``contact`` at the lock) starts its flight with its true heading: its optical flow is rotated the right way."""
    with World(seed=6) as world:
        carrier = world.add_robot("mobile_manipulator", "carrier")
        uav = world.add_robot("bebop2", "uav", pose=[3.0, 0.0, 0.0])
        carrier.reset_arm("storage")
        p_A, q_A = carrier.link_pose("part_a")
        _, turned = pybullet.multiplyTransforms([0, 0, 0], list(q_A), [0, 0, 0], [0, 0, 1, 0])  # π about Part A's z
        place_link_at(uav, "part_b", p_A, turned)
        carrier.docking._attach(uav)  # locked as a contact phase leaves it
        harness = Harness(world)
        py_trees.blackboard.Blackboard.set("/carrier/part_b_yaw", math.pi)
        deploy = harness.node(Deploy, "uav")
        while getattr(deploy, "phase", None) is not Deploy.Phase.CLIMB and world.now < 10.0:  # up to the release
            assert harness.run(deploy, 0.1) == Status.RUNNING
        assert harness.blackboard("carrier/part_b_yaw") is None  # released: no UAV on Part A any more
        assert harness.run(deploy, 0.3) == Status.RUNNING  # the hand-over crosses the team link (20 ms + jitter)
        error = math.remainder(uav.estimator.estimate().yaw - yaw_of(uav.pose()[1]), math.tau)
        assert abs(error) < 0.05
