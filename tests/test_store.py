"""Carriers that start a run with a child stored (`stored_on` in a mission)."""

import numpy as np
import pytest

from marsupial.world import World


def test_mobile_manipulator_stores_a_bebop2_locked_on_part_a_and_charging():
    with World(seed=1) as world:
        carrier = world.add_robot("mobile_manipulator", name="carrier", pose=[0, 0, 0])
        uav = world.add_robot("bebop2", name="uav", pose=[3, 0, 0])
        uav.battery.soc = 0.5
        carrier.store(uav)
        assert carrier.docking.state == "locked"
        assert not uav.motors_on and uav.charging
        carrier.drive(0.5, 0.0)
        world.step(4.0)
        gap = np.linalg.norm(carrier.link_pose("part_a")[0] - uav.link_pose("part_b")[0])
        assert gap < 0.005  # carried rigidly, not dropped
        assert carrier.pose()[0][0] > 1.0
        assert uav.battery.soc > 0.5


def test_second_store_on_the_same_part_a_is_refused():
    with World() as world:
        carrier = world.add_robot("mobile_manipulator", name="carrier")
        carrier.store(world.add_robot("bebop2", name="a", pose=[3, 0, 0]))
        with pytest.raises(ValueError, match="already holds a"):
            carrier.store(world.add_robot("bebop2", name="b", pose=[5, 0, 0]))


def test_mother_ugv_stores_a_child_up_in_the_capsule():
    with World(seed=1) as world:
        mother = world.add_robot("mother_ugv", name="mother", pose=[0, 0, 0])
        child = world.add_robot("child_ugv", name="child", pose=[2, 0, 0])
        mother.store(child)
        mother.drive(0.3, 0.0)
        world.step(3.0)
        assert mother.platform_height() == pytest.approx(mother.lift_travel, abs=0.01)
        assert mother.child_on_platform(child)
        assert mother.state()["carried"] == ["child"]
