"""Motion Engine of Narváez et al. (Fig. 5): two rates in simulated time, tracking a UAV with the real arm.

A synthetic UAV (ground-truth P_Q^M, no rendering) flies a line 1.25 m
above frame M at 0.15 m/s; the engine drives the mobile manipulator's joint
PIDs in pybullet and keeps the eye-in-hand camera under the marker: after
1 s of start-up the marker centre stays within 4 cm of the optical axis
(1 cm on average), no joint exceeds 15 rpm, every planning cycle has ≥ 300
valid vertices and recycles the previous ones. Kinematic runs (no world)
check the rates f_B = 4 Hz and f_O = 8 Hz, determinism, the hold when the
UAV is lost, obstacle scans in the local map (a real LiDAR scan of a wall,
converted to M) and the contact-phase target.
"""

import numpy as np
import pytest

from marsupial.api.errors import UnknownNameError
from marsupial.api.kinematics import ArmKinematics
from marsupial.skills.uav_docking.engine import MotionEngine, MotionEngineParams, ObstacleScan
from marsupial.world import World
from marsupial.world.robots.mobile_manipulator import JOINT_SPEED_LIMIT

SPEED = 0.15  # m/s, UAV speed along the line (in M)


def uav_on_line(t: float, start=(0.30, -0.30, 1.25), direction=(0.0, 1.0, 0.0), speed=SPEED) -> np.ndarray:
    """P_Q^M of a level UAV flying a straight line."""
    T = np.eye(4)
    T[:3, 3] = np.asarray(start) + speed * t * np.asarray(direction)
    return T


@pytest.fixture(scope="module")
def kinematics():
    return ArmKinematics.from_urdf("mobile_manipulator.urdf", "arm_base", "part_a")


def _under_the_uav(engine: MotionEngine, T_M_Q: np.ndarray, q_now: np.ndarray) -> np.ndarray:
    q = engine.joint_goal(*engine.pbvs(T_M_Q), q_now)
    assert q is not None
    return q


def _drive(engine: MotionEngine, seconds: float, rate: float = 40.0, q0=None, uav=uav_on_line):
    """Kinematic run: the arm follows the set-point exactly. Returns the commands."""
    q = _under_the_uav(engine, uav(0.0), np.zeros(6)) if q0 is None else q0
    commands = []
    for k in range(int(seconds * rate)):
        command = engine.update(k / rate, q, uav(k / rate), 0.0, SPEED)
        q = command.q
        commands.append(command)
    return commands


def test_the_arm_tracks_a_uav_flying_a_line_in_the_world():
    with World(seed=3) as world:
        carrier = world.add_robot("mobile_manipulator", "carrier", arm_pose="docking_ready")
        kinematics = carrier.arm_kinematics
        engine = MotionEngine(kinematics, world.rng_for("carrier/motion_engine"))
        carrier.reset_arm(_under_the_uav(engine, uav_on_line(0.0), carrier.joint_positions()))
        aim_Q = np.append(engine.target.aim_Q, 1.0)
        offsets, speeds, vertices, recycled, planned, selected = [], [], [], [], 0, 0
        while world.now < 4.0 - 1e-9:
            command = engine.update(world.now, carrier.joint_positions(), uav_on_line(world.now), 0.0, SPEED)
            carrier.set_joint_targets(command.q)
            planned += command.planned
            selected += command.selected
            if command.planned:
                vertices.append(engine.graph.n)
                recycled.append(engine.graph.n_recycled)
            world.step(1.0 / 40.0)
            speeds.append(np.abs(carrier.joint_velocities()).max())
            T_M_C = kinematics.transform(carrier.joint_positions(), "eye_in_hand")
            p_aim_C = np.linalg.solve(T_M_C, uav_on_line(world.now) @ aim_Q)[:3]  # the marker centre, camera frame
            offsets.append((world.now, np.hypot(p_aim_C[0], p_aim_C[1]), p_aim_C[2]))
    offsets = np.array(offsets)
    tracking = offsets[offsets[:, 0] > 1.0]
    assert tracking[:, 1].mean() < 0.02 and tracking[:, 1].max() < 0.04  # m off the optical axis
    assert np.degrees(np.arctan2(offsets[:, 1], offsets[:, 2])).max() < 6.0  # deep inside the 30° half FOV
    assert np.abs(offsets[:, 2] - engine.target.standoff).max() < 0.05  # at the standoff
    assert max(speeds) <= JOINT_SPEED_LIMIT * 1.02  # 15 rpm
    assert planned == 16 and selected == 32  # f_B = 4 Hz, f_O = 8 Hz over 4 s
    assert min(vertices) >= 300 and min(recycled[2:]) > 0


def test_rates_follow_the_simulated_time(kinematics):
    engine = MotionEngine(kinematics, np.random.default_rng(0))
    params = MotionEngineParams()
    assert params.f_B == 4.0 and params.f_O == 8.0  # §IV-A
    commands = _drive(engine, 2.0, rate=40.0)
    assert sum(c.planned for c in commands) == 8 and sum(c.selected for c in commands) == 16
    assert all(c.planned <= c.selected for c in commands)  # a planning cycle always precedes a selection
    t_selected = [c.t for c in commands if c.selected]
    np.testing.assert_allclose(np.diff(t_selected), 1.0 / 8.0)
    again = engine.update(commands[-1].t, commands[-1].q, uav_on_line(commands[-1].t))  # same time: nothing new
    assert not again.selected and not again.planned
    # a faster caller gets the same number of cycles
    fast = _drive(MotionEngine(kinematics, np.random.default_rng(0)), 2.0, rate=120.0)
    assert sum(c.planned for c in fast) == 8 and sum(c.selected for c in fast) == 16
    steps = np.abs(np.diff([c.q for c in fast], axis=0)).max(axis=1)
    replanned = np.array([c.selected for c in fast[1:]])
    assert steps[~replanned].max() <= JOINT_SPEED_LIMIT / 120.0 * 1.01  # along a trajectory: within 15 rpm
    assert steps[replanned].max() < 0.1  # a new trajectory takes over with a small step


def test_same_seed_same_commands(kinematics):
    a = _drive(MotionEngine(kinematics, np.random.default_rng(7)), 1.5)
    b = _drive(MotionEngine(kinematics, np.random.default_rng(7)), 1.5)
    np.testing.assert_array_equal([c.q for c in a], [c.q for c in b])
    np.testing.assert_array_equal([c.p_R_M for c in a], [c.p_R_M for c in b])


def test_a_lost_uav_finishes_the_trajectory_and_holds(kinematics):
    engine = MotionEngine(kinematics, np.random.default_rng(1))
    commands = _drive(engine, 1.0)
    q = commands[-1].q
    lost = []
    for k in range(40, 80):
        command = engine.update(k / 40.0, q, None)
        q = command.q
        lost.append(command)
    assert not any(c.tracking or c.selected or c.planned for c in lost)
    np.testing.assert_allclose(lost[-1].q, commands[-1].q_goal)  # reached the last goal and holds there
    np.testing.assert_allclose(lost[-1].qd, 0.0)
    back = engine.update(2.0, q, uav_on_line(2.0))
    assert back.tracking and back.selected


def test_obstacle_scans_shape_the_graph(kinematics):
    engine = MotionEngine(kinematics, np.random.default_rng(2))
    wall = np.column_stack((np.full(61, 0.40), np.linspace(-0.6, 0.6, 61)))  # LiDAR hits of a wall, M frame
    q = _under_the_uav(engine, uav_on_line(0.0, start=(0.38, -0.2, 1.25)), np.zeros(6))
    for k in range(12):
        t = k / 8.0
        command = engine.update(t, q, uav_on_line(t, start=(0.38, -0.2, 1.25)), 0.0, SPEED, wall if k == 0 else None)
        q = command.q
        cycle = engine.cycle
        assert engine.zones.points_free(cycle.graph.positions).all()
        assert cycle.graph.n >= 300
    assert any(z.kind == "obstacle" for z in engine.zones.zones)
    assert cycle.repair.ok and cycle.repair.iterations > 0  # the wall pushed the cord toward the arm
    assert engine.zones.vicinity_free(cycle.vicinity, clearance=engine.zones.params.T_s - 1e-4)
    engine.update(2.0, q, uav_on_line(2.0, start=(0.38, -0.2, 1.25)), obstacles=ObstacleScan(np.zeros((0, 2))))
    assert not any(z.kind == "obstacle" for z in engine.zones.zones)  # an empty scan clears the map


def test_lidar_scans_enter_the_map_in_frame_m():
    with World(seed=4) as world:
        carrier = world.add_robot(
            "mobile_manipulator", "carrier", arm_pose="docking_ready", sensors={"lidar": {"noise_std": 0.0}}
        )
        bullet = world.bullet
        wall = bullet.createCollisionShape(bullet.GEOM_BOX, halfExtents=[0.02, 0.4, 0.4])
        bullet.createMultiBody(0.0, wall, basePosition=[0.50, 0.0, 0.4])  # 0.5 m ahead of the base centre
        world.step(0.05)
        scan = carrier.lidar.read().data
        engine = MotionEngine(carrier.arm_kinematics, world.rng_for("carrier/motion_engine"))
        obstacles = engine.scan_from_sensor(scan.points_sensor())
        p_M, q_M = carrier.arm_base_pose()
        R_world_M = np.array(world.bullet.getMatrixFromQuaternion(q_M)).reshape(3, 3)
        expected = (scan.points_world() - p_M) @ R_world_M  # the same echoes, world → M
        np.testing.assert_allclose(obstacles.points_M, expected[:, :2], atol=1e-6)
        front = np.abs(obstacles.points_M[:, 1]) < 0.3
        np.testing.assert_allclose(obstacles.points_M[front, 0], 0.50 - 0.02 + 0.06, atol=0.01)  # the wall's face
        T_M_Q = uav_on_line(0.0, start=(0.48, 0.0, 1.25))  # P_VS 11 cm from the wall
        q = engine.joint_goal(*engine.pbvs(uav_on_line(0.0, start=(0.3, 0.0, 1.25))), carrier.joint_positions())
        engine.update(0.0, q, T_M_Q)
        assert engine.cycle.repair.iterations == 0  # free without the wall
        engine.update(0.25, q, T_M_Q, obstacles=obstacles)
        cycle = engine.cycle
        assert any(z.kind == "obstacle" for z in engine.zones.zones)
        assert cycle.repair.ok and cycle.repair.iterations > 0
        assert np.all(cycle.vicinity.centers[:, 0] < engine.pbvs(T_M_Q)[0][0])  # pushed back from the wall
        assert engine.zones.points_free(cycle.graph.positions).all() and cycle.graph.n >= 300


def test_contact_target_and_bad_input(kinematics):
    engine = MotionEngine(kinematics, np.random.default_rng(3))
    T_M_Q = uav_on_line(0.0)
    p_B_Q = np.array([0.11, 0.0, -0.08])  # the Bebop 2's Part B
    engine.set_target(frame="part_a", aim_Q=tuple(p_B_Q), standoff=0.02)
    p_vs, R_vs = engine.pbvs(T_M_Q)
    np.testing.assert_allclose(p_vs, T_M_Q[:3, 3] + p_B_Q - [0.0, 0.0, 0.02], atol=1e-12)  # Part A under Part B
    np.testing.assert_allclose(R_vs, np.eye(3), atol=1e-12)
    with pytest.raises(UnknownNameError, match="part_a"):
        engine.set_target(frame="gripper")
    with pytest.raises(ValueError, match="4x4"):
        engine.update(0.0, np.zeros(6), np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"\(n, 2\)"):
        engine.update(0.0, np.zeros(6), T_M_Q, obstacles=np.zeros((4, 5)))
    with pytest.raises(RuntimeError, match="UAV pose"):
        MotionEngine(kinematics, np.random.default_rng(3)).plan(0.0, np.zeros(6), 0.0, 0.0)
    with pytest.raises(ValueError, match="L_C"):
        MotionEngineParams(selection=MotionEngineParams().selection.__class__(L_C=0.2))
