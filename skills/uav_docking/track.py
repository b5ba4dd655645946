"""UAV motion tracking (Narváez §IV-A, Figs. 4–5): the Motion Engine drives the arm from the measured UAV pose.

Every tick (Fig. 4):

1. the eye-in-hand frame is measured once for every skill that looks at it
   (:class:`~.observer.EyeInHandObserver`: AprilTag bundle → P_Q^{C_A} by
   solvePnP → P_Q^M by eq. (1) with F(q) from the joint encoders) and fused
   with the two robots' own estimates (:mod:`.relative_pose`: the carrier's
   onboard estimate, the UAV's over the team link): they carry the pose
   between frames and while the marker is hidden, each frame re-anchors
   it, outliers (a tag at the image border, a wrong planar-pose branch) are
   dropped;
2. the Motion Engine (:class:`~.engine.MotionEngine`: cord, vicinity, local
   map from the LiDAR, RRT* graph over the IK engine at f_B = 4 Hz; PBVS,
   V_tr, L_p and P_R at f_O = 8 Hz) turns the estimate, ``lead`` seconds
   ahead (the arm's lag) at the estimated velocity relative to M, into
   joint set-points for the arm's PIDs;
3. the UAV holds a reachable pose in the manipulator frame M — Part B at
   ``part_b_M``, facing ``yaw_M`` — by the relative-hold law of
   :mod:`.relative_hold` on the same estimate ("the UAV pose is being
   controlled within M coordinates", §IV-A), whatever the carrier does; the
   command is a body-frame velocity, a frame the UAV knows.

While tracking, the PBVS target P_VS puts the camera ``standoff`` straight
below the centre of the tag plate. The end effector keeps the heading
``ee_yaw_M`` in M (joint 6 in the middle of its range); with the UAV facing
the carrier's rear (``yaw_M`` = π) the camera, 4.5 cm in front of Part A
(O_C), then lies under the tag plate when Part A is under Part B, so the
bundle stays in view during most of the contact phase.

The contact phase (:mod:`.contact`, run beside this skill) writes a
:class:`ContactTarget` on the blackboard (``<carrier>/contact_target``):
Part A is then aimed at Part B from the standoff of eq. (15), the vicinity
narrows (``contact_vicinity``: the relative pose is held, the end effector
only rises) and the UAV's downward sonar cone enters the local map as a
prohibited zone. Without a contact target (none yet, or a cancelled
contact) the engine tracks with the camera target: after a cancellation the
end effector drops back to the tracking standoff, which brings the bundle
back into view (§IV-B).

Unintended contacts are counted by the run's referee (world side), not here.

Blackboard: writes ``<carrier>/tracking`` (:class:`TrackingState`, for the
contact phase) and the docking flag; reads ``<carrier>/contact_target``
(with ``contact``). Metrics (Fig. 20), all the skill's own ESTIMATES (the
referee logs the truth): ``part_a_M`` (forward kinematics of the encoders)
and ``part_b_M`` (label ``axis``, the estimated UAV pose while the marker
is seen), ``uav_M_estimate`` (label ``axis``: the estimated P_Q^M position,
every tick once measured), ``camera_offset``, ``docking_gap_estimate``.

Frames: manipulator frame M (``arm_base``), metres, radians, seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.api.capabilities import Rotorcraft
from marsupial.geometry import yaw_of_rotation
from marsupial.trees.metrics import MetricSpec
from marsupial.trees.phases import phase_event
from marsupial.trees.skill import NodeParams, Skill

from ..common.carrier_frame import CarrierFrame
from .engine import MotionEngine, MotionEngineParams
from .pose import invert
from .relative_hold import PART_A_LINK, HoldGains, command_hold, part_b_offset, relative_pose_of
from .relative_pose import RelativeState
from .selection import PbvsTarget, SelectionParams, rot_z
from .team import DOCKING_FLAG, CarrierName, carrier_port
from .vicinity import VicinityParams
from .zones import ZoneMap, carrier_zones

TRACKING = "tracking"
"""Blackboard key (under the carrier's name) of the :class:`TrackingState`."""
CONTACT_TARGET = "contact_target"
"""Blackboard key (under the carrier's name) of the :class:`ContactTarget`."""
CAMERA_FRAME = "eye_in_hand"  # the eye-in-hand optical frame C_A, aimed at the tag plate while tracking
SONAR_SEGMENTS = 8  # cylinders covering the sonar cone (each as wide as the cone at its lower end)


@dataclass(frozen=True)
class ContactTarget:
    """What the contact phase asks of the Motion Engine (§IV-B).

    Attributes:
        standoff: distance (m) from Part A's face up to Part B's along the
            vertical: P_RC of eq. (14) is P_R raised by eq. (15).
        sonar_cone: ``(half_angle rad, length m)`` of the UAV's downward range
            finder beam, a prohibited zone of the local map; ``None``: no zone.
    """

    standoff: float
    sonar_cone: tuple[float, float] | None = None


@dataclass(frozen=True)
class TrackingState:
    """How tracking goes, for the contact phase (blackboard ``<carrier>/tracking``).

    Attributes:
        t: simulated time (s) of this state.
        started: time (s) tracking began (the end of the initial encounter).
        seen: True when the bundle was measured in a frame at most ``max_age`` old.
        seen_at: time (s) of the last frame in which it was measured (−inf: never).
        T_M_Q: the estimated UAV pose in M (4×4, :class:`~.relative_pose.RelativePose`: the robots'
            estimates re-anchored by the measurements), ``None`` before any measurement.
        p_B_A: Part B's mating face in Part A's frame (m) from that pose and the arm's forward
            kinematics: ``[2]`` is the axial gap, ``hypot([0], [1])`` the lateral offset.
        hold_error: distance (m) of that UAV pose from its hold pose in M.
        camera_offset: distance (m) of the tag plate's centre from the camera's optical axis.
        v_M: the UAV's estimated velocity relative to frame M, in M's axes (m/s).
    """

    t: float
    started: float
    seen: bool
    seen_at: float
    T_M_Q: np.ndarray | None = field(default=None, repr=False)
    p_B_A: np.ndarray | None = None
    hold_error: float = math.inf
    camera_offset: float = math.inf
    v_M: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def age(self) -> float:
        """Seconds since the bundle was last measured."""
        return self.t - self.seen_at


def sonar_cone_zones(zones: ZoneMap, T_M_S: np.ndarray, half_angle: float, length: float, name: str = "sonar") -> None:
    """Add the cone of a downward range finder to ``zones`` as stacked cylinders (a conservative cover, §IV-B).

    ``T_M_S`` is the sensor in M (beam along its −z). The beam is cut into
    :data:`SONAR_SEGMENTS` slices, each covered by a cylinder as wide as the
    cone at the slice's far end.
    """
    axis = -T_M_S[:3, 2]
    R = np.column_stack((T_M_S[:3, 0], -T_M_S[:3, 1], axis))  # turned half a turn about x: z along the beam
    slice_length = length / SONAR_SEGMENTS
    for k in range(SONAR_SEGMENTS):
        centre = T_M_S[:3, 3] + axis * (k + 0.5) * slice_length
        radius = max((k + 1) * slice_length * math.tan(half_angle), 1e-3)
        zones.add_cylinder(f"{name}_{k}", centre, radius, slice_length / 2.0, R)


class Track(Skill["Track.Params"]):
    """Track the UAV with the arm's Motion Engine from the eye-in-hand camera while the UAV holds its pose in M."""

    metrics: ClassVar[tuple[MetricSpec, ...]] = (
        MetricSpec("part_a_M", "m", "Part A's position in M, per axis (arm's forward kinematics)"),
        MetricSpec("uav_M_estimate", "m", "the UAV's position in M, per axis, as the carrier estimates it"),
        MetricSpec("part_b_M", "m", "Part B's position in M, per axis, from the camera"),
        MetricSpec("camera_offset", "m", "distance of the tag plate's centre from the camera's axis", "mean_abs"),
        MetricSpec("docking_gap_estimate", "m", "distance from Part A to Part B as the camera estimates it"),
    )

    class Params(NodeParams):
        carrier: CarrierName = "carrier"
        """Team member carrying the arm and its eye-in-hand camera (a mobile_manipulator)."""
        standoff: float = Field(0.40, ge=0.2, le=1.2)
        """Camera-to-tag-plate distance (m) of the tracking target P_VS.

        Chosen: the bundle fills the view, all tags found at 320×240.
        """
        part_b_M: tuple[float, float, float] = (0.20, 0.0, 0.80)
        """Part B's position (m) in M held by the UAV.

        In front of the shoulder axis, within the arm's reach for contact (chosen).
        """
        yaw_M: float = math.pi
        """UAV heading in M (rad) held while docking.

        Facing the carrier's rear, so the camera sees the bundle during contact.
        """
        ee_yaw_M: float = 0.0
        """End-effector heading in M (rad) of the PBVS target (0: joint 6 mid-range at ``docking_ready``)."""
        hold_kp: float = Field(2.5, gt=0.0)
        """Position gain of the UAV's hold in M (1/s).

        Chosen: the stiffest without overshoot at 20 Hz, 3 cm RMS in 2 m/s gusts.
        """
        hold_speed: float = Field(1.0, gt=0.0, le=4.0)
        """Largest UAV speed relative to the carrier while it takes its hold pose (m/s)."""
        max_age: float = Field(0.2, gt=0.0)
        """Oldest measurement (s) the UAV's hold and the engine use; older: the marker counts as unseen."""
        lost_timeout: float | None = Field(10.0, gt=0.0)
        """Fail when the marker has not been seen for this long (s), counted from the end of a contact phase.

        None: never.
        """
        contact: bool = True
        """Read the contact phase's target (``<carrier>/contact_target``, written by ``contact``)."""
        K_Lp: float = Field(0.005, ge=0.0)
        """Constant K_Lp of eq. (12) (m/s), L_p = K_Lp·L_C / V_tr.

        Small, the UAV holds still in M (the paper gives no value).
        """
        contact_vicinity: tuple[float, float] = (0.01, 0.02)
        """Gains (K_a 1/m, K_b) of the vicinity (eq. 7) during contact.

        The relative pose is held, the end effector only rises.
        """
        lead: float = Field(0.15, ge=0.0)
        """The engine plans on the UAV pose this far ahead (s), from its estimated velocity relative to M.

        This covers the arm's lag.
        """
        fusion_gain: float = Field(0.8, gt=0.0, le=1.0)
        """Weight of each eye-in-hand measurement in the UAV pose estimate.

        See :class:`~.relative_pose.RelativePoseFilter`. The camera is precise to millimetres at tracking range, the
        UAV's odometry over the carrier is not: 2.3 cm RMS of P_Q^M against truth at 0.8 in a 25 s encounter, 6.3 cm
        at 0.3.
        """
        fusion_gate: float = Field(0.03, gt=0.0)
        """Measurements farther than this (m) from the predicted pose are outliers.

        See :class:`~.relative_pose.RelativePoseFilter`.
        """
        vision_fixes: bool = True
        """Send each accepted camera frame to the UAV's estimator as an external vision fix.

        Its height and velocity are then anchored to the camera, not to sonar echoes off the arm.
        """
        f_B: float = Field(4.0, gt=0.0)
        """Planning-and-optimisation rate f_B (Hz), §IV-A; merge and selection run at f_O = 2·f_B."""

    robot_kinds = (Rotorcraft,)
    sensors = ("sonar", "{carrier}/eye_in_hand", "{carrier}/lidar")
    claims = ("rotors", "{carrier}/arm")
    runs_on = "carrier"  # Narváez §V-B-2: computed on the carrier, sent to the UAV over Wi-Fi
    writes = (f"{{carrier}}/{TRACKING}", f"{{carrier}}/{DOCKING_FLAG}")

    @classmethod
    def read_keys(cls, params: Track.Params, robot: str | None) -> tuple[str, ...]:
        """The contact target, when the skill follows a contact phase."""
        return (f"{params.carrier}/{CONTACT_TARGET}",) if params.contact else ()

    # ------------------------------------------------------------ life cycle
    def start(self) -> None:
        p = self.params
        self.carrier = carrier_port(self, p.carrier)
        kinematics = self.carrier.arm_kinematics
        self.kinematics = kinematics
        self.relative = relative_pose_of(self, self.carrier, p.fusion_gain, p.fusion_gate, vision_fixes=p.vision_fixes)
        self.lidar = self.carrier.sensor("lidar")
        self.tracking_zones = carrier_zones(kinematics, "mobile_manipulator.urdf")
        self.tracking_vicinity = VicinityParams()
        self.engine = MotionEngine(
            kinematics,
            self.context.rng(f"{p.carrier}/motion_engine"),
            MotionEngineParams(
                f_B=p.f_B,
                selection=SelectionParams(K_Lp=p.K_Lp),
                target=PbvsTarget(standoff=p.standoff, frame=CAMERA_FRAME),
            ),
            zones=self.tracking_zones,
        )
        self.p_B_Q = part_b_offset(self.robot)
        R_M_Q = rot_z(p.yaw_M)
        self.p_hold_M = np.asarray(p.part_b_M, dtype=float) - R_M_Q @ self.p_B_Q
        self.T_Q_B = np.eye(4)
        self.T_Q_B[:3, 3] = self.p_B_Q
        self.gains = HoldGains(p.hold_kp, p.hold_speed)
        self.T_M_Q: np.ndarray | None = None  # the estimated UAV pose in M, once a frame anchored it
        self.started = self.now
        self.contact: ContactTarget | None = None
        self.contact_until = -math.inf  # last tick of a contact phase (the marker may be too close to see)
        self.sonar_T_Q = self._sonar_in_uav()
        self.write(f"{p.carrier}/{DOCKING_FLAG}", True)
        phase_event(self, "tracking", part_b_M=list(p.part_b_M), standoff=p.standoff)

    def step(self) -> Status:
        p = self.params
        now = self.now
        relative = self.relative.update(now)
        self.T_M_Q = relative.T_M_Q if relative.measured else None
        seen = now - relative.seen_at <= p.max_age + 1e-9
        lost_for = now - max(relative.seen_at, self.started, self.contact_until)  # blind in contact: counts after it
        if p.lost_timeout is not None and self.contact is None and lost_for > p.lost_timeout:
            self.feedback_message = f"marker unseen for {p.lost_timeout:.0f} s: tracking lost"
            return Status.FAILURE
        self._apply_contact(self.read(f"{p.carrier}/{CONTACT_TARGET}") if p.contact else None)
        if self.contact is not None:
            self.contact_until = now
        state = TrackingState(now, self.started, seen, relative.seen_at)
        if self.T_M_Q is None:
            self.carrier.hold_arm()
        else:
            q = self.carrier.joint_positions()
            scan = self.lidar.read()
            obstacles = None if scan is None else self.engine.scan_from_sensor(scan.data.points_sensor())
            T_M_Q_ahead = self.T_M_Q.copy()  # where the UAV will be when the arm gets there (estimated velocity in M)
            T_M_Q_ahead[:3, 3] += p.lead * relative.v_M
            command = self.engine.update(now, q, T_M_Q_ahead, self.carrier.speed(), relative.uav_speed, obstacles)
            self.carrier.set_joint_targets(command.q)
            state = self._state(now, q, seen, relative.seen_at, relative.v_M)
            self._log(q, state)
        self._hold_uav(relative)
        self.write(f"{p.carrier}/{TRACKING}", state)
        what = "contact" if self.contact is not None else "tracking"
        marker = "seen" if state.seen else f"unseen for {state.age():.1f} s"
        self.feedback_message = f"{what}: marker {marker}, UAV {state.hold_error:.3f} m from its hold pose"
        return Status.RUNNING

    def finish(self, status: Status) -> None:
        docked = self.carrier.docking.locked and self.robot.docked
        if not docked:  # docked: the flag stays up until the UAV is stored
            self.write(f"{self.params.carrier}/{DOCKING_FLAG}", False)
            self.carrier.hold_arm()
        self.leave_safe()

    # ------------------------------------------------------------- pieces
    def _sonar_in_uav(self) -> np.ndarray:
        """T_Q_S of the UAV's downward range finder (its mount offset; beam along −z)."""
        T = np.eye(4)
        sonar = self.robot.sensor("sonar")
        T[:3, 3] = sonar.offset
        return T

    def _apply_contact(self, target: ContactTarget | None) -> None:
        """Aim the engine for the contact phase (Part A at Part B, sonar cone mapped) or for tracking."""
        p, engine = self.params, self.engine
        changes: dict = {}
        if target is None and self.contact is not None:  # cancelled: back to the camera target, lower down
            engine.zones = self.tracking_zones
            engine.params = replace(engine.params, vicinity=self.tracking_vicinity)
            changes.update(standoff=p.standoff, frame=CAMERA_FRAME, aim_Q=PbvsTarget().aim_Q)
            phase_event(self, "tracking", standoff=p.standoff)
        elif target is not None:
            if self.contact is None or self.contact.sonar_cone != target.sonar_cone:
                engine.zones = self._contact_zones(target)
            if self.contact is None:
                engine.params = replace(engine.params, vicinity=VicinityParams(*p.contact_vicinity))
                changes.update(frame=PART_A_LINK, aim_Q=tuple(self.p_B_Q))
            changes["standoff"] = max(target.standoff, 0.0)
        self.contact = target
        if self.T_M_Q is not None:  # the end effector keeps its heading in M whatever the UAV's
            changes["yaw_offset"] = p.ee_yaw_M - yaw_of_rotation(self.T_M_Q[:3, :3])
        if changes:
            engine.set_target(**changes)

    def _contact_zones(self, target: ContactTarget) -> ZoneMap:
        """The carrier's zones plus, if asked, the sonar cone of the UAV at its last measured pose in M."""
        zones = carrier_zones(self.kinematics, "mobile_manipulator.urdf")
        if target.sonar_cone is not None and self.T_M_Q is not None:
            half_angle, length = target.sonar_cone
            sonar_cone_zones(zones, self.T_M_Q @ self.sonar_T_Q, half_angle, length)
        return zones

    def _state(self, now: float, q: np.ndarray, seen: bool, seen_at: float, v_M: np.ndarray) -> TrackingState:
        """The tracking state from the last UAV pose (set) and the arm's forward kinematics."""
        T_M_Q = self.T_M_Q
        assert T_M_Q is not None, "called once a frame anchored the UAV pose"
        T_M_A = self.kinematics.transform(q, PART_A_LINK)
        p_B_A = (invert(T_M_A) @ T_M_Q @ self.T_Q_B)[:3, 3]
        T_M_C = self.kinematics.transform(q, CAMERA_FRAME)
        p_aim_C = (invert(T_M_C) @ T_M_Q @ np.append(PbvsTarget().aim_Q, 1.0))[:3]
        hold_error = float(np.linalg.norm(T_M_Q[:3, 3] - self.p_hold_M))
        offset = float(math.hypot(p_aim_C[0], p_aim_C[1]))
        return TrackingState(now, self.started, seen, seen_at, T_M_Q, p_B_A, hold_error, offset, v_M)

    def _hold_uav(self, relative: RelativeState) -> None:
        """Relative hold of the UAV at its pose in M on the estimate (the estimates alone before any frame)."""
        command_hold(self.robot, relative, self.p_hold_M, self.params.yaw_M, CarrierFrame.of(self.carrier), self.gains)

    def _log(self, q: np.ndarray, state: TrackingState) -> None:
        """Metrics of Fig. 20: Part A and (when measured) Part B in M, the camera's centring, the gap."""
        robot, T_M_Q = self.robot_name, state.T_M_Q
        assert T_M_Q is not None and state.p_B_A is not None, "logged for a state with a UAV pose"
        p_A_M = self.kinematics.forward(q, PART_A_LINK)[0]
        p_B_M = (T_M_Q @ self.T_Q_B)[:3, 3]
        for k, axis in enumerate("xyz"):
            self.context.metric("part_a_M", float(p_A_M[k]), robot=robot, axis=axis)
            self.context.metric("uav_M_estimate", float(T_M_Q[k, 3]), robot=robot, axis=axis)
            if state.seen:
                self.context.metric("part_b_M", float(p_B_M[k]), robot=robot, axis=axis)
        if state.seen:
            self.context.metric("camera_offset", state.camera_offset, robot=robot)
        self.context.metric("docking_gap_estimate", float(np.linalg.norm(state.p_B_A)), robot=robot)
