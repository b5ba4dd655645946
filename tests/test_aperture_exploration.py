"""Exploration of the bounded volume V until stuck (Arora & Papachristos, §III Problem 1, §IV-A).

Synthetic M first: the rays of a level camera 2 m before a 3 m wide, 1.6 m high wall (face at y = 0), the
floor in front of it seen from above; then ``explore_volume`` and ``exploration_stuck`` on the MMS in
``collapsed_mockup``, read back from the MCAP log.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from py_trees.composites import Sequence
from skill_harness import Harness

from marsupial.skills.aperture.exploration import (
    ExplorationParams,
    GainGrid,
    outside_body,
    plan_viewpoints,
    sector_gain,
    visible_unknown,
)
from marsupial.skills.aperture.explore import ExplorationStuck, ExploreVolume
from marsupial.skills.aperture.volumetric import OCCUPIED, UNKNOWN, SensorCloud, VolumetricMap
from marsupial.skills.navigation import Footprint
from marsupial.tools.rig import live_view
from marsupial.trees.replay import read_log
from marsupial.world import World

CAMERA = np.array([0.0, -2.0, 0.8])
OFFSET = np.array([1.0, 0.0, 0.8])  # the camera 1 m ahead of base_footprint, 0.8 m up (like the MMS's level view)


def _seen_map() -> VolumetricMap:
    """M after one look at the wall (x −1.5…1.5, z 0…1.6, face y = 0) and one down at the floor before it
    (y −2.6…0)."""
    occupancy = VolumetricMap(0.03)
    x, z = np.meshgrid(np.arange(-1.5, 1.5, 0.02), np.arange(0.01, 1.6, 0.02), indexing="ij")
    wall = np.column_stack((x.ravel(), np.full(x.size, 0.01), z.ravel()))
    occupancy.insert(SensorCloud(wall, CAMERA, 4.0))
    gx, gy = np.meshgrid(np.arange(-1.5, 1.5, 0.02), np.arange(-2.6, -0.05, 0.02), indexing="ij")
    floor = np.column_stack((gx.ravel(), gy.ravel(), np.full(gx.size, 0.005)))
    occupancy.insert(SensorCloud(floor, np.array([0.0, -1.3, 1.5]), 4.0))
    return occupancy


def test_the_wall_hides_what_lies_behind_it_from_the_gain():
    occupancy = _seen_map()
    grid = GainGrid(occupancy, ((-1.5, -4.0, 0.0), (1.5, 1.0, 1.6)))
    wall_cell = np.floor((np.array([0.0, 0.01, 0.8]) - grid.lo) / grid.cell).astype(int)
    assert grid.states[tuple(wall_cell)] == OCCUPIED
    behind = np.floor((np.array([0.0, 0.6, 0.8]) - grid.lo) / grid.cell).astype(int)
    assert grid.states[tuple(behind)] == UNKNOWN
    cells = visible_unknown(grid, CAMERA, 3.0, 0.39)
    assert len(cells) and not np.any(cells[:, 1] > 0.1)  # nothing behind the wall is in view
    ahead, back = sector_gain(cells, CAMERA, math.pi / 2, 1.1, grid.cell), sector_gain(cells, CAMERA, -math.pi / 2,
                                                                                         1.1, grid.cell)
    assert ahead < back  # what the camera looked at is known; the unknown is behind it


@pytest.mark.slow
def test_viewpoints_turn_to_the_unseen_and_none_is_left_once_all_is_seen():
    occupancy = _seen_map()
    start = np.array([-1.0, -2.0, math.pi / 2])
    params = ExplorationParams(bounds=((-1.5, -3.0, 0.0), (1.5, 0.5, 1.6)), stuck_gain=0.5)
    views = plan_viewpoints(occupancy, start, OFFSET, params)
    assert views, "the space behind the camera is unknown and reachable by turning"
    best = views[0]
    assert best.gain >= 0.5 and math.sin(best.pose[2]) < 0.9  # it does not look at the wall (+y) again
    assert np.hypot(best.pose[0], best.pose[1]) >= 1.2 - 1e-9  # clearance from the wall
    # a volume the camera saw whole: nothing offers gain, stuck
    seen = ExplorationParams(bounds=((-0.5, -1.0, 0.45), (0.5, -0.1, 1.15)), stuck_gain=0.5)
    assert plan_viewpoints(occupancy, start, OFFSET, seen) == []


def test_the_self_filter_drops_returns_on_the_robot_only():
    cloud = SensorCloud(np.array([[0.3, 0.0, 0.3], [0.3, 0.0, 1.3], [0.9, 0.0, 0.3], [0.0, 0.5, 0.2]]),
                        np.zeros(3), 4.0)
    kept = outside_body(cloud, np.array([0.0, 0.0, 0.0]), 0.0, Footprint(0.5, 0.5, 0.35), 1.0)
    assert kept.points.tolist() == [[0.3, 0.0, 1.3], [0.9, 0.0, 0.3], [0.0, 0.5, 0.2]]


def test_exploration_params_refuse_an_empty_or_a_huge_volume_and_nan():
    with pytest.raises(ValueError, match="low corner"):
        ExploreVolume.Params(bounds=[[1.0, -3.0, 0.0], [-1.0, 0.5, 1.6]])
    with pytest.raises(ValueError, match="at most 2e"):
        ExploreVolume.Params(bounds=[[-1e4, -1e4, 0.0], [1e4, 1e4, 2.0]])
    with pytest.raises(ValueError, match="finite"):
        ExploreVolume.Params(bounds=[[float("nan"), -3.0, 0.0], [1.0, 0.5, 1.6]])


@pytest.mark.slow
def test_the_mms_explores_the_approach_area_until_stuck(tmp_path):
    """From 2.4 m before the wall facing it, no horizon: several views, then no reachable view offers 1.5 m³; the
    condition agrees; every view stands 1.2 m clear of the wall; back where it began, facing the wall; logged."""
    log = tmp_path / "explore.mcap"
    with World(scene="collapsed_mockup", seed=3) as world:
        world.add_robot("mms", "mms", pose=[0.3, -2.4, math.pi / 2], mavs=False)
        harness = Harness(world, log_path=log)
        explore = harness.node(ExploreVolume, robot="mms", bounds=[[-1.6, -3.0, 0.0], [1.6, 0.5, 1.6]],
                               horizon=None, end_at_start=True, end_yaw=math.pi / 2)
        stuck = harness.node(ExplorationStuck, robot="mms")
        root = Sequence("explore, then stuck", memory=True, children=[explore, stuck])
        status = harness.run(root, 150.0)
        estimate = live_view(world, "mms").estimate()
        harness.close()
    assert status.name == "SUCCESS", explore.feedback_message
    events = read_log(log).events_of("state_change")
    views = [e for e in events if e.get("phase") == "explore_view"]
    goals = [e for e in events if e.get("phase") == "explore_goal"]
    assert len(views) >= 2 and len(goals) == len(views) - 1
    assert views[-1]["unknown_m3"] < views[0]["unknown_m3"]
    assert all(g["goal"]["gain_m3"] >= 1.5 for g in goals)
    assert all(-0.05 - g["goal"]["pose"][1] >= 1.2 - 0.05 for g in goals)  # the wall's face is at y = -0.05
    assert any(e.get("phase") == "exploration_stuck" for e in events)
    assert any(e.get("phase") == "explore_return" for e in events)
    assert np.hypot(estimate.position[0] - 0.3, estimate.position[1] + 2.4) < 0.1
    assert abs(math.remainder(estimate.yaw - math.pi / 2, math.tau)) < 0.06


@pytest.mark.slow
def test_with_the_default_horizon_the_mms_is_stuck_after_one_look_around(tmp_path):
    """The paper's case (§III Problem 1: exploration "assumed to (almost) immediately reach the maximum-possible
    exploration gain"): within 1 m of the start no view offers 1.5 m³ of V."""
    log = tmp_path / "stuck.mcap"
    with World(scene="collapsed_mockup", seed=3) as world:
        world.add_robot("mms", "mms", pose=[0.3, -2.4, math.pi / 2], mavs=False)
        harness = Harness(world, log_path=log)
        explore = harness.node(ExploreVolume, robot="mms", bounds=[[-1.6, -3.0, 0.0], [1.6, 0.5, 1.6]])
        assert harness.run(explore, 40.0).name == "SUCCESS", explore.feedback_message
        harness.close()
    events = read_log(log).events_of("state_change")
    phases = [e.get("phase", "") for e in events]
    assert [p for p in phases if p.startswith("explor")] == ["explore_view", "exploration_stuck"]
