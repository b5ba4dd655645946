"""The Motion Engine of the carrier's arm (Narváez et al., §IV-A, Fig. 5), driven by simulated time.

Two processes at two rates, both run from :meth:`MotionEngine.update`:

- **merge and selection** at f_O = 2·f_B = 8 Hz: the UAV pose P_Q^M becomes
  the online-PBVS target P_VS (stored in the history OP); the tracking
  state V_tr (eqs. 9–11) sets the path length L_p (eq. 12); the vertex P_R
  is selected on the graph, solved by IK and turned into a joint
  trajectory timed by toppra within the 15 rpm limit;
- **planning and optimisation** at f_B = 4 Hz: switching-regression cord
  (Algorithm 1), vicinity (eqs. 7–8), local map with the latest obstacle
  scan, cord repair (Fig. 9), random-sample validation, and the RRT* graph
  over IK-valid poses recycling the previous graph (Algorithms 2–3).

Between selections every call returns the running trajectory's set-point
(``lead_time`` ahead, against the PIDs' lag) for the joint PIDs
(``carrier.set_joint_targets``). Nothing here reads a clock: the caller
passes the simulated time.

A ``track`` skill is a loop over::

    engine = MotionEngine(carrier.arm_kinematics, rng=self.context.rng("carrier/motion_engine"))
    ...
    scan = engine.scan_from_sensor(carrier.sensor("lidar").read().data.points_sensor())  # or None: keep the last
    command = engine.update(self.now, carrier.joint_positions(), T_M_Q, carrier.speed(), uav_speed, scan)
    carrier.set_joint_targets(command.q)

with ``carrier`` the carrier's onboard interface (joint encoders, wheel
encoders, LiDAR) and ``T_M_Q`` the estimated UAV pose in M
(:mod:`.relative_pose`; ``None`` before any measurement: the engine
finishes the running trajectory and holds).
The contact phase (eq. 15) shortens the standoff with
``engine.set_target(standoff=…)`` and, to bring Part A under Part B,
``engine.set_target(frame="part_a", aim_Q=p_B_Q)``.

Measured (``benchmarks/motion_engine.py``, 2-core machine): planning
cycle 13 ms CPU at the median, 20 ms at the 95th percentile, with 360
valid vertices, ≈ 250 of them recycled; toppra ≈ 7 ms per selection. In the
simulation with the real arm and a UAV flying a line 1.25 m above M
(``tests/test_motion_engine.py``), the marker centre stays 0.8 cm from the
optical axis on average (1.6 cm at most) at 0.15 m/s, 4.6 cm (7.6 cm) at
0.3 m/s, after 1 s of start-up; the lead L_p and the joint PIDs' lag make
up most of it.

Frames: manipulator frame M (``arm_base``), metres, radians, seconds.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from marsupial.api.kinematics import ArmKinematics

from ..common.ik_engine import ArmGeometry, IKEngine
from ..common.trajectory import JointTrajectory, TrajectoryParams, plan_joint_trajectory
from .cord import Cord, CordParams, CordPlanner
from .graph import Graph, GraphParams, build_graph
from .selection import (
    PbvsTarget,
    Selection,
    SelectionParams,
    path_length,
    pbvs_target,
    pose_rates,
    select,
    tracking_state,
)
from .vicinity import Vicinity, VicinityCheck, VicinityParams, build_vicinity, validate_vicinity
from .zones import Repair, ZoneMap, carrier_zones, repair_cord, thickening

STAGES = ("cord", "vicinity", "map", "repair", "validation", "graph", "selection", "trajectory")
"""Stage names passed to the ``on_stage`` hook, in the order they run."""


@dataclass(frozen=True)
class MotionEngineParams:
    """Rates and the parameter sets of every stage (paper values as defaults where it gives them).

    Attributes:
        f_B: planning-and-optimisation rate f_B (Hz), §IV-A ("nearly at f_B = 4 Hz").
        validation_samples: random poses of the vicinity's quick validation, §IV-A-2.
        resync: joint distance (rad) between the set-point and the measured arm beyond
            which a new trajectory starts from the measured angles (the arm was held back).
        lead_time: the set-point sent to the joint PIDs is the trajectory's this far (s) ahead:
            a PID with velocity output kp follows a ramp qd·t with the lag qd/kp, so the lead
            1/kp (0.125 s for the carrier's kp = 8/s) cancels it.
        front_shoulder: solve IK toward the front-shoulder branch (joint 1 turned to the
            target's bearing), whose ±170° range of joint 1 leaves its gap behind the carrier;
            otherwise the branch closest to the present angles (it may run out of range
            ahead of the carrier and swing over).
        cord, vicinity, graph, selection, trajectory, target: the stages' parameters.
    """

    f_B: float = 4.0
    validation_samples: int = 32
    resync: float = 0.25
    front_shoulder: bool = True
    lead_time: float = 0.125
    cord: CordParams = CordParams()
    vicinity: VicinityParams = VicinityParams()
    graph: GraphParams = GraphParams()
    selection: SelectionParams = SelectionParams()
    trajectory: TrajectoryParams = TrajectoryParams()
    target: PbvsTarget = field(default_factory=PbvsTarget)

    def __post_init__(self) -> None:
        if self.f_B <= 0 or self.validation_samples < 1 or self.resync <= 0 or self.lead_time < 0:
            raise ValueError(
                f"MotionEngineParams needs f_B > 0, validation_samples >= 1, resync > 0, lead_time >= 0; got {self}"
            )
        if not math.isclose(self.selection.L_C, self.cord.L_C):
            raise ValueError(f"selection.L_C ({self.selection.L_C}) must be the cord's L_C ({self.cord.L_C})")

    @property
    def f_O(self) -> float:
        """Merge-and-selection rate f_O = 2·f_B (Hz), §IV-A."""
        return 2.0 * self.f_B


@dataclass(frozen=True)
class ObstacleScan:
    """Range-sensor hits for the local map, in M.

    Attributes:
        points_M: ``(n, 2)`` or ``(n, 3)`` hit points (m); only x, y are used (obstacle columns).
        origin_M: the sensor's position (m); ``None``: the engine's sensor link (the LiDAR).
    """

    points_M: np.ndarray
    origin_M: np.ndarray | None = None

    def __post_init__(self) -> None:
        points = np.asarray(self.points_M, dtype=float)
        if points.size == 0:
            points = points.reshape(0, 2)
        if points.ndim != 2 or points.shape[1] not in (2, 3):
            raise ValueError(f"an obstacle scan holds (n, 2) or (n, 3) points in M, got shape {points.shape}")
        object.__setattr__(self, "points_M", points)


@dataclass(frozen=True)
class PlanningCycle:
    """What one planning cycle produced (for logs, tests and plots).

    Attributes:
        t: simulated time (s); cord, repair, vicinity, check, graph: the stages' outputs
        (``vicinity`` is the repaired one).
    """

    t: float
    cord: Cord
    repair: Repair
    vicinity: Vicinity
    check: VicinityCheck
    graph: Graph


@dataclass(frozen=True)
class MotionCommand:
    """The engine's output at one call.

    Attributes:
        t: simulated time (s).
        q, qd: joint set-point (rad) and speed (rad/s) for the joint PIDs: the trajectory
            ``lead_time`` ahead of ``t`` (send ``q`` with ``set_joint_targets``).
        q_goal: joint angles (rad) of the pose the running trajectory goes to.
        p_vs_M: the PBVS target P_VS (m), ``None`` before the UAV was seen.
        p_R_M: the selected pose P_R (m), ``None`` without a graph.
        R_M_E: end-effector orientation of P_VS / P_R (3×3).
        tracking: True when this call had a UAV pose.
        planned, selected: True when a planning cycle / a selection ran in this call.
        L_p: path length of the last selection (m); V_tr: its tracking state (m/s).
    """

    t: float
    q: np.ndarray
    qd: np.ndarray
    q_goal: np.ndarray
    p_vs_M: np.ndarray | None
    p_R_M: np.ndarray | None
    R_M_E: np.ndarray | None
    tracking: bool
    planned: bool
    selected: bool
    L_p: float
    V_tr: float


def _as_pose(uav_M: np.ndarray) -> np.ndarray:
    """A 4×4 UAV pose in M from a 4×4 pose or a 3-vector position (heading along M's x)."""
    uav_M = np.asarray(uav_M, dtype=float)
    if uav_M.shape == (4, 4):
        return uav_M
    if uav_M.shape == (3,):
        T = np.eye(4)
        T[:3, 3] = uav_M
        return T
    raise ValueError(f"expected the UAV pose in M as a 4x4 transform or a position [x, y, z], got shape {uav_M.shape}")


class MotionEngine:
    """Fig. 5: planning and optimisation at f_B, merge and selection at f_O = 2·f_B, in simulated time.

    Args:
        kinematics: the carrier arm's model (``carrier.arm_kinematics``: M → ``part_a``).
        rng: the random source of the vicinity samples (``world.rng_for(...)``).
        params: :class:`MotionEngineParams`.
        zones: the prohibited zones (default: :func:`~.zones.carrier_zones` of the arm's URDF);
            obstacle scans are added to and cleared from it.
        ik: the IK engine (default: closed form, one process).
        urdf: the URDF of ``kinematics`` (for the default zones).
        sensor_link: link of the range sensor whose scans are passed in (its origin seeds the columns).
        on_stage: called with each stage's name (:data:`STAGES`) when it ends — a profiling hook.

    Attributes:
        cycle: the last :class:`PlanningCycle` (``None`` before the first).
        selection: the last :class:`~.selection.Selection` (``None`` if none).
        trajectory: the running :class:`~.trajectory.JointTrajectory` and ``trajectory_start`` (s).
        target: the present :class:`~.selection.PbvsTarget`.
    """

    def __init__(
        self,
        kinematics: ArmKinematics,
        rng: np.random.Generator,
        params: MotionEngineParams = MotionEngineParams(),
        zones: ZoneMap | None = None,
        ik: IKEngine | None = None,
        urdf: str = "mobile_manipulator.urdf",
        sensor_link: str = "lidar",
        on_stage: Callable[[str], Any] | None = None,
    ):
        self.kinematics = kinematics
        self.rng = rng
        self.params = params
        self.zones = zones if zones is not None else carrier_zones(kinematics, urdf)
        self.ik = ik if ik is not None else IKEngine(kinematics)
        self.cord_planner = CordPlanner(params.cord)
        self._shoulder_M = ArmGeometry.from_kinematics(kinematics).shoulder  # on joint 1's axis
        self.target = params.target
        self._T_E_F = self._aiming_frame(self.target.frame)
        q0 = np.zeros(kinematics.dof)
        self._sensor_link = sensor_link
        self._T_M_S = kinematics.transform(q0, sensor_link) if sensor_link in kinematics.links else None
        self._on_stage = on_stage or (lambda stage: None)
        self.reset()

    # ------------------------------------------------------------------ API
    def reset(self) -> None:
        """Forget the history, the graph and the trajectory (a new encounter)."""
        self.cord_planner.reset()
        self.cycle: PlanningCycle | None = None
        self.selection: Selection | None = None
        self.trajectory: JointTrajectory | None = None
        self.trajectory_start = 0.0
        self._scan: ObstacleScan | None = None
        self._last_B = self._last_O = -1
        self._previous: tuple[float, np.ndarray, np.ndarray] | None = None  # t, T_M_Q, T_M_E at the last selection
        self._p_vs: np.ndarray | None = None
        self._R_vs: np.ndarray | None = None
        self._L_p = self._V_tr = 0.0

    def set_target(self, **changes: Any) -> None:
        """Change fields of the PBVS target (``standoff``, ``aim_Q``, ``frame``, ``yaw_offset``)."""
        target = replace(self.target, **changes)
        self._T_E_F = self._aiming_frame(target.frame)
        self.target = target

    def scan_from_sensor(self, points_S: np.ndarray) -> ObstacleScan:
        """An :class:`ObstacleScan` in M from ``(n, 2)`` hits (m) in the sensor's frame (``LidarScan.points_sensor()``).

        The sensor link is fixed to the base, so its pose in M is constant.
        """
        points_S = np.asarray(points_S, dtype=float).reshape(-1, 2)
        T_M_S = self._sensor_M()
        points_M = points_S @ T_M_S[:2, :2].T + T_M_S[:2, 3]
        return ObstacleScan(points_M, T_M_S[:3, 3].copy())

    def pbvs(self, T_M_Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """P_VS of the UAV pose ``T_M_Q`` (4×4 or a position) with the present target: position (m), rotation."""
        return pbvs_target(_as_pose(T_M_Q), self._T_E_F, self.target)

    def joint_goal(self, p_M: np.ndarray, R_M_E: np.ndarray, q_near: np.ndarray) -> np.ndarray | None:
        """IK of the end-effector pose (``p_M`` m, ``R_M_E``) near ``q_near`` (rad); ``None`` if out of reach.

        The branch follows ``q_near`` in every joint but, with ``front_shoulder``, joint 1,
        which turns toward the pose's bearing.
        """
        p_M = np.asarray(p_M, dtype=float)
        solution = self.ik.solve(p_M[None], R_M_E, self._ik_reference(q_near, p_M))
        return solution.q[0] if solution.valid[0] else None

    @property
    def graph(self) -> Graph | None:
        """The graph of the last planning cycle."""
        return None if self.cycle is None else self.cycle.graph

    def update(
        self,
        t: float,
        q_arm: np.ndarray,
        T_M_Q: np.ndarray | None,
        ugv_speed: float = 0.0,
        uav_speed: float = 0.0,
        obstacles: ObstacleScan | np.ndarray | None = None,
    ) -> MotionCommand:
        """One call of the engine at simulated time ``t`` (s); call it at ≥ 2·f_O (every control tick).

        Args:
            q_arm: measured arm joint angles (rad).
            T_M_Q: the UAV pose P_Q^M (4×4, or a position [x, y, z]); ``None`` when not seen.
            ugv_speed, uav_speed: carrier and UAV speeds (m/s) for the cord's switching rule.
            obstacles: a new range scan for the local map (hits in M, or an :class:`ObstacleScan`);
                ``None`` keeps the previous one.

        Runs a selection when a new f_O period has begun, preceded by a
        planning cycle when a new f_B period has begun, and returns the
        running trajectory's set-point ``lead_time`` ahead of ``t``.
        """
        q_arm = np.asarray(q_arm, dtype=float)
        if obstacles is not None:
            self._scan = obstacles if isinstance(obstacles, ObstacleScan) else ObstacleScan(obstacles)
        planned = selected = False
        slot_O = math.floor(t * self.params.f_O + 1e-9)
        if T_M_Q is not None and slot_O != self._last_O:
            T_M_Q = _as_pose(T_M_Q)
            self._p_vs, self._R_vs = self.pbvs(T_M_Q)
            self.cord_planner.record(self._p_vs)  # OP
            slot_B = math.floor(t * self.params.f_B + 1e-9)
            if slot_B != self._last_B or self.cycle is None:
                self.plan(t, q_arm, ugv_speed, uav_speed)
                self._last_B, planned = slot_B, True
            self._select(t, q_arm, T_M_Q)
            self._last_O, selected = slot_O, True
        q, qd = self._setpoint(t + self.params.lead_time, q_arm)
        return MotionCommand(
            t,
            q,
            qd,
            q if self.trajectory is None else self.trajectory.q_goal.copy(),
            None if self._p_vs is None else self._p_vs.copy(),
            None if self.selection is None else self.selection.p_R_M.copy(),
            self._R_vs,
            T_M_Q is not None,
            planned,
            selected,
            self._L_p,
            self._V_tr,
        )

    def plan(self, t: float, q_arm: np.ndarray, ugv_speed: float, uav_speed: float) -> PlanningCycle:
        """One planning-and-optimisation cycle around the present P_VS (needs one UAV pose first)."""
        if self._p_vs is None or self._R_vs is None:
            raise RuntimeError("the motion engine plans around P_VS: pass a UAV pose to update() first")
        p, stage = self.params, self._on_stage
        cord = self.cord_planner.plan(self._p_vs, ugv_speed, uav_speed)
        stage("cord")
        vicinity = build_vicinity(cord, p.cord.L_S, p.vicinity)
        stage("vicinity")
        if self._scan is not None:
            self.zones.clear("obstacle")
            origin = self._scan.origin_M if self._scan.origin_M is not None else self._sensor_M()[:3, 3]
            self.zones.add_obstacle_columns(self._scan.points_M[:, :2], np.asarray(origin)[:2])
            self._scan = None
        stage("map")
        repair = repair_cord(cord, self.zones, thickening(vicinity, self.zones.params))
        if repair.cord is not cord:
            vicinity = build_vicinity(repair.cord, p.cord.L_S, p.vicinity)
        stage("repair")
        q_ref = self._ik_reference(q_arm, self._p_vs)
        check = validate_vicinity(vicinity, self.zones, self.rng, p.validation_samples, self.ik, self._R_vs, q_ref)
        stage("validation")
        graph = build_graph(vicinity, self.zones, self.ik, self._R_vs, self.rng, q_ref, self.graph, p.graph)
        stage("graph")
        self.cycle = PlanningCycle(t, repair.cord, repair, vicinity, check, graph)
        return self.cycle

    # ------------------------------------------------------------ internals
    def _sensor_M(self) -> np.ndarray:
        """T_M_S of the range sensor; an error names the missing link."""
        if self._T_M_S is None:
            raise ValueError(
                f"the arm model has no sensor link '{self._sensor_link}': pass ObstacleScan(points_M, origin_M)"
            )
        return self._T_M_S

    def _aiming_frame(self, frame: str) -> np.ndarray:
        """T_E_F: the aiming frame in the end-effector (IK) frame, constant along the arm's last link."""
        q0 = np.zeros(self.kinematics.dof)
        T_M_E = self.kinematics.transform(q0)
        return np.linalg.inv(T_M_E) @ self.kinematics.transform(q0, frame)

    def _ik_reference(self, q: np.ndarray, p_M: np.ndarray) -> np.ndarray:
        """The IK reference near ``q`` (rad): with ``front_shoulder``, joint 1 turned to the bearing of ``p_M``."""
        q_ref = np.array(q, dtype=float)
        if self.params.front_shoulder:
            q_ref[0] = math.atan2(p_M[1] - self._shoulder_M[1], p_M[0] - self._shoulder_M[0])
        return q_ref

    def _select(self, t: float, q_arm: np.ndarray, T_M_Q: np.ndarray) -> None:
        """Merge and selection: V_tr, L_p, P_R on the graph, IK, toppra trajectory."""
        assert self.cycle is not None and self._p_vs is not None and self._R_vs is not None
        p = self.params
        T_M_E = self.kinematics.transform(q_arm)
        if self._previous is not None and t > self._previous[0]:
            t0, T_Q0, T_E0 = self._previous
            self._V_tr = tracking_state(pose_rates(T_E0, T_M_E, t - t0), pose_rates(T_Q0, T_M_Q, t - t0), p.selection)
        self._previous = (t, T_M_Q, T_M_E)
        self._L_p = path_length(self._V_tr, p.selection)
        self.selection = select(self.cycle.graph, self._p_vs, self.cycle.cord.items, self._L_p)
        self._on_stage("selection")
        if self.selection is None:
            return  # nothing valid to go to: the running trajectory ends and holds
        # the new trajectory starts from the present set-point and replaces the running one; the command keeps
        # leading it by lead_time, so the new information acts at once (the sent set-point may step by the two
        # trajectories' difference over lead_time)
        q_start, qd_start = self._setpoint(t, q_arm)
        if np.max(np.abs(q_start - q_arm)) > p.resync:  # the arm was held back: restart from where it is
            q_start, qd_start = q_arm.copy(), np.zeros_like(q_arm)
        q_goal = self.joint_goal(self.selection.p_R_M, self._R_vs, q_start)
        if q_goal is None:
            q_goal = self.selection.q_R
        self.trajectory = plan_joint_trajectory(q_start, q_goal, qd_start, p.trajectory)
        self.trajectory_start = t
        self._on_stage("trajectory")

    def _setpoint(self, t: float, q_arm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The running trajectory's set-point at ``t`` (the measured angles, at rest, before the first one)."""
        if self.trajectory is None:
            return q_arm.copy(), np.zeros_like(q_arm)
        return self.trajectory.sample(t - self.trajectory_start)
