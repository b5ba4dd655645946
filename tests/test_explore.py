"""explore (Narváez §V-A): the UAV surveys the rooms around the carrier.

It stops every D_e for a yaw sweep and never leaves D_team.

One mission in ``usar_building``: the carrier follows the operator's guide
path at 0.3 m/s (``navigate``) while the UAV explores around it; everything
is read back from the MCAP log (poses at 5 Hz, the skill's phase events,
the coverage metric).
"""

import itertools
import math

import numpy as np
import pytest
from py_trees.common import Status
from skill_harness import Harness

from marsupial.api.readings import StateEstimate
from marsupial.geometry import quaternion_from_yaw, yaw_of
from marsupial.sensing import body_pose, in_nav_frame, sensor_mount
from marsupial.skills.uav_docking.coverage import (
    FlightMap,
    detect_colour,
    floor_point,
    next_goal,
    plan_ranges,
    view_bearings,
    visible_cells,
)
from marsupial.skills.uav_docking.explore import Explore
from marsupial.tools.rig import live_view
from marsupial.trees.replay import read_log
from marsupial.trees.runner import run_mission
from marsupial.world import World
from marsupial.world.priors import building_plan
from marsupial.world.team_link import TeamLinkConfig

D_E, D_TEAM = 1.5, 4.5  # m: smaller than the defaults so that a short run meets both constraints many times

MISSION = f"""
mission: explore_test
world: {{scene: usar_building, seed: 3}}
team:
  carrier: {{robot: mobile_manipulator, pose: [-13, -7, 0.73]}}
  uav: {{robot: bebop2, pose: [-12.4, -7.0, 1.2, 0.0]}}
run: {{tick_hz: 10, until: 45}}
tree:
  parallel:
    - {{skill: navigate, robot: carrier, params: {{max_speed: 0.3}}}}
    - {{skill: explore, robot: uav, params: {{D_e: {D_E}, D_team: {D_TEAM}, sweep_angle: 3.1416}}}}
"""


@pytest.fixture(scope="module")
def log(tmp_path_factory):
    folder = tmp_path_factory.mktemp("explore")
    path = folder / "explore.yaml"
    path.write_text(MISSION)
    result = run_mission(str(path), log_path=folder / "run.mcap", progress=False)
    assert result.outcome == "time_limit", result.message
    return read_log(folder / "run.mcap")


def phases(log, phase):
    return [e for e in log.events_of("state_change") if e.get("phase") == phase]


@pytest.mark.slow
def test_uav_never_leaves_D_team_of_the_moving_carrier(log):
    t_uav, p_uav = log.poses("uav")
    t_car, p_car = log.poses("carrier")
    assert np.array_equal(t_uav, t_car)
    distance = np.linalg.norm(p_uav - p_car, axis=1)
    assert distance.max() < D_TEAM
    assert np.linalg.norm(p_car[-1] - p_car[0]) > 10.0  # the carrier really moved away from the start
    assert distance.max() > D_TEAM - 1.5  # and the constraint was binding


@pytest.mark.slow
def test_uav_stops_every_D_e_for_a_yaw_sweep(log):
    events = [e for e in log.events_of("state_change") if "phase" in e]
    sweeps = [(e, after) for e, after in itertools.pairwise(events) if e["phase"] == "sweep"]
    assert len(sweeps) >= 5
    legs = [e["flown"] for e, _ in sweeps[1:]]  # exploration flight before each stop (the first is at the start)
    assert max(legs) <= D_E + 0.1  # a stop at the latest every D_e
    assert np.median(legs) > 0.8 * D_E
    t, p, q = log.poses("uav", orientation=True)
    _, p_carrier = log.poses("carrier")
    yaw = np.unwrap([yaw_of(x) for x in q])
    for sweep, after in sweeps:
        window = (t >= sweep["t"]) & (t <= after["t"])
        assert np.ptp(yaw[window]) > 0.9 * math.pi  # the heading turned through the sweep angle
        moved = np.linalg.norm(p[window][-1, :2] - p[window][0, :2])
        carrier_moved = np.linalg.norm(p_carrier[window][-1, :2] - p_carrier[window][0, :2])
        assert moved < 0.6 * carrier_moved + 0.1  # held in place but for the pull of the D_team leash


@pytest.mark.slow
def test_coverage_is_written_for_area_explored(log):
    t, coverage = log.metric("coverage", robot="uav")
    assert len(coverage) >= 3
    assert np.all((coverage >= 0.0) & (coverage <= 1.0))
    assert coverage.max() > 0.3


def front_camera(world, uav):
    """The front camera's next frame and the camera pose the UAV estimated at its stamp (estimate ∘ URDF mount).

    A camera samples when read and delivers the frame a latency later (or
    drops it): the world is stepped by ticks until one arrives.
    """
    onboard = live_view(uav.world, uav.name)
    port = onboard.sensor("front_camera")
    mount = sensor_mount(onboard, "camera_front", port.offset, port.R_link_optical)
    asked = world.now
    port.read()
    for _ in range(20):
        world.step(0.1)
        reading = port.read()
        if reading is not None and reading.stamp >= asked:
            position, R = in_nav_frame(body_pose(onboard.estimate(), reading.stamp), mount)
            return reading.data, position, R
    raise AssertionError("no front-camera frame in 2 s")


def flight_map(world):
    return FlightMap.from_plan(building_plan(world.scene), 1.5, 0.5, 0.45, ("room", "hall", "corridor"))


def test_walls_of_the_plan_hide_what_is_behind_them_from_the_coverage():
    with World(scene="usar_building") as world:
        grid = flight_map(world)
        # in the hall 1.5 m from its north wall (y = 4, solid for x -9.3..-5.1), facing it
        uav = world.add_robot("bebop2", "uav", pose=[-7.2, 2.5, 1.5, math.pi / 2])
        frame, position, R = front_camera(world, uav)
    bearings = view_bearings(frame.K, frame.rgb.shape[1], R)
    assert np.ptp(bearings) == pytest.approx(math.radians(80), abs=math.radians(8))  # the Bebop's horizontal field
    ranges = plan_ranges(grid, position[:2], bearings, 6.0)
    # the wall's face (0.1 m half thickness; lens 0.128 m ahead)
    assert np.median(ranges) == pytest.approx(1.5 - 0.1 - 0.128, abs=0.25)
    seen = visible_cells(grid, position[:2], bearings, ranges, 6.0)
    x, y = grid.centers()
    assert seen[(np.abs(x + 7.2) < 0.5) & (y > 3.0) & (y < 3.8)].all()  # the hall up to the wall
    assert not seen[y > 4.1].any()  # nothing of room_nw behind it
    assert not seen[y < 2.4].any()  # nothing behind the camera


def test_next_goal_prefers_the_nearer_unsurveyed_area():
    with World(scene="usar_building") as world:
        grid = flight_map(world)
    x, _ = grid.centers()
    unseen = grid.area & (np.abs(x + 12.0) < 1.0)  # a strip of the hall at x = -12
    distance = np.where(grid.area, np.abs(x + 8.0), np.inf)  # path lengths from x = -8
    goal = next_goal(grid, distance, unseen, 2.0, 4.0, np.zeros(grid.shape, dtype=bool))
    assert goal is not None and -12.5 < grid.point(goal)[0] < -9.5
    none = np.zeros(grid.shape, dtype=bool)
    assert next_goal(grid, distance, none, 2.0, 4.0, none) is None


def test_explore_finds_the_target_and_succeeds(tmp_path):
    with World(scene="usar_building", seed=0) as world:
        # in the lobby, not under the sonar
        world.add_robot("mobile_manipulator", "carrier", pose=[11.5, -1.8, -math.pi / 2])
        world.add_robot("bebop2", "uav", pose=[11.5, -3.6, 1.5, 0.0])  # in door_6, the target room south of it
        harness = Harness(world, log_path=tmp_path / "run.mcap")
        explore = harness.node(Explore, "uav")
        assert harness.run(explore, 20.0) == Status.SUCCESS
        harness.close()
        p_target = np.asarray(world.scene.object("target").position)
        target_size = world.scene.object("target").size
    log = read_log(tmp_path / "run.mcap")
    [found] = phases(log, "target_found")
    t, p_uav = log.poses("uav")
    assert np.linalg.norm(p_uav[np.searchsorted(t, found["t"])] - p_target) < 6.0
    half = 0.5 * np.asarray(target_size[:2])
    outside = np.maximum(np.abs(np.asarray(found["at"]) - p_target[:2]) - half, 0.0)
    assert np.linalg.norm(outside) < 0.3  # where the detection puts it on the floor: at its near edge
    assert harness.blackboard("target_found") is True


def test_target_is_detected_by_its_colour_only_where_the_camera_sees_it():
    with World(scene="usar_building", seed=0) as world:
        # in the lobby, facing the target
        outside = world.add_robot("bebop2", "outside", pose=[12.9, -1.5, 1.5, -math.pi / 2])
        # in the target room, 3.6 m away
        inside = world.add_robot("bebop2", "inside", pose=[12.9, -4.0, 1.5, -math.pi / 2])
        frame, _, _ = front_camera(world, outside)  # the room's north wall (y = -3) between them
        assert detect_colour(frame.rgb, (255, 120, 20)) is None
        frame, position, R = front_camera(world, inside)
        target = world.scene.object("target")
    blob = detect_colour(frame.rgb, (255, 120, 20))
    assert blob is not None and blob.area > 200
    near_edge_y = target.position[1] + 0.5 * target.size[1]  # its north edge on the floor, facing the UAV
    point = floor_point(frame.K, position, R, blob.bottom)
    assert point[2] == pytest.approx(0.0) and point[1] == pytest.approx(near_edge_y, abs=0.3)
    assert abs(point[0] - target.position[0]) < 0.3
    assert floor_point(frame.K, position, R, (160.0, 0.0)) is None  # above the horizon: no floor
    assert detect_colour(frame.rgb, (255, 120, 20), min_pixels=blob.area + 1) is None


def test_a_late_frame_is_placed_with_the_estimate_propagated_back_to_its_stamp():
    turning = StateEstimate(2.0, "odom", np.array([1.0, 2.0, 1.5]), quaternion_from_yaw(0.5),
                            np.array([0.2, 0.0, 0.0]), np.array([0.0, 0.0, 1.2]))
    p, R = body_pose(turning, 1.9)  # a frame 0.1 s old, taken while sweeping at 1.2 rad/s
    assert p == pytest.approx([0.98, 2.0, 1.5]) and math.atan2(R[1, 0], R[0, 0]) == pytest.approx(0.5 - 0.12)
    assert body_pose(turning)[0] == pytest.approx(turning.position)


def test_without_the_carriers_telemetry_the_uav_hovers_and_waits():
    with World(scene="usar_building", seed=0, team_link=TeamLinkConfig(drop=1.0)) as world:  # every message lost
        world.add_robot("mobile_manipulator", "carrier", pose=[-13, -7, 0.73])
        uav = world.add_robot("bebop2", "uav", pose=[-11.0, -7.0, 1.2, 0.0])
        start = uav.pose()[0]
        harness = Harness(world)
        explore = harness.node(Explore, "uav")
        assert harness.run(explore, 3.0) == Status.RUNNING
        assert explore.feedback_message == "waiting for carrier's telemetry"
        assert np.linalg.norm(uav.pose()[0] - start) < 0.2


def test_browns_shifted_by_a_poor_white_balance_are_not_the_target():
    with World(scene="usar_building", seed=1, noise_scale=4.0) as world:  # four times the sourced colour variation
        uav = world.add_robot("bebop2", "uav", pose=[-10.0, -3.0, 1.5, math.pi / 2])  # the hall: door frames, debris
        frame, _, _ = front_camera(world, uav)
    assert detect_colour(frame.rgb, (255, 120, 20)) is None  # (pixel noise makes specks of a few pixels: not a blob)
