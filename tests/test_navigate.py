"""navigate (Narváez §V-A, §V-B-1): smoothed guide path, LiDAR obstacle avoidance, 2 m/s, 0.5 m/s when docking."""

import numpy as np
import py_trees
import pytest
from py_trees.common import Status
from skill_harness import Harness

from marsupial.skills.navigation import Footprint, Navigate, PathFollower, local_plan, smooth_path
from marsupial.trees.replay import read_log
from marsupial.trees.runner import run_mission
from marsupial.world import World
from marsupial.world.contacts import ContactMonitor
from marsupial.world.priors import building_plan


def add_box(world, center, half_extents):
    """A static box obstacle (m, world) taller than the LiDAR's scan plane."""
    bullet = world.bullet
    shape = bullet.createCollisionShape(bullet.GEOM_BOX, halfExtents=half_extents)
    visual = bullet.createVisualShape(bullet.GEOM_BOX, halfExtents=half_extents)
    return bullet.createMultiBody(0, shape, visual, center)


def test_smoothing_rounds_corners_inside_the_guide_and_keeps_its_ends():
    guide = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0]])
    smooth = smooth_path(guide, 3)
    assert np.allclose(smooth[0], guide[0]) and np.allclose(smooth[-1], guide[-1])
    assert np.all(smooth[:, 0] <= 4.0 + 1e-9) and np.all(smooth[:, 1] >= -1e-9)  # inside the corner
    corner_cut = np.min(np.linalg.norm(smooth - guide[1], axis=1))
    assert 0.3 < corner_cut < 1.0  # rounded, over about a quarter of the segments
    assert 7.0 < PathFollower(guide).length < 8.0  # shorter than the guide by the rounded corner
    u_turn = PathFollower(np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 1.0], [0.0, 1.0]]))
    assert u_turn.update(np.array([0.5, 0.6])) < 1.0  # on the first leg, not short-cut to the nearer return leg


def test_local_plan_turns_away_from_a_wall_and_stops_when_boxed_in():
    footprint = Footprint(0.25, 0.25, 0.2)
    wall = np.column_stack((np.full(41, 0.8), np.linspace(-2.0, 2.0, 41)))  # 0.55 m ahead of the bumper
    plan = local_plan(wall, np.array([3.0, 0.0]), 2.0, 0.0, 2.0, 1.7, footprint)
    assert plan.v < 0.5  # cannot drive straight through; slow, clear of the wall
    assert plan.clearance >= 0.15
    ring = np.column_stack(
        (0.45 * np.cos(np.linspace(0, 2 * np.pi, 120)), 0.45 * np.sin(np.linspace(0, 2 * np.pi, 120)))
    )
    assert local_plan(ring, np.array([3.0, 0.0]), 2.0, 0.0, 2.0, 1.7, footprint).v == 0.0


@pytest.fixture
def world():
    with World(seed=2) as w:
        yield w


def test_navigate_drives_around_an_obstacle_on_the_path_without_touching_it(world, tmp_path):
    carrier = world.add_robot("mobile_manipulator", "carrier", pose=[0.0, 0.0, 0.0])
    box = add_box(world, [3.0, 0.05, 0.5], [0.3, 0.4, 0.5])  # not on any plan: only the LiDAR sees it
    monitor = ContactMonitor(world, "carrier", box)
    world.add_actor(monitor)
    harness = Harness(world, log_path=tmp_path / "run.mcap")
    navigate = harness.node(Navigate, "carrier", path=[[0.0, 0.0], [3.0, 0.0], [6.0, 0.0]])
    assert harness.run(navigate, 30.0) == Status.SUCCESS
    world.step(1.5)  # the finished skill stopped the base
    harness.close()
    assert monitor.events == []
    log = read_log(tmp_path / "run.mcap")
    t, p = log.poses("carrier")  # truth, 10 Hz
    _, estimate = log.poses("carrier", estimate=True)  # wheel odometry
    track = p[:, :2]
    assert np.linalg.norm(estimate[-1, :2] - [6.0, 0.0]) <= 0.3  # the end, as the robot believes (goal tolerance)
    assert np.linalg.norm(track[-1] - [6.0, 0.0]) <= 0.45  # and as it is: odometry drifts ~1-2 % over the 7 m
    assert np.abs(track[:, 1]).max() > 0.6  # went around the box (0.8 m wide, on the path)
    assert np.abs(track[:, 1]).max() < 1.6
    assert np.max(np.linalg.norm(np.diff(track, axis=0), axis=1) / np.diff(t)) <= 2.0 + 0.05
    _, progress = log.metric("path_progress", robot="carrier")
    assert np.all(np.diff(progress) >= 0.0) and progress[-1] == pytest.approx(1.0, abs=0.06)
    assert abs(carrier.speed()) < 0.01


def test_docking_flag_limits_the_speed_to_half_a_metre_per_second(world):
    carrier = world.add_robot("mobile_manipulator", "carrier", pose=[0.0, 0.0, 0.0])
    harness = Harness(world)
    navigate = harness.node(Navigate, "carrier", path=[[0.0, 0.0], [12.0, 0.0]], docking_flag="carrier/docking")
    assert navigate.read_keys(navigate.params, "carrier") == ("carrier/docking",)
    client = py_trees.blackboard.Client(name="docking skill")
    client.register_key("/carrier/docking", access=py_trees.common.Access.WRITE)
    speeds = []
    harness.run(navigate, 4.0, lambda: speeds.append(carrier.speed()))
    assert max(speeds) > 1.5  # free run: up to the 2 m/s limit
    client.set("/carrier/docking", True)
    harness.run(navigate, 3.0)
    speeds = []
    harness.run(navigate, 2.0, lambda: speeds.append(carrier.speed()))
    assert max(speeds) <= 0.5 + 0.02
    harness.stop(navigate)


def test_operator_set_points_replace_the_guide_path(world):
    carrier = world.add_robot("mobile_manipulator", "carrier", pose=[0.0, 0.0, 0.0])
    harness = Harness(world)
    navigate = harness.node(Navigate, "carrier", path=[[0.0, 0.0], [5.0, 0.0]], setpoints_key="operator/setpoints")
    client = py_trees.blackboard.Client(name="operator")
    client.register_key("/operator/setpoints", access=py_trees.common.Access.WRITE)
    harness.run(navigate, 1.0)
    client.set("/operator/setpoints", [[1.0, 2.5]])
    assert harness.run(navigate, 20.0) == Status.SUCCESS
    assert np.linalg.norm(carrier.footprint_pose()[0][:2] - [1.0, 2.5]) <= 0.3


@pytest.mark.slow
def test_navigate_follows_the_plans_guide_path_through_the_building_on_map_localisation(tmp_path):
    mission = tmp_path / "m.yaml"
    mission.write_text(
        "mission: through_the_building\n"
        "world: {scene: usar_building, seed: 7}\n"
        "team:\n"
        "  carrier: {robot: mobile_manipulator, pose: [-13, -7, 0.73], options: {localization: map},\n"
        "            sensors: {lidar: {rate_hz: 10, resolution_deg: 1.0}}}\n"
        "run: {tick_hz: 10, until: 90}\n"
        "tree: {skill: navigate, robot: carrier, params: {max_speed: 1.0}}\n"
    )
    result = run_mission(str(mission), log_path=tmp_path / "run.mcap", progress=False)
    assert result.outcome == "success", result.message
    log = read_log(tmp_path / "run.mcap")
    _, truth = log.poses("carrier")
    _, estimate = log.poses("carrier", estimate=True)
    with World(scene="usar_building") as world:
        plan = building_plan(world.scene)
    end = plan.path("operator_path")[-1]
    assert np.linalg.norm(truth[-1, :2] - end) < 0.6  # the guide path's end in the target room, through door_6
    assert np.linalg.norm(truth[:, :2] - estimate[:, :2], axis=1).max() < 0.3  # map localisation: bounded error
    clearance = min(min(e.distance([x, y, 0.3]) for e in plan.structure) for x, y, _ in truth)
    assert clearance > 0.19 + 0.2  # the base's half-width (0.19 m) plus room: no wall or jamb grazed
