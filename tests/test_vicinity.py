"""Vicinity of the cord (eqs. 7–8), the local zone map and the cord repair of Fig. 9.

Section sizes follow eqs. (7)–(8), computed here by hand; random poses are
drawn inside their sections; after the shift-and-smooth repair the vicinity
keeps at least T_s from every obstacle and prohibited zone (random seeded
scenes, checked with exact fcl ellipsoid collisions); the random-sample
validation accepts a free, reachable vicinity and rejects a blocked one.
"""

import math

import numpy as np
import pytest

from marsupial.api.kinematics import ArmKinematics
from marsupial.skills.common.ik_engine import IKEngine
from marsupial.skills.uav_docking.cord import Cord, CordParams, build_cord
from marsupial.skills.uav_docking.vicinity import (
    VicinityParams,
    build_vicinity,
    section_sizes,
    validate_vicinity,
)
from marsupial.skills.uav_docking.zones import ZoneMap, ZoneParams, carrier_zones, repair_cord, thickening

CORD = CordParams()
VICINITY = VicinityParams()
Q_READY = np.array([0.0, -0.87, 1.98, 0.0, -1.11, 0.0])  # the carrier's "docking_ready" arm pose


@pytest.fixture(scope="module")
def kinematics():
    return ArmKinematics.from_urdf("mobile_manipulator.urdf", "arm_base", "part_a")


def _line_cord(start, heading, N=CORD.N):
    """A straight cord of N items L_S apart from ``start`` along the horizontal ``heading`` (rad)."""
    d = np.array([math.cos(heading), math.sin(heading), 0.0])
    items = np.asarray(start, dtype=float) + CORD.L_S * np.arange(N)[:, None] * d
    return Cord(items, 1 if N > 1 else 0, 0, np.zeros(2 if N > 1 else 0), False, d[:2])


def test_section_sizes_follow_eq_7_by_hand():
    K_a, K_b, L_S = 0.05, 0.06, 0.03
    sizes = section_sizes(5, L_S, VicinityParams(K_a=K_a, K_b=K_b))
    # L_os,i = 1 + i·L_S = 1.03, 1.06, 1.09, 1.12, 1.15
    # a_i = K_a·L_os²: 0.05·1.0609 = 0.053045, …, 0.05·1.3225 = 0.066125
    # b_i = K_b·L_os/2: 0.03·1.03 = 0.0309, …, 0.03·1.15 = 0.0345
    np.testing.assert_allclose(sizes[:, 1], [0.053045, 0.05618, 0.059405, 0.06272, 0.066125], atol=1e-12)
    np.testing.assert_allclose(sizes[:, 2], [0.0309, 0.0318, 0.0327, 0.0336, 0.0345], atol=1e-12)
    np.testing.assert_allclose(sizes[:, 0], L_S)  # thickness along the cord: RandomPoseGenerate(a_i, b_i, L_S)


def test_single_item_is_an_ellipsoid_with_doubled_gains_eq_8():
    (c, a, b), = section_sizes(1, 0.03, VicinityParams(K_a=0.05, K_b=0.06))
    # K_sa = 2K_a = 0.1, K_sb = 2K_b = 0.12, L_os = 1.03
    assert a == pytest.approx(0.1 * 1.03**2)  # 0.10609
    assert b == pytest.approx(0.12 * 1.03 / 2)  # 0.0618
    assert c == pytest.approx(0.03)  # c_1 = L_S


def test_sections_are_perpendicular_to_the_cord_and_samples_fall_inside_them():
    x = np.linspace(0.2, 0.35, CORD.N_OP)
    history = np.column_stack((x, 0.3 - 2.0 * (x - 0.3) ** 2, np.full(x.size, 0.7)))
    cord = build_cord(history[-1], history, ugv_speed=0.1, uav_speed=0.5)
    vicinity = build_vicinity(cord, CORD.L_S, VICINITY)
    tangents = np.gradient(cord.items, axis=0)
    tangents /= np.linalg.norm(tangents, axis=1, keepdims=True)
    np.testing.assert_allclose(vicinity.rotations[:, :, 0], tangents, atol=1e-12)  # along the cord
    np.testing.assert_allclose(vicinity.rotations[:, 2, 1], 0.0, atol=1e-12)  # semimajor axis horizontal
    np.testing.assert_allclose(vicinity.rotations[:, 2, 2], 1.0, atol=1e-12)  # semiminor axis vertical
    points, section = vicinity.sample(200, np.random.default_rng(0))
    assert points.shape == (200 * CORD.N, 3)
    local = np.einsum("nji,nj->ni", vicinity.rotations[section], points - vicinity.centers[section])
    assert np.all(np.sum((local / vicinity.semi_axes[section]) ** 2, axis=1) <= 1.0 + 1e-12)
    assert vicinity.contains(points).all()
    # the draws fill the sections: they reach most of each semi-axis
    extent = np.abs(local).max(axis=0) / vicinity.semi_axes.max(axis=0)
    assert np.all(extent > 0.8)


def test_carrier_zones_come_from_the_urdf(kinematics):
    zones = carrier_zones(kinematics, "mobile_manipulator.urdf")
    names = [z.name for z in zones.zones]
    assert any(n.startswith("base_link") for n in names) and "shoulder_singularity" in names
    base = next(z for z in zones.zones if z.name.startswith("base_link"))
    np.testing.assert_allclose(base.upper[2], 0.0, atol=1e-9)  # the top deck is M's z = 0
    free = zones.points_free(np.array([[0.3, 0.0, 0.6], [0.1, 0.0, -0.05], [0.0, 0.0, 0.6], [0.0, 0.0, 1.2]]))
    assert free.tolist() == [True, False, False, False]  # free, inside the base, singular, out of reach


def _random_scene(rng, kinematics):
    """The carrier's zones plus random LiDAR walls and boxes near a random straight cord."""
    zones = carrier_zones(kinematics, "mobile_manipulator.urdf")
    heading = rng.uniform(-math.pi, math.pi)
    start = np.array([0.0, 0.0, rng.uniform(0.55, 0.8)])
    start[:2] = rng.uniform(0.2, 0.35) * np.array([math.cos(heading + 1.0), math.sin(heading + 1.0)])
    cord = _line_cord(start, heading, N=int(rng.choice([1, CORD.N])))
    centre = cord.items.mean(axis=0)
    for _ in range(rng.integers(1, 4)):
        offset = rng.uniform(-0.15, 0.15, 3)
        offset[2] = rng.uniform(-0.1, 0.1)
        zones.add_box("box", centre + offset, rng.uniform(0.02, 0.06, 3), kind="obstacle")
    bearing = math.atan2(centre[1], centre[0]) + rng.uniform(-0.6, 0.6)
    wall = np.array([math.cos(bearing), math.sin(bearing)]) * (np.linalg.norm(centre[:2]) + rng.uniform(0.08, 0.2))
    along = np.array([-math.sin(bearing), math.cos(bearing)])
    hits = wall + np.linspace(-0.3, 0.3, 40)[:, None] * along
    zones.add_obstacle_columns(hits, origin_xy=np.zeros(2))
    return zones, cord


def test_vicinity_never_intersects_a_zone_after_repair(kinematics):
    rng = np.random.default_rng(2024)
    repaired = blocked_before = 0
    scenes = 40
    for _ in range(scenes):
        zones, cord = _random_scene(rng, kinematics)
        vicinity = build_vicinity(cord, CORD.L_S, VICINITY)
        blocked_before += not zones.vicinity_free(vicinity)
        repair = repair_cord(cord, zones, thickening(vicinity, zones.params))
        if not repair.ok:
            continue  # the cord has nowhere to go: the planner falls back, nothing to check
        repaired += 1
        fixed = build_vicinity(repair.cord, CORD.L_S, VICINITY)
        # exact ellipsoid–zone tests: every section stays T_s away from every zone (tiny solver slack)
        assert zones.vicinity_free(fixed, clearance=zones.params.T_s - 1e-4)
        points, _ = fixed.sample(100, rng)
        assert zones.points_free(points).all()
    assert blocked_before >= scenes // 3  # the scenes do put zones in the way
    assert repaired >= 0.9 * scenes


def test_repair_leaves_a_free_cord_alone_and_shifts_a_blocked_one():
    zones = ZoneMap(ZoneParams())
    cord = _line_cord([0.3, -0.06, 0.7], 0.0)
    vicinity = build_vicinity(cord, CORD.L_S, VICINITY)
    clearance = thickening(vicinity, zones.params)
    assert clearance == pytest.approx(vicinity.semi_axes[-1, 1] + zones.params.T_s)  # a_N + T_s
    untouched = repair_cord(cord, zones, clearance)
    assert untouched.ok and untouched.iterations == 0 and untouched.cord is cord
    zones.add_box("post", [0.36, 0.05, 0.7], [0.03, 0.03, 0.3], kind="obstacle")  # beside the cord (+y)
    shifted = repair_cord(cord, zones, clearance)
    assert shifted.ok and shifted.iterations > 0
    assert np.all(shifted.cord.items[:, 1] <= cord.items[:, 1] + 1e-12)  # pushed away from the post (-y)
    assert zones.points_free(shifted.cord.items, clearance).all()


def test_random_sample_validation(kinematics):
    rng = np.random.default_rng(5)
    zones = carrier_zones(kinematics, "mobile_manipulator.urdf")
    vicinity = build_vicinity(_line_cord([0.3, 0.0, 0.7], 0.5), CORD.L_S, VICINITY)
    with IKEngine(kinematics) as ik:
        good = validate_vicinity(vicinity, zones, rng, samples=64, ik=ik, q_ref=Q_READY)
        assert good.ok and good.free_fraction == 1.0 and good.reachable_fraction == 1.0
        zones.add_box("crate", vicinity.centers[2], [0.02, 0.02, 0.02], kind="obstacle")
        blocked = validate_vicinity(vicinity, zones, rng, samples=64, ik=ik, q_ref=Q_READY)
        assert not blocked.ok and blocked.free_fraction < 1.0
        far = build_vicinity(_line_cord([0.9, 0.0, 0.7], 0.0), CORD.L_S, VICINITY)  # beyond the arm's reach
        unreachable = validate_vicinity(far, ZoneMap(), rng, samples=64, ik=ik, q_ref=Q_READY)
        assert not unreachable.ok and unreachable.reachable_fraction == 0.0
