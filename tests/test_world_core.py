"""World core: clock, seeded streams, isolation of worlds, camera intrinsics, diff-drive base."""

import math

import numpy as np
import pybullet
import pytest

from marsupial.api.errors import UnknownNameError
from marsupial.api.model import DiffDriveLimits, Intrinsics
from marsupial.world import World
from marsupial.world.robots.diff_drive import DiffDrive


def test_clock_counts_whole_physics_steps():
    with World() as world:
        world.step(1.0)
        world.step(0.5)
        assert world.clock.steps == 360
        assert world.now == pytest.approx(1.5, abs=1e-12)


def test_noise_streams_depend_on_seed_and_key_only():
    with World(seed=3) as a, World(seed=3) as b, World(seed=4) as c:
        assert a.rng_for("sonar").random() == b.rng_for("sonar").random()
        assert a.rng_for("sonar").random() != a.rng_for("imu").random()
        assert a.rng_for("sonar").random() != c.rng_for("sonar").random()


def test_worlds_in_one_process_are_isolated():
    with World() as a, World() as b:
        box = pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=[0.1] * 3, physicsClientId=a.client_id)
        body = pybullet.createMultiBody(1.0, box, -1, [0, 0, 2], physicsClientId=a.client_id)
        a.step(0.5)
        assert (
            pybullet.getNumBodies(physicsClientId=a.client_id) == pybullet.getNumBodies(physicsClientId=b.client_id) + 1
        )
        z = pybullet.getBasePositionAndOrientation(body, physicsClientId=a.client_id)[0][2]
        assert z == pytest.approx(2 - 0.5 * 9.81 * 0.5**2, abs=0.02)


def test_intrinsics_follow_fov_and_resolution():
    K = Intrinsics(640, 480, fov_v_deg=60.0).K
    assert K[1, 1] == pytest.approx(240 / math.tan(math.radians(30)))
    assert K[0, 0] == K[1, 1]
    assert (K[0, 2], K[1, 2]) == (319.5, 239.5)


def test_unknown_robot_kind_lists_known_kinds():
    with World() as world, pytest.raises(UnknownNameError, match="unknown robot 'no_such_bot'"):
        world.add_robot("no_such_bot")


def _driven_box(world, limits):
    cid = world.client_id
    shape = pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=[0.3, 0.25, 0.1], physicsClientId=cid)
    body = pybullet.createMultiBody(20.0, shape, -1, [0, 0, 0.15], physicsClientId=cid)
    drive = DiffDrive(world, body, limits, "test/drive")
    world.add_actor(
        type("A", (), {"pre_physics": lambda self, dt: drive.pre_physics(dt), "post_physics": lambda self, dt: None})()
    )
    return body, drive


def test_diff_drive_reaches_commanded_speed_and_closes_a_circle():
    with World() as world:
        body, drive = _driven_box(world, DiffDriveLimits(max_speed=2.0, max_omega=1.0, max_accel=1.0))
        drive.command(0.5, 0.0)
        world.step(3.0)
        v = pybullet.getBaseVelocity(body, physicsClientId=world.client_id)[0]
        assert v[0] == pytest.approx(0.5, abs=1e-3)
        start = np.array(pybullet.getBasePositionAndOrientation(body, physicsClientId=world.client_id)[0])
        drive.command(0.5, 0.5)
        world.step(2 * math.pi / 0.5)
        end = np.array(pybullet.getBasePositionAndOrientation(body, physicsClientId=world.client_id)[0])
        assert np.linalg.norm(end[:2] - start[:2]) < 0.05


def test_diff_drive_is_stopped_by_a_wall():
    with World() as world:
        cid = world.client_id
        wall = pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=[0.1, 2, 1], physicsClientId=cid)
        pybullet.createMultiBody(0.0, wall, -1, [3, 0, 1], physicsClientId=cid)
        body, drive = _driven_box(world, DiffDriveLimits(max_speed=2.0, max_omega=1.0, max_force=500.0))
        drive.command(1.0, 0.0)
        world.step(8.0)
        x = pybullet.getBasePositionAndOrientation(body, physicsClientId=cid)[0][0]
        assert x == pytest.approx(3 - 0.1 - 0.3, abs=0.02)


def test_missing_asset_names_the_known_ones():
    from marsupial.api.assets import asset_path

    with pytest.raises(
        UnknownNameError, match=r"unknown asset 'bebop3.urdf'\. Did you mean 'bebop2.urdf'\?.*summit_xl.urdf"
    ):
        asset_path("bebop3.urdf")


def _team_trace(seed):
    from marsupial.world.disturbances import apply_disturbances

    with World(scene="open_field", seed=seed) as world:
        ugv = world.add_robot("summit_xl", name="ugv", pose=[0, 0, 0])
        uav = world.add_robot("ardrone2", name="uav", pose=[0, 0, 2.0, 0])
        apply_disturbances(world, {"wind": {"gust": 2.0}})
        ugv.drive(0.7, 0.07)
        uav.command_velocity(0.7, 0.0, 0.0, 0.07)
        trace = []
        for _ in range(40):
            world.step(0.1)
            trace.append(np.concatenate([ugv.pose()[0], uav.pose()[0], uav.pose()[1]]))
        return np.array(trace)


def test_two_runs_with_one_seed_give_identical_pose_traces():
    first, second, other = _team_trace(7), _team_trace(7), _team_trace(8)
    assert np.array_equal(first, second)
    assert not np.allclose(first, other, atol=1e-4)  # gusts and wheel noise do depend on the seed
