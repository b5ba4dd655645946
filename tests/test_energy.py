"""Energy: LiPo battery, charger (Narváez §V-A: 12.6 V, 3.5 A, 2700 mAh), rotor power model,
hover endurance and the battery drain of flying, stored and docked quadrotors."""

import itertools

import pytest

from marsupial.world import World
from marsupial.world.energy import (
    Battery,
    BatterySpec,
    RotorPowerModel,
    cell_voltage,
    hover_endurance_s,
)
from marsupial.world.robots.quadrotor import ARDRONE2, BEBOP2, TELLO


def test_lipo_voltage_follows_the_soc_curve():
    full, empty = Battery(BatterySpec(), 1.0), Battery(BatterySpec(), 0.0)
    assert full.voltage == pytest.approx(12.6)  # 3S full = charger voltage, §V-A
    assert empty.voltage == pytest.approx(9.9) and empty.empty
    socs = [i / 20 for i in range(21)]
    volts = [cell_voltage(s) for s in socs]
    assert all(a < b for a, b in itertools.pairwise(volts))
    assert cell_voltage(-0.1) == cell_voltage(0.0) and cell_voltage(1.2) == cell_voltage(1.0)


def test_draw_takes_current_from_power_and_lowers_the_soc():
    battery = Battery(BatterySpec(capacity_mAh=2700.0), soc=1.0)
    battery.draw(126.0, 1.0)
    assert battery.current_A == pytest.approx(10.0)  # 126 W / 12.6 V
    assert battery.soc == pytest.approx(1.0 - 10.0 / (2.7 * 3600))
    assert battery.discharged_mAh == pytest.approx(10.0 / 3.6)
    battery.draw(0.0, 10.0)
    assert battery.current_A == 0.0 and battery.discharged_mAh == pytest.approx(10.0 / 3.6)


def test_charger_pushes_3_5_A_until_full():
    battery = Battery(BatterySpec(), soc=0.9)
    battery.charge(60.0)
    assert battery.current_A == pytest.approx(-3.5)
    assert battery.charged_mAh == pytest.approx(3.5 * 60 / 3.6)
    for _ in range(200):
        battery.charge(60.0)
    assert battery.soc == 1.0 and battery.current_A == 0.0
    # 0.1 × 2700 mAh at 3.5 A takes 4.6 min; the rest was not counted
    assert battery.charged_mAh == pytest.approx(270.0, abs=3.5 * 60 / 3.6)


def test_bad_battery_settings_are_rejected():
    with pytest.raises(ValueError, match="capacity_mAh"):
        BatterySpec(capacity_mAh=0.0)
    with pytest.raises(ValueError, match="state of charge"):
        Battery(BatterySpec(), soc=1.5)
    with pytest.raises(ValueError, match="efficiencies"):
        RotorPowerModel(rotor_area_m2=0.07, figure_of_merit=1.5, drive_efficiency=0.6, avionics_W=5.0)


def test_power_grows_with_weight_climb_and_airspeed():
    model = BEBOP2.power
    hover = model.hover_power(0.5)
    assert 70.0 < hover < 100.0
    assert model.hover_power(0.6) > hover * (0.6 / 0.5) ** 1.4  # induced power ∝ (mg)^1.5
    assert model.power(0.5 * 9.81, 1.0, 0.0) > hover + 0.5 * 9.81 * 1.0  # climbing
    assert model.power(0.5 * 9.81, 0.0, 5.0) == pytest.approx(hover + 5.0 / model.drive_efficiency)


@pytest.mark.parametrize(
    "spec, mass, low_min, high_min",
    [(BEBOP2, 0.50, 20.0, 25.0), (ARDRONE2, 0.42, 10.0, 14.0), (TELLO, 0.08, 11.0, 15.0)],
)
def test_hover_endurance_matches_the_vendors(spec, mass, low_min, high_min):
    minutes = hover_endurance_s(spec.battery, spec.power.hover_power(mass)) / 60
    assert low_min <= minutes <= high_min  # Bebop 2: "autonomy of 20 min", §V-A


def test_flying_drains_storing_does_not_and_docking_on_a_charger_charges():
    with World() as world:
        uav = world.add_robot("bebop2", pose=[0.0, 0.0, 1.0, 0.0], battery_soc=0.8)
        assert uav.hover_endurance_s() / 60 == pytest.approx(0.8 * 21.9, rel=0.05)
        world.step(10.0)
        flown = 0.8 - uav.battery.soc
        hover_current = uav.spec.power.hover_power(uav.mass) / uav.battery.voltage
        assert flown == pytest.approx(hover_current * 10.0 / (2.7 * 3600), rel=0.03)
        gauge = uav.sensor("battery").read().data
        assert gauge.soc_percent == round(100 * uav.battery.soc)
        assert gauge.current == pytest.approx(hover_current, rel=0.03)

        uav.set_motors(False)  # stored (e.g. lying on the carrier), no charger
        world.step(2.0)
        soc = uav.battery.soc
        world.step(10.0)
        assert uav.battery.soc == soc and uav.power == 0.0

        uav.on_docked(charger=True)
        world.step(10.0)
        assert uav.battery.soc == pytest.approx(soc + 3.5 * 10.0 / (2.7 * 3600))
        uav.on_released()
        world.step(10.0)
        assert uav.battery.current_A == 0.0  # released with motors off: nothing drawn


def test_an_empty_battery_stops_the_motors():
    with World() as world:
        uav = world.add_robot("tello", pose=[0.0, 0.0, 0.5, 0.0], battery_soc=0.0005)
        world.step(2.0)
        assert uav.battery.empty and not uav.motors_on
        uav.set_motors(True)
        assert not uav.motors_on


@pytest.mark.slow
def test_the_child_ugv_drains_while_driving_charges_on_the_lift_and_battery_below_reads_it():
    from skill_harness import Harness

    from marsupial.trees.conditions import BatteryBelow
    from marsupial.world.robots.ugv_docking import CHILD_BATTERY, CHILD_POWER

    with World(scene="marsupial_yard", seed=0) as world:
        mother = world.add_robot("mother_ugv", name="mother", pose=[0.0, 0.0, 0.0])
        child = world.add_robot("child_ugv", name="child", pose=[-2.0, 0.0, 0.0], battery_soc=0.2)
        harness = Harness(world)
        low = harness.node(BatteryBelow, "child", threshold=0.2)

        def holds() -> bool:
            harness.feed(low)
            return low.check()

        assert not holds()  # no gauge sample yet
        world.step(1.0)
        standing = child.battery.discharged_mAh
        assert child.power == pytest.approx(CHILD_POWER.electronics_W)  # the computer and camera only
        child.drive(0.3, 0.0)
        world.step(60.0)
        assert child.power == pytest.approx(CHILD_POWER.power(child._mass, 0.3, 0.0)) and child.power > 7.0
        driven = child.battery.discharged_mAh - standing
        assert driven == pytest.approx(child.power / child.battery.voltage * 60.0 / 3.6, rel=0.02)
        assert child.battery.soc < 0.195 and holds()  # the gauge reads 19 %: the condition holds on the child
        soc = child.battery.soc
        mother.store(child)
        world.step(60.0)
        assert child.charging and child.battery.current_A == -CHILD_BATTERY.charge_current_A
        assert child.battery.soc - soc == pytest.approx(1.25 * 60.0 / (2500 * 3.6), rel=0.01)
        assert child.battery.discharged_mAh - standing == pytest.approx(driven)  # nothing drawn while stored
        assert not holds()  # 20 % again
