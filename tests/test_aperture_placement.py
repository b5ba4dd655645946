"""Base placement (Arora & Papachristos §IV-D) and the launch pose (§IV-E output, §IV-F) on synthetic inputs.

The volumetric map M is built from synthetic rays (no rendering): a wall
2.4 m ahead of the robot with a 0.25 × 0.20 m hole centred 0.6 m up, a back
wall behind the hole, and the floor in front of the wall, all seen. The
arm is the MMS's pinocchio model; the camera its eye-in-hand camera. The
launch pose is checked on a synthetic fronto-parallel image, then on the
detection and profile analysis of frames rendered before a mockup opening.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapely.geometry import Point
from test_aperture_detection import STANDOFF_M, WALL_FACE_Y, _frames

from marsupial.api.kinematics import ArmKinematics
from marsupial.skills.aperture import mav_contour, plan_launches, profile_analysis
from marsupial.skills.aperture.detection import (
    DetectionParams,
    FrontoParallelView,
    InertialFrame,
    detect_apertures,
    fronto_parallel_rotation,
)
from marsupial.skills.aperture.launch_pose import LaunchParams, attitude_ok, plan_launch, roll_pitch_yaw
from marsupial.skills.aperture.placement import (
    CameraModel,
    PlacementParams,
    aim_camera,
    camera_goal,
    in_view,
    plan_placements,
)
from marsupial.skills.aperture.profile import LaunchConfiguration
from marsupial.skills.aperture.volumetric import FREE, SensorCloud, VolumetricMap
from marsupial.world.apertures import aperture_outline
from marsupial.world.robots.mms import CAMERA_INTRINSICS
from marsupial.world.sensors.camera import OPTICAL_FORWARD

WALL_X = 2.4
TARGET = np.array([WALL_X, 0.0, 0.6])  # the hole's centre
NORMAL = np.array([-1.0, 0.0, 0.0])  # toward the robot
START = (0.0, 0.0, 0.0)
Q_LEVEL = np.array((0.0, 1.15, 0.2, 0.0, 0.221, 0.0))  # aperture_scan's level pose
ARM_MOUNT = (np.array([0.25, 0.0, 0.39]), np.eye(3))  # mms.urdf: arm_base_link 0.19 m above base_link (0.20 m up)
KINEMATICS = ArmKinematics.from_urdf("mms.urdf", "arm_base_link", "tcp")
CAMERA = CameraModel(np.zeros(3), OPTICAL_FORWARD, CAMERA_INTRINSICS.K, CAMERA_INTRINSICS.width,
                     CAMERA_INTRINSICS.height, CAMERA_INTRINSICS.near)
STEP = 0.03  # spacing of the synthetic returns (m)


def _grid(xs: np.ndarray, ys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a, b = np.meshgrid(xs, ys)
    return a.ravel(), b.ravel()


def _map(floor: bool = True, rubble: bool = False) -> VolumetricMap:
    """M of the wall with its hole, seen from 1 m ahead of the robot; the floor seen from above."""
    occupancy = VolumetricMap(0.03)
    y, z = _grid(np.arange(-2.5, 2.5, STEP), np.arange(0.0, 1.5, STEP))
    hole = (np.abs(y - TARGET[1]) < 0.125) & (np.abs(z - TARGET[2]) < 0.1)
    wall = np.c_[np.full((~hole).sum(), WALL_X), y[~hole], z[~hole]]
    back = np.c_[np.full(hole.sum(), 4.0), y[hole], z[hole]]
    occupancy.insert(SensorCloud(np.vstack((wall, back)), np.array([1.0, 0.0, 0.8]), 4.0))
    above = np.array([0.5, 0.0, 2.5])
    if floor:
        x, y = _grid(np.arange(-1.0, WALL_X, STEP), np.arange(-2.5, 2.5, STEP))
        occupancy.insert(SensorCloud(np.c_[x, y, np.zeros_like(x)], above, 6.0))
    if rubble:  # a layer of debris 0.2 m up over the whole cone
        x, y = _grid(np.arange(0.0, WALL_X, STEP), np.arange(-2.5, 2.5, STEP))
        occupancy.insert(SensorCloud(np.c_[x, y, np.full_like(x, 0.2)], above, 6.0))
    return occupancy


@pytest.fixture(scope="module")
def seen():
    return _map()


def _plan(occupancy, seed=0, target=TARGET, params=None):
    return plan_placements(target, NORMAL, occupancy, KINEMATICS, CAMERA, ARM_MOUNT, START, Q_LEVEL, 0.0,
                           np.random.default_rng(seed), params)


@pytest.mark.slow
def test_placements_lie_in_the_cone_clear_of_m_and_see_the_aperture_through_the_arm(seen):
    params = PlacementParams()
    placements = _plan(seen)
    assert len(placements) >= 10
    assert [p.cost for p in placements] == sorted(p.cost for p in placements)
    for i, placement in enumerate(placements):
        x, y, yaw = placement.pose
        offset = np.array([x, y]) - TARGET[:2]
        assert np.hypot(*offset) <= params.rho + 1e-9
        cos_off_axis = offset @ NORMAL[:2] / np.hypot(*offset)
        assert math.acos(min(1.0, cos_off_axis)) <= params.half_angle + 1e-9  # within β of n̂'s ground projection
        c, s = math.cos(yaw), math.sin(yaw)
        if i % 8 == 0:  # the base's box (inflated), every 1.5 cm over its height band: free in M (a sample: slow)
            front, rear, half = (d + params.margin for d in params.footprint)
            u, v = _grid(np.arange(-rear, front, 0.015), np.arange(-half, half, 0.015))
            for z in np.arange(params.ground_clearance, params.height, 0.015):
                points = np.c_[x + c * u - s * v, y + s * u + c * v, np.full_like(u, z)]
                assert np.all(seen.state(points) == FREE), placement.pose
        # the arm: within its limits, pinocchio FK puts the camera at the stand-off, looking at the aperture
        assert KINEMATICS.within_limits(placement.q)
        p_l, R_l = KINEMATICS.forward(placement.q, "camera_link")
        R_M = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        p_M = np.array([x, y, 0.0]) + R_M @ ARM_MOUNT[0]
        p_cam, R_opt = p_M + R_M @ p_l, R_M @ R_l @ OPTICAL_FORWARD
        assert np.linalg.norm(p_cam - (TARGET + params.standoff * NORMAL)) < 1e-4
        seen_from = R_opt.T @ (TARGET - p_cam)
        uv = CAMERA.K @ seen_from / seen_from[2]
        assert seen_from[2] > CAMERA.near
        assert 0 <= uv[0] < CAMERA.width and 0 <= uv[1] < CAMERA.height


def test_placements_are_deterministic_given_the_seed(seen):
    first, again, other = _plan(seen, seed=5), _plan(seen, seed=5), _plan(seen, seed=6)
    assert [p.pose.tolist() for p in first] == [p.pose.tolist() for p in again]
    assert [p.pose.tolist() for p in first] != [p.pose.tolist() for p in other]


@pytest.mark.slow
def test_a_blocked_cone_has_no_placement():
    assert _plan(_map(rubble=True)) == []


def test_ground_the_camera_never_saw_is_not_a_placement():
    assert _plan(_map(floor=False)) == []


def test_an_aperture_beyond_the_arm_has_no_placement(seen):
    assert _plan(seen, target=np.array([WALL_X, 0.0, 2.2])) == []  # the camera would need to be 2.2 m up


def test_the_camera_is_centred_on_the_view_point_and_still_sees_the_target(seen):
    # m_A lay 10-15 cm off a U's centre: the camera in front of it saw the far arm cut by the image border
    view = TARGET + np.array([0.3, 0.08, 0.05])  # the contour's centre: off t_a across n̂ (and its depth ignored)
    params = PlacementParams()
    placements = plan_placements(TARGET, NORMAL, seen, KINEMATICS, CAMERA, ARM_MOUNT, START, Q_LEVEL, 0.0,
                                 np.random.default_rng(0), params, view_point=view)
    assert placements
    goal = np.array([WALL_X, 0.08, 0.65]) + params.standoff * NORMAL
    for placement in placements[:5]:
        assert np.linalg.norm(placement.camera_position - goal) < 1e-4
        p_cam, R_opt = placement.camera_position, camera_goal(goal, NORMAL, 0.0)[1]
        assert in_view(CAMERA, p_cam, R_opt, TARGET, params.view_margin_px)


def test_the_camera_is_aimed_again_from_where_the_base_stopped(seen):
    # the base stops within 5 cm and 0.05 rad of its placement, and the relocalisation moves its estimate by the
    # drift (up to 8 cm): from there the arm is solved again so that the camera stands at its goal
    placement = _plan(seen)[0]
    p_opt, R_opt = camera_goal(TARGET, NORMAL, PlacementParams().standoff)
    stopped = placement.pose + np.array([0.06, -0.04, 0.04])
    q = aim_camera(KINEMATICS, CAMERA, ARM_MOUNT, stopped, 0.0, p_opt, R_opt, placement.q)
    assert q is not None and KINEMATICS.within_limits(q)
    c, s = math.cos(stopped[2]), math.sin(stopped[2])
    R_M = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    p_l, R_l = KINEMATICS.forward(q, "camera_link")
    assert np.linalg.norm(np.array([*stopped[:2], 0.0]) + R_M @ (ARM_MOUNT[0] + p_l) - p_opt) < 1e-4
    assert np.allclose(R_M @ R_l @ OPTICAL_FORWARD, R_opt, atol=1e-4)
    assert np.max(np.abs(q - placement.q)) < 0.5  # the nearby solution, not another branch
    assert aim_camera(KINEMATICS, CAMERA, ARM_MOUNT, placement.pose - np.array([1.5, 0.0, 0.0]), 0.0, p_opt,
                      R_opt, placement.q) is None  # 1.5 m short: out of the arm's reach


# ------------------------------------------------------------------ launch pose
F, CX, CY, DEPTH = 400.0, 160.0, 120.0, 0.6  # the virtual camera of the fronto-parallel image, plane 0.6 m ahead


def _view(normal_I: np.ndarray) -> tuple[FrontoParallelView, InertialFrame]:
    """I of a plane with normal ``normal_I`` (F_I) ``DEPTH`` ahead of F_I at (0.5, 0, 0.8), looking along +x."""
    K = np.array([[F, 0.0, CX], [0.0, F, CY], [0.0, 0.0, 1.0]])
    empty = np.zeros((240, 320), np.uint8)
    view = FrontoParallelView(empty.astype(np.float32), empty, K, fronto_parallel_rotation(normal_I), DEPTH)
    R_nav_I = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])  # x right (−y), y down, z ahead (+x)
    return view, InertialFrame(np.array([0.5, 0.0, 0.8]), R_nav_I)


def _config(u: float, v: float, angle: float) -> LaunchConfiguration:
    return LaunchConfiguration((u, v), angle, ((u - 10.0, v), (u + 10.0, v)), 0.0, 0.0)


def test_the_phase_i_goal_lies_d_l_in_front_of_the_aperture_along_its_normal():
    view, frame = _view(np.array([0.0, 0.0, -1.0]))  # a wall facing the sensor
    params = LaunchParams()
    plan = plan_launch(_config(CX + F * 0.1 / DEPTH, CY, 0.1), view, frame, params)
    assert plan.normal == pytest.approx([-1.0, 0.0, 0.0])
    assert plan.pre_launch == pytest.approx([1.1, -0.1, 0.8])  # 0.1 m right of the axis in the image: −y
    assert plan.goal - plan.pre_launch == pytest.approx(params.d_l * plan.normal)
    start, end = plan.insertion
    assert start == pytest.approx(plan.goal) and end == pytest.approx(plan.pre_launch)
    assert plan.launch_position == pytest.approx(plan.pre_launch - params.d_l * plan.normal)  # past the plane
    assert plan.R_pre_launch[:, 0] == pytest.approx(-plan.normal)  # nose first through the aperture
    roll, pitch, _ = roll_pitch_yaw(plan.R_pre_launch)
    assert roll == pytest.approx(0.1) and pitch == pytest.approx(0.0, abs=1e-12)
    assert plan.feasible and plan.roll == pytest.approx(0.0, abs=1e-12)  # Phase III levelled the fit's roll


def test_an_over_tilted_launch_is_rejected():
    view, frame = _view(np.array([0.0, 0.0, -1.0]))
    params = LaunchParams(max_level_roll=math.radians(20.0))
    steep = plan_launch(_config(CX, CY, 1.0), view, frame, params)  # 57° roll: more than a 20° turn can level
    assert plan_launch(_config(CX, CY, 1.0), view, frame).feasible  # the default turn levels any fit
    assert not steep.feasible
    assert abs(steep.roll) == pytest.approx(1.0 - params.max_level_roll) and abs(steep.roll) > params.alpha_launch
    tilt = math.radians(30.0)  # a plane leaning back 30°: the MAV would launch pitched 30°
    view, frame = _view(np.array([0.0, -math.sin(tilt), -math.cos(tilt)]))
    leaning = plan_launch(_config(CX, CY, 0.0), view, frame, params)
    assert not leaning.feasible and abs(leaning.pitch) == pytest.approx(tilt)
    assert attitude_ok(np.eye(3), params.alpha_launch) and not attitude_ok(leaning.R_launch, params.alpha_launch)


def test_launch_plans_of_a_detected_aperture_go_through_the_true_opening():
    """Rendered frames 0.6 m before the orthogonal opening → detection → profile analysis → launch plans."""
    outline = aperture_outline("orthogonal")
    found = detect_apertures(_frames(outline.centroid.x, STANDOFF_M, 3), DetectionParams(n_frames=3))[0]
    configs = profile_analysis(found.mask(), mav_contour(found.view.plane_depth, found.view.K))
    params = LaunchParams()
    plans = plan_launches(found, configs, params)
    assert plans and len(plans) <= len(configs)
    for plan in plans:
        assert plan.pre_launch[1] == pytest.approx(WALL_FACE_Y, abs=0.01)  # on the wall's face
        assert outline.contains(Point(plan.pre_launch[0], plan.pre_launch[2]))
        assert plan.goal[1] == pytest.approx(WALL_FACE_Y - params.d_l, abs=0.015)  # d_l before it (n̂ ≈ −y)
        assert plan.launch_position[1] == pytest.approx(WALL_FACE_Y + params.d_l, abs=0.015)  # d_l past it
        assert abs(plan.roll) <= params.alpha_launch and abs(plan.pitch) <= params.alpha_launch
