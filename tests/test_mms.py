"""MMS of Arora & Papachristos: holstered Tellos, grasping and lifting a launching apparatus, releasing the MAV."""

import math

import numpy as np
import pybullet
import pytest

from marsupial.api.errors import UnknownNameError
from marsupial.api.kinematics import ArmKinematics
from marsupial.world import World
from marsupial.world.robots.mms import MMS, LaunchingApparatus


def _rotation(q) -> np.ndarray:
    return np.array(pybullet.getMatrixFromQuaternion(q)).reshape(3, 3)


def _ik(kin: ArmKinematics, q0, p_goal, R_goal) -> np.ndarray:
    """Damped least squares on the pinocchio model of mms.urdf (poses in arm_base_link)."""
    q = np.array(q0, dtype=float)
    for _ in range(300):
        p, R = kin.forward(q)
        error = np.r_[p_goal - p, 0.5 * sum(np.cross(R[:, i], R_goal[:, i]) for i in range(3))]
        if np.linalg.norm(error) < 1e-8:
            break
        J = kin.jacobian(q)
        q = kin.clip(q + J.T @ np.linalg.solve(J @ J.T + 1e-4 * np.eye(6), error))
    assert np.linalg.norm(error) < 1e-5
    return q


def test_tellos_sit_in_the_holsters_with_motors_off():
    with World() as world:
        mms = world.add_robot("mms", pose=[1.0, -0.5, 0.3])
        assert isinstance(mms, MMS)
        assert set(mms.holsters) == {"holster_left", "holster_right"}
        for i, (name, holster) in enumerate(mms.holsters.items()):
            assert holster.mav is world.robot(f"mms_tello_{i}") and holster.apparatus.mav is holster.mav
            assert mms.launch_apparatus(i) is mms.launch_apparatus(name) is holster.apparatus
        left = mms.holsters["holster_left"]
        p_base, q_base = mms.pose()
        assert (_rotation(q_base).T @ (left.apparatus.handle_pose()[0] - p_base))[1] > 0  # on the left
        mms.drive(0.5, 0.4)
        world.step(3.0)
        mms.stop()
        world.step(1.0)
        for holster in mms.holsters.values():
            tello, apparatus = holster.mav, holster.apparatus
            assert not tello.motors_on and tello.docked and apparatus.latched and apparatus.mav_secured
            p_seat, q_seat = apparatus.seat_pose()
            p_tello, q_tello = tello.pose()
            assert p_tello == pytest.approx(p_seat + [0, 0, tello.spec.landed_height], abs=1e-3)
            assert np.allclose(_rotation(q_tello), _rotation(q_seat), atol=1e-3)
            p_holster, _ = mms.link_pose(holster.link)
            assert apparatus.handle_pose()[0] == pytest.approx(p_holster, abs=1e-3)
        assert apparatus.length == pytest.approx(0.30, abs=1e-3)
        with pytest.raises(UnknownNameError, match="holster_left"):
            mms.launch_apparatus("holster_middle")


def _move(world, mms, q, seconds):
    mms.set_joint_targets(q)
    world.step(seconds)


def test_gripper_grasps_an_apparatus_lifts_it_and_the_tello_takes_off():
    with World() as world:
        mms = world.add_robot("mms")
        kin = ArmKinematics.from_urdf("mms.urdf", "arm_base_link", "tcp")
        p_arm, q_arm = mms.link_pose("arm_base_link")
        R_arm = _rotation(q_arm)
        p_fk, _ = kin.forward(mms.arm_positions())
        assert R_arm @ p_fk + p_arm == pytest.approx(mms.tcp_pose()[0], abs=1e-6)  # one URDF for both

        apparatus: LaunchingApparatus = mms.launch_apparatus("holster_right")
        other = mms.launch_apparatus("holster_left")
        p_handle, q_handle = apparatus.handle_pose()
        across = _rotation(q_handle)[:, 1]  # fingers close across the handle, approach from above
        down = np.array([0.0, 0.0, -1.0])
        R_goal = R_arm.T @ np.c_[np.cross(across, down), across, down]

        def goal(dz):  # the handle point dz (m) above, in the arm base frame
            return R_arm.T @ (p_handle + [0.0, 0.0, dz] - p_arm)

        g = goal(0.10)
        q_pre = _ik(kin, [math.atan2(g[1], g[0]), 0.3, 1.2, 0.0, 1.6, 0.0], g, R_goal)
        q_at = _ik(kin, q_pre, goal(0.0), R_goal)
        q_up = _ik(kin, q_pre, goal(0.20), R_goal)

        _move(world, mms, [q_pre[0], *mms.arm_positions()[1:]], 3.5)  # swing round above the deck
        _move(world, mms, q_pre, 2.0)
        _move(world, mms, q_at, 1.5)
        assert mms.tcp_pose()[0] == pytest.approx(p_handle, abs=3e-3)
        assert not mms.grasp(apparatus)  # fingers still open
        mms.close_gripper()
        world.step(1.0)
        assert mms.gripper_opening() == pytest.approx(apparatus.handle_size[1], abs=2e-3)
        assert mms.grasp(apparatus) and mms.held is apparatus and not apparatus.latched

        _move(world, mms, q_up, 2.0)
        assert apparatus.handle_pose()[0] == pytest.approx(p_handle + [0, 0, 0.20], abs=5e-3)
        tello = apparatus.mav
        p_seat, _ = apparatus.seat_pose()
        assert tello.pose()[0] == pytest.approx(p_seat + [0, 0, tello.spec.landed_height], abs=2e-3)
        assert other.latched and other.mav.pose()[0][2] == pytest.approx(0.4225, abs=1e-3)
        assert mms.state()["held"] == apparatus.name

        # launch: the apparatus lets the MAV go and it climbs off the cradle
        apparatus.release_mav()
        assert not apparatus.mav_secured and not tello.docked
        tello.set_motors(True)
        tello.command_velocity(0.0, 0.0, 0.5)
        world.step(1.5)
        assert tello.pose()[0][2] - p_seat[2] > 0.3
        assert apparatus.handle_pose()[0] == pytest.approx(p_handle + [0, 0, 0.20], abs=5e-3)

        assert mms.release() is apparatus and mms.held is None


def test_safe_stop_holds_the_arm_and_stops_the_base():
    with World() as world:
        mms = world.add_robot("mms", mavs=False)
        assert all(h.mav is None for h in mms.holsters.values())
        mms.drive(0.8, 0.0)
        mms.set_joint_targets([1.0, 0.0, 1.0, 0.0, 1.0, 0.0])
        world.step(1.0)
        mms.safe_stop()
        q_stop = mms.arm_positions()
        world.step(2.5)
        assert mms.arm_positions() == pytest.approx(q_stop, abs=0.02)
        assert abs(mms.speed()) < 1e-3


def test_a_team_tello_stored_on_the_mms_sits_in_the_first_empty_apparatus():
    with World() as world:
        mms = world.add_robot("mms", mavs=False)
        first, second = world.add_robot("tello", "first"), world.add_robot("tello", "second")
        mms.store(first)
        mms.store(second)
        left, right = mms.launch_apparatus("holster_left"), mms.launch_apparatus("holster_right")
        assert left.mav is first and right.mav is second and left.mav_secured and first.docked
        assert mms.holsters["holster_left"].mav is first
        assert first.pose()[0] == pytest.approx(left.seat_pose()[0] + [0, 0, first.spec.landed_height], abs=1e-6)
        with pytest.raises(ValueError, match="already carries a MAV"):
            mms.store(world.add_robot("tello", "third"))
        with pytest.raises(ValueError, match="carry tello micro-scouts, not a bebop2"):
            mms.store(world.add_robot("bebop2", "big"))
