"""Child and mother UGVs of Zhao et al.: Table 1 geometry, benchmark seen by the child camera, entrance fit, lifting."""

import math

import numpy as np
import pybullet
import pytest

from marsupial.world import World
from marsupial.world.robots.base import yaw_of
from marsupial.world.robots.ugv_docking import ChildUGV, MotherUGV


def _contacts(world, a, b) -> int:
    """Penetrating contact points between the bodies of robots ``a`` and ``b``."""
    points = pybullet.getContactPoints(a.body_id, b.body_id, physicsClientId=world.client_id)
    return sum(1 for point in points if point[8] < 0.0)


def _child_in_front(world, mother, distance, lateral=0.0, **options):
    """A child facing the entrance, its front ``distance`` (m) from it and ``lateral`` (m) to its left."""
    p_entrance, heading = mother.entrance_pose()
    forward = np.array([math.cos(heading), math.sin(heading), 0.0])
    left = np.array([-forward[1], forward[0], 0.0])
    p = p_entrance - forward * (distance + 0.10) + left * lateral  # the child's front is 0.10 m ahead of its centre
    return world.add_robot("child_ugv", pose=[p[0], p[1], heading], **options)


def test_table_1_geometry():
    with World() as world:
        mother = world.add_robot("mother_ugv", pose=[0.0, 0.0, 0.0])
        child = world.add_robot("child_ugv", pose=[-2.0, 0.0, 0.0])
        assert isinstance(mother, MotherUGV) and isinstance(child, ChildUGV)
        cid = world.client_id
        # entrance b_e = 19 cm: rays from the slot's centre line hit the station walls 9.5 cm either side
        p_entrance, heading = mother.entrance_pose()
        inside = p_entrance + np.array([0.05, 0.0, 0.05])
        hits = [pybullet.rayTest(inside, inside + [0.0, s * 0.3, 0.0], physicsClientId=cid)[0] for s in (1, -1)]
        assert all(hit[0] == mother.body_id for hit in hits)
        assert hits[0][3][1] - hits[1][3][1] == pytest.approx(0.19, abs=1e-4)
        assert mother.entrance_width == 0.19
        # child b_c = 17 cm
        lo, hi = pybullet.getAABB(child.body_id, -1, physicsClientId=cid)
        assert hi[1] - lo[1] == pytest.approx(0.17, abs=1e-3) and child.size[1] == pytest.approx(0.17)
        # camera tilted up θ = 15°, H_GS h = 23 cm above it
        p_cam, R_cam = child.camera.optical_pose()
        assert math.degrees(math.asin(R_cam[2, 2])) == pytest.approx(15.0, abs=1e-3)
        assert mother.benchmark_pose()[0][2] - p_cam[2] == pytest.approx(0.23, abs=1e-4)
        assert child.camera.intrinsics.fov_v_deg == 61.0
        assert (child.camera.intrinsics.width, child.camera.intrinsics.height) == (640, 480)
        assert heading == pytest.approx(0.0)
        assert {"platform_height", "carried"} <= set(mother.state())


def _main_colour(rgb: np.ndarray) -> np.ndarray:
    """Per pixel: 1 where red is the main component, 2 where green is (§3.1), else 0."""
    r, g, b = (rgb[..., i].astype(int) for i in range(3))
    return np.where((r > g + 60) & (r > b + 60), 1, np.where((g > r + 60) & (g > b + 60), 2, 0))


@pytest.mark.parametrize("distance", [0.5, 1.0, 1.5])
def test_child_camera_sees_the_red_green_benchmark(distance):
    with World() as world:
        mother = world.add_robot("mother_ugv", pose=[1.0, 0.5, 0.4])
        child = _child_in_front(world, mother, distance)
        frame = child.camera.measure()
        colour = _main_colour(frame.rgb)
        rows, cols = np.nonzero(colour)
        assert (colour == 1).sum() > 100 and (colour == 2).sum() > 100
        # I_h: the crossing of the colour borders, where the benchmark projects
        p_bench, _ = mother.benchmark_pose()
        p_optical = frame.rotation.T @ (p_bench - frame.position)
        u_h, v_h = (frame.K @ (p_optical / p_optical[2]))[:2]
        assert (cols.min() + cols.max()) / 2 == pytest.approx(u_h, abs=2.0)
        assert abs(u_h - 319.5) < 3  # a child facing the entrance sees it on the vertical bisector
        # s_u: the benchmark is 0.136 m wide (203 px at d_e = 22 cm, Table 1)
        assert cols.max() - cols.min() + 1 == pytest.approx(0.136 * frame.K[0, 0] / p_optical[2], abs=3)
        # layout: red top-left and bottom-right, green top-right and bottom-left
        u, v = int(round(u_h)), int(round(v_h))

        def quarter(r0, r1, c0, c1):  # the dominant colour (1 red, 2 green) of an image window
            return np.bincount(colour[r0:r1, c0:c1].ravel(), minlength=3)[1:].argmax() + 1

        h = max(3, (rows.max() - rows.min()) // 4)
        w = max(3, (cols.max() - cols.min()) // 4)
        assert quarter(v - h, v - 1, u - w, u - 1) == 1
        assert quarter(v - h, v - 1, u + 1, u + w) == 2
        assert quarter(v + 1, v + h, u - w, u - 1) == 2
        assert quarter(v + 1, v + h, u + 1, u + w) == 1


def _drive_in(world, mother, child, stop_x_in_mother: float) -> int:
    """Drive the child straight at 0.1 m/s until its centre reaches ``stop_x_in_mother``; count contacts on the way."""
    p_mother, q_mother = mother.pose()
    yaw = yaw_of(q_mother)
    child.drive(0.1, 0.0)
    contacts = 0
    for _ in range(140):
        world.step(0.05)
        contacts += _contacts(world, child, mother)
        d = child.pose()[0] - p_mother
        if d[0] * math.cos(yaw) + d[1] * math.sin(yaw) >= stop_x_in_mother:
            break
    child.stop()
    world.step(0.5)
    return contacts


def test_aligned_child_fits_the_entrance_and_an_offset_one_collides():
    with World() as world:
        mother = world.add_robot("mother_ugv")
        aligned = _child_in_front(world, mother, 0.3, limits={"noise_std": 0.0})
        assert not mother.child_on_platform(aligned)
        assert _drive_in(world, mother, aligned, stop_x_in_mother=-0.25) == 0
        assert mother.child_on_platform(aligned)
    with World() as world:
        mother = world.add_robot("mother_ugv")
        offset = _child_in_front(world, mother, 0.3, lateral=0.012)  # 17 cm + 2 × 1.2 cm > 19 cm
        assert _drive_in(world, mother, offset, stop_x_in_mother=-0.25) > 0
        assert not mother.child_on_platform(offset)
        assert offset.pose()[0][0] < -0.45 - 0.09  # stopped at the wall's edge, outside the station


def test_lifting_platform_stores_carries_and_returns_the_child():
    with World() as world:
        mother = world.add_robot("mother_ugv", pose=[0.0, 0.0, 0.0])
        child = world.add_robot("child_ugv", pose=[-0.25, 0.0, 0.0])  # on the plate
        world.step(0.2)
        assert mother.child_on_platform(child)
        z0 = child.pose()[0][2]
        assert mother.raise_platform() == [child.name]
        world.step(0.30 / 0.05 + 1.0)
        assert mother.platform_height() == pytest.approx(mother.lift_travel, abs=2e-3)
        assert child.pose()[0][2] - z0 == pytest.approx(0.30, abs=3e-3)
        assert child.carrier is mother and mother.state()["carried"] == [child.name]
        # carried along while the mother drives and turns; commands to the child are ignored
        child.drive(0.3, 0.0)
        mother.drive(0.4, 0.3)
        world.step(3.0)
        mother.stop()
        world.step(1.5)
        p_plate, q_plate = mother.platform_pose()
        R = np.array(pybullet.getMatrixFromQuaternion(q_plate)).reshape(3, 3)
        offset = R.T @ (child.footprint_pose()[0] - p_plate)
        assert offset == pytest.approx([0.0025, 0.0, 0.0], abs=3e-3)  # still where it boarded
        # lowered: released on the floor, drives again
        mother.lower_platform()
        world.step(0.30 / 0.05 + 1.0)
        assert child.carrier is None and not mother.carried
        assert child.pose()[0][2] == pytest.approx(z0, abs=2e-3)
        child.drive(-0.1, 0.0)
        world.step(2.0)
        assert child.speed() == pytest.approx(-0.1, abs=0.01)


def test_platform_rises_without_a_child_that_is_not_aboard():
    with World() as world:
        mother = world.add_robot("mother_ugv")
        outside = world.add_robot("child_ugv", pose=[-1.5, 0.0, 0.0])
        assert mother.raise_platform() == []
        world.step(7.0)
        assert mother.platform_height() == pytest.approx(0.30, abs=2e-3)
        assert outside.carrier is None and outside.pose()[0][2] == pytest.approx(0.055, abs=1e-3)
        mother.safe_stop()
        world.step(0.5)
        assert mother.platform_height() == pytest.approx(0.30, abs=2e-3)
