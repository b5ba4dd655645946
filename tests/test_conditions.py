"""Built-in conditions read what the robots sense.

The battery monitor, the LiDAR scan, the estimate against the declared plan.
"""

import math

import pytest
from skill_harness import Harness

from marsupial.api.errors import UnknownNameError
from marsupial.tools.rig import live_view
from marsupial.trees.conditions import BatteryBelow, DifficultArea, ObstacleAhead
from marsupial.trees.skill import RunContext
from marsupial.world import World
from marsupial.world.priors import building_plan


def holds(harness, cls, robot, **params):
    condition = harness.node(cls, robot, **params)
    harness.feed(condition)
    return condition.check()


def test_battery_below_reads_the_whole_percent_gauge():
    with World(seed=1) as world:
        world.add_robot("bebop2", "uav", pose=[0, 0, 1.0, 0], battery_soc=0.2049)
        harness = Harness(world)
        assert not holds(harness, BatteryBelow, "uav", threshold=0.2)  # no gauge sample yet
        world.step(0.2)
        assert live_view(world, "uav").battery().soc_percent == 20.0  # 20.49 % reads 20 %
        assert not holds(harness, BatteryBelow, "uav", threshold=0.2)
        assert holds(harness, BatteryBelow, "uav", threshold=0.201)


def test_obstacle_ahead_sees_a_post_in_the_lidar_scan():
    with World(scene="open_field", seed=1) as world:  # marker post of radius 0.15 m at (60, 60)
        # front 0.23 m ahead: post 0.72 m beyond it
        world.add_robot("mobile_manipulator", "carrier", pose=[58.9, 60, 0])
        harness = Harness(world)
        world.step(0.1)
        assert holds(harness, ObstacleAhead, "carrier", distance=1.0)
        assert not holds(harness, ObstacleAhead, "carrier", distance=0.5)
        assert not holds(harness, ObstacleAhead, "carrier", distance=1.0, width=0.6, front=1.2)  # corridor beyond it


def test_difficult_area_compares_the_estimate_with_the_declared_zones_and_door_frames():
    with World(scene="usar_building", seed=1) as world:
        world.add_robot("mobile_manipulator", "near", pose=[-13, -7, 0])  # 1.35 m east of the entrance door frame
        world.add_robot("mobile_manipulator", "hall", pose=[-10, -5, 0])
        harness = Harness(world)
        world.step(0.1)
        assert holds(harness, DifficultArea, "near", distance=1.5)
        assert not holds(harness, DifficultArea, "near", distance=1.0)
        assert not holds(harness, DifficultArea, "hall", distance=1.0)
        assert holds(harness, DifficultArea, "hall", distance=1.0, tags=("hall",))


def test_the_building_plan_declares_structure_zones_and_paths_but_no_debris_or_target():
    with World(scene="usar_building") as world:
        plan = building_plan(world.scene)
        assert {t for e in plan.structure for t in e.tags} <= {"wall", "door_frame", "exterior"}
        assert len(plan.structure) == 42 and not any("debris" in e.tags or "target" in e.tags for e in plan.structure)
        assert plan.path("operator_path")[0] == pytest.approx([-13, -7])
        assert [z.label for z in plan.zones_at([1.5, 0.0], tag="corridor")] == ["corridor"]
        door = next(e for e in plan.tagged("door_frame") if e.label == "door_1_jamb_1")
        assert door.distance([-10.74, 4.0 + 0.14 + 1.0]) == pytest.approx(1.0)
        with pytest.raises(UnknownNameError, match="building_plan"):
            RunContext(priors={"building_plan": plan}).prior("floor_plan")
    assert not hasattr(plan.structure[0], "body_id") and math.isfinite(plan.size[0])
