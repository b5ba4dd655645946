"""Mobile Manipulation System (MMS) carrying Tello micro-scouts, after Arora & Papachristos.

"Mobile Manipulation-based Deployment of Micro Aerial Robot Scouts through
Constricted Aperture-like Ingress Points" (§III-B): a differential-drive
4-wheeled base with a 6-DoF arm, a parallel gripper and an eye-in-hand
camera; Tello MAVs "mounted on launching apparatuses positioned into
holster-like attachments on the main robot body", retrieved with the arm
and gripper, one on the left and one on the right of the body (§V). The
apparatus is "grasped by the gripper at one end with a supporting structure
at the other end which firmly holds the MAV in place, and at the same time
allows it to take off without significant friction"; its length is d_l
(Phase I, §IV-F).

The paper gives no dimensions or speeds; ``mms.urdf`` documents the
geometry chosen (Husky-class base, ≈0.92 m reach spherical-wrist arm).
Joint speed limit 0.8 rad/s (≈46°/s, in the URDF): below the ≈70-80°/s
actuator limits of comparable light 6-DoF arms, for the careful "slipping"
of a MAV through an aperture with centimetre clearances.

Holding, in the simulation:

* The holster latches its apparatus so that it stays put while the MMS
  drives; a successful :meth:`MMS.grasp` unlatches it. A latched apparatus
  and its MAV move rigidly with the holster (their poses and velocities are
  set from the MMS base after every physics step) and do not touch it.
* The apparatus "firmly holds the MAV": :meth:`LaunchingApparatus.secure_mav`
  welds the Tello to the cradle and tells it it is docked (``on_docked``:
  motors off). :meth:`LaunchingApparatus.release_mav` removes the weld just
  before take-off (``on_released``); the Tello then rests on the tray
  between 8 mm lips until its motors lift it off.
* The gripper: :meth:`MMS.close_gripper` closes the fingers with a limited
  force; while they are commanded closed, :meth:`MMS.grasp` is tried on each
  apparatus after every physics step: it welds the apparatus to the gripper
  at their relative pose once both fingers touch the handle and the finger
  gap matches the handle width within :data:`GRASP_GAP_TOLERANCE_M` (the
  friction grip of the real fingers). :meth:`MMS.open_gripper` removes the
  weld and opens the fingers (:meth:`MMS.release`); an apparatus let go with
  its handle within :data:`STOW_TOLERANCE_M` and :data:`STOW_TOLERANCE_RAD`
  of an empty holster's frame is latched there again (stowed).
* The launch: :meth:`MMS.release_scout` opens the held apparatus's hold on
  its MAV (:meth:`LaunchingApparatus.release_mav`), the "appropriately timed
  command" of §IV-F after which the MAV takes off from the cradle.

Held pairs do not collide with each other. Stowed MAVs cost almost nothing
per physics step this way: a resting compound-on-compound contact or a
fixed constraint each costs the solver tens of microseconds per step.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pybullet

from marsupial.api.assets import asset_path
from marsupial.api.errors import UnknownNameError
from marsupial.api.kinematics import ArmKinematics
from marsupial.api.model import DiffDriveLimits, Intrinsics
from marsupial.api.views import ManipulatorView
from marsupial.geometry import Vector, quaternion_from_matrix, rotation_matrix, transform

from ..estimation.ground import SKID_STEER_ODOMETRY
from ..sensors.base import SensorConfig
from ..sensors.camera import OPTICAL_FORWARD, Camera
from .arm import ArmController
from .attachment import set_collisions, weld
from .base import Robot, yaw_of
from .encoders import JointEncoders
from .wheeled import WheeledRobot

if TYPE_CHECKING:
    from ..world import World

ARM_LINKS = tuple(f"arm_link_{i}" for i in range(1, 7))
FINGER_LINKS = ("finger_left", "finger_right")
HOLSTERS = ("holster_left", "holster_right")  # §V: one MAV on the left, one on the right
FINGER_FORCE_N = 20.0  # grip force of each finger (N)
FINGER_SPEED_MPS = 0.05  # finger closing speed (m/s)
GRASP_GAP_TOLERANCE_M = 0.003  # finger gap vs handle width accepted as "closed around the handle"
WELD_FORCE_N = 500.0  # strength of the gripper–apparatus and apparatus–MAV welds (N)
STOW_TOLERANCE_M = 0.015  # handle centre from an empty holster's frame, at which a let-go apparatus latches (m)
STOW_TOLERANCE_RAD = 0.15  # handle attitude from the holster frame's, at which it latches (rad)

MMS_LIMITS = DiffDriveLimits(max_speed=1.0, max_omega=1.0, max_accel=0.5, max_alpha=1.0)
"""Husky-class base; the paper gives no speeds."""

CAMERA_INTRINSICS = Intrinsics(320, 240, 58.0, near=0.1, far=10.0)
"""Eye-in-hand RGB-D camera (the paper names none): a RealSense-class 58° vertical field
of view and 0.1 m minimum depth, at 320×240 to keep rendering cheap."""
CAMERA_CONFIG = SensorConfig(rate_hz=15.0, noise_std=2.0, latency_s=0.05)  # RGB noise 0-255; latency chosen
CAMERA_DEPTH_NOISE_PER_M = 0.002  # depth noise std per metre of depth (≈0.2 %)

ARM_READY = (0.0, -0.3, 2.2, 0.0, 1.2, 0.0)
"""Arm joint angles (rad) of the folded pose the MMS starts in, above the front of the deck."""


def _point_velocity(
    v: Vector, w: Vector, c: Vector, p: Vector
) -> tuple[float, float, float]:
    """Velocity (m/s) of point ``p`` of a rigid body whose point ``c`` moves at ``v`` and which turns at ``w``."""
    rx, ry, rz = p[0] - c[0], p[1] - c[1], p[2] - c[2]
    return (v[0] + w[1] * rz - w[2] * ry, v[1] + w[2] * rx - w[0] * rz, v[2] + w[0] * ry - w[1] * rx)


class LaunchingApparatus:
    """The launching apparatus (``launching_apparatus.urdf``): a handle, a boom and a cradle for one MAV.

    Frames: ``handle`` (base link; centre of the handle, x toward the cradle),
    ``cradle``, ``mav_seat`` (centre of the tray's top surface, x = the MAV's heading).

    States: *latched* in a holster fixed to a carrier's base (it and its
    secured MAV move rigidly with the base: the carrier calls :meth:`follow`
    after every physics step) or free (held by a gripper or lying somewhere;
    a secured MAV is then welded to the cradle).

    Attributes:
        name: e.g. ``"mms_apparatus_left"``.
        body_id: its pybullet body.
        handle_size: ``(length, width, height)`` of the handle (m), from the URDF;
            the gripper closes across its width.
        length: d_l, handle centre to MAV seat (m), §IV-F.
        mav: the MAV it carries (``None`` when empty).
    """

    def __init__(self, world: World, name: str, position: Vector, orientation: Vector):
        self.world = world
        self.name = name
        self.cid = world.client_id
        self.body_id = pybullet.loadURDF(
            str(asset_path("launching_apparatus.urdf")),
            basePosition=list(position),
            baseOrientation=list(orientation),
            flags=pybullet.URDF_USE_INERTIA_FROM_FILE,
            physicsClientId=self.cid,
        )
        self.links = {"handle": -1}
        for j in range(pybullet.getNumJoints(self.body_id, physicsClientId=self.cid)):
            info = pybullet.getJointInfo(self.body_id, j, physicsClientId=self.cid)
            self.links[info[12].decode()] = j
        self._collision_links = (-1, self.links["cradle"])
        (handle,) = pybullet.getCollisionShapeData(self.body_id, -1, physicsClientId=self.cid)
        self.handle_size: tuple[float, float, float] = tuple(float(d) for d in handle[3])  # type: ignore[assignment]
        self.length = float(np.linalg.norm(self.seat_pose()[0] - self.handle_pose()[0]))
        self.mav: Robot | None = None
        self._holster: tuple[int, int, Any, Any] | None = None  # carrier, link, handle pose in the carrier base
        self._mav_in_handle: tuple[Any, Any] | None = None  # MAV base pose in the handle frame while secured
        self._mav_weld: int | None = None

    # ----------------------------------------------------------------- poses
    def handle_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """World pose of the handle frame (position m, quaternion ``[x, y, z, w]``)."""
        p, q = pybullet.getBasePositionAndOrientation(self.body_id, physicsClientId=self.cid)
        return np.array(p), np.array(q)

    def seat_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """World pose of the MAV seat (centre of the tray's top surface, x = the MAV's heading)."""
        state = pybullet.getLinkState(
            self.body_id, self.links["mav_seat"], computeForwardKinematics=True, physicsClientId=self.cid
        )
        return np.array(state[4]), np.array(state[5])

    # --------------------------------------------------------------- holster
    @property
    def latched(self) -> bool:
        """True while latched in a holster."""
        return self._holster is not None

    @property
    def holster_link(self) -> int | None:
        """The link index of the holster it is latched in, ``None`` while free."""
        return None if self._holster is None else self._holster[1]

    def latch(self, body: int, link: int) -> None:
        """Latch the apparatus where it is to ``link`` of ``body``: a holster fixed to that body's base.

        The apparatus does not touch the holster or the base while latched.
        """
        self.unlatch()
        set_collisions(self.body_id, self._collision_links, body, (link, -1), False, self.cid)
        p_base, q_base = pybullet.getBasePositionAndOrientation(body, physicsClientId=self.cid)
        p_inv, q_inv = pybullet.invertTransform(p_base, q_base)
        p_handle, q_handle = pybullet.getBasePositionAndOrientation(self.body_id, physicsClientId=self.cid)
        self._holster = (body, link, *pybullet.multiplyTransforms(p_inv, q_inv, p_handle, q_handle))
        if self._mav_weld is not None:  # the holster carries the MAV from now on
            pybullet.removeConstraint(self._mav_weld, physicsClientId=self.cid)
            self._mav_weld = None

    def unlatch(self) -> None:
        """Free the apparatus from its holster (contacts restored; a secured MAV is welded to the cradle)."""
        if self._holster is None:
            return
        body, link, _, _ = self._holster
        self._holster = None
        set_collisions(self.body_id, self._collision_links, body, (link, -1), True, self.cid)
        if self._mav_in_handle is not None and self.mav is not None:
            self._mav_weld = weld(self.body_id, self.links["cradle"], self.mav.body_id, -1, WELD_FORCE_N, self.cid)

    def move_to(self, p_handle: Vector, q_handle: Vector) -> None:
        """Put the handle frame at the world pose ``p_handle`` (m), ``q_handle`` ([x, y, z, w]), a secured MAV too."""
        cid = self.cid
        pybullet.resetBasePositionAndOrientation(self.body_id, p_handle, q_handle, physicsClientId=cid)
        if self._mav_in_handle is not None and self.mav is not None:
            p_mav, q_mav = pybullet.multiplyTransforms(p_handle, q_handle, *self._mav_in_handle)
            pybullet.resetBasePositionAndOrientation(self.mav.body_id, p_mav, q_mav, physicsClientId=cid)

    def follow(
        self, p_base: Vector, q_base: Vector, v_base: Vector, w_base: Vector
    ) -> None:
        """Move a latched apparatus and its secured MAV rigidly with the carrier's base.

        ``p_base``, ``q_base``: the base's centre-of-mass pose; ``v_base``,
        ``w_base``: its linear and angular velocity (world frame), after the physics step.
        """
        if self._holster is None:
            return
        cid = self.cid
        _, _, p_rel, q_rel = self._holster
        p_handle, q_handle = pybullet.multiplyTransforms(p_base, q_base, p_rel, q_rel)
        v_handle = _point_velocity(v_base, w_base, p_base, p_handle)
        pybullet.resetBasePositionAndOrientation(self.body_id, p_handle, q_handle, physicsClientId=cid)
        pybullet.resetBaseVelocity(self.body_id, v_handle, w_base, physicsClientId=cid)
        if self._mav_in_handle is not None and self.mav is not None:
            p_mav, q_mav = pybullet.multiplyTransforms(p_handle, q_handle, *self._mav_in_handle)
            v_mav = _point_velocity(v_base, w_base, p_base, p_mav)
            pybullet.resetBasePositionAndOrientation(self.mav.body_id, p_mav, q_mav, physicsClientId=cid)
            pybullet.resetBaseVelocity(self.mav.body_id, v_mav, w_base, physicsClientId=cid)

    # ------------------------------------------------------------------- MAV
    @property
    def mav_secured(self) -> bool:
        """True while the MAV is held firmly in the cradle."""
        return self._mav_in_handle is not None

    def load_mav(self, mav: Robot) -> None:
        """Seat ``mav`` (a quadrotor standing at its ``spec.landed_height``) on the tray and secure it."""
        p_seat, q_seat = self.seat_pose()
        p_mav = p_seat + np.array([0.0, 0.0, mav.spec.landed_height])  # type: ignore[attr-defined]
        pybullet.resetBasePositionAndOrientation(mav.body_id, p_mav, q_seat, physicsClientId=self.cid)
        pybullet.resetBaseVelocity(mav.body_id, (0, 0, 0), (0, 0, 0), physicsClientId=self.cid)
        mav.restart_estimate()  # set-up: the MAV starts the run in the cradle
        self.mav = mav
        self.secure_mav()

    def secure_mav(self) -> None:
        """Hold the MAV firmly where it is in the cradle (it is told it is docked: motors off)."""
        if self.mav is None or self._mav_in_handle is not None:
            return
        cid = self.cid
        set_collisions(self.body_id, self._collision_links, self.mav.body_id, (-1,), False, cid)
        p_handle, q_handle = pybullet.getBasePositionAndOrientation(self.body_id, physicsClientId=cid)
        p_mav, q_mav = pybullet.getBasePositionAndOrientation(self.mav.body_id, physicsClientId=cid)
        p_inv, q_inv = pybullet.invertTransform(p_handle, q_handle)
        self._mav_in_handle = pybullet.multiplyTransforms(p_inv, q_inv, p_mav, q_mav)
        if self._holster is None:
            self._mav_weld = weld(self.body_id, self.links["cradle"], self.mav.body_id, -1, WELD_FORCE_N, cid)
        self.mav.on_docked(charger=False)  # type: ignore[attr-defined]

    def release_mav(self) -> Robot | None:
        """Let the MAV go (just before take-off); it stays the apparatus's :attr:`mav`. Returns it."""
        if self._mav_in_handle is None or self.mav is None:
            return self.mav
        self._mav_in_handle = None
        if self._mav_weld is not None:
            pybullet.removeConstraint(self._mav_weld, physicsClientId=self.cid)
            self._mav_weld = None
        set_collisions(self.body_id, self._collision_links, self.mav.body_id, (-1,), True, self.cid)
        self.mav.on_released()  # type: ignore[attr-defined]
        return self.mav


@dataclass(frozen=True)
class Holster:
    """One holster of the MMS: its link and the apparatus and MAV it was loaded with."""

    name: str
    link: int
    apparatus: LaunchingApparatus
    mav: Robot | None


class MMS(WheeledRobot):
    """Mobile manipulator carrying launching apparatuses with Tello MAVs in two holsters.

    Links: ``base_link``, ``base_footprint``, ``holster_left``, ``holster_right``,
    ``arm_base_link``, ``arm_link_1`` … ``arm_link_6`` (joints ``arm_joint_1`` … ``arm_joint_6``),
    ``gripper_base``, ``finger_left``, ``finger_right`` (prismatic, 0 … 0.04 m each),
    ``tcp`` (between the finger tips; z = approach axis, y = closing axis), ``camera_link``.

    Sensors: ``camera`` (eye-in-hand RGB-D on ``camera_link``, looking along the tcp's z).

    Args:
        pose: footprint pose ``[x, y]``, ``[x, y, yaw]`` or ``[x, y, z, yaw]`` (world frame, m, rad).
        limits: drive limits replacing :data:`MMS_LIMITS`, whole or by field.
        mavs: spawn a ``tello`` in each apparatus (named ``<name>_tello_0`` left, ``<name>_tello_1`` right).
        arm_q: initial arm joint angles (rad); :data:`ARM_READY` by default.
        camera: :class:`SensorConfig` overrides of the camera.

    Attributes:
        arm: the :class:`ArmController` of the six arm joints.
        arm_kinematics: pinocchio model of the chain ``arm_base_link`` → ``tcp`` (same URDF; ``camera_link`` too).
        holsters: ``{"holster_left": Holster, "holster_right": Holster}``.
        held: the apparatus welded to the gripper, or ``None``.
    """

    kind = "mms"
    view_class = ManipulatorView
    urdf = "mms.urdf"
    default_limits = MMS_LIMITS

    odometry_errors = SKID_STEER_ODOMETRY

    def __init__(
        self,
        world: World,
        name: str,
        pose: Vector = (0.0, 0.0, 0.0),
        limits: DiffDriveLimits | Mapping[str, float] | None = None,
        localization: str = "odometry",
        mavs: bool = True,
        arm_q: Vector = ARM_READY,
        camera: Mapping[str, Any] | None = None,
    ):
        super().__init__(world, name, pose=pose, limits=limits, localization=localization)
        cid, body = self.cid, self.body_id
        joints = [self.link_index(link) for link in ARM_LINKS]  # a link's index is its parent joint's
        infos = [pybullet.getJointInfo(body, j, physicsClientId=cid) for j in joints]
        self.arm = ArmController(
            world,
            body,
            joints,
            limits=[(info[8], info[9]) for info in infos],
            max_speed=min(info[11] for info in infos),
            max_torque=[info[10] for info in infos],
        )
        self.arm.reset(arm_q)
        self.arm_kinematics = ArmKinematics.from_urdf(self.urdf, "arm_base_link", "tcp")  # same URDF as the body
        self.encoders = JointEncoders(world, f"{name}/arm")
        self.fingers = [self.link_index(link) for link in FINGER_LINKS]
        self.finger_travel = float(pybullet.getJointInfo(body, self.fingers[0], physicsClientId=cid)[9])
        self.gripper_link = self.link_index("gripper_base")
        self.tcp_link = self.link_index("tcp")
        for finger in self.fingers:
            pybullet.resetJointState(body, finger, self.finger_travel, physicsClientId=cid)
        self.held: LaunchingApparatus | None = None
        self._grip_weld: int | None = None
        self._closing = False
        self.open_gripper()
        self.holsters: dict[str, Holster] = {}
        for i, holster in enumerate(HOLSTERS):
            link = self.link_index(holster)
            p, q = self.link_pose(link)
            side = holster.removeprefix("holster_")
            apparatus = LaunchingApparatus(world, f"{name}_apparatus_{side}", p, q)
            apparatus.latch(body, link)
            mav = None
            if mavs:
                p_seat, q_seat = apparatus.seat_pose()
                mav = world.add_robot(
                    "tello",
                    name=f"{name}_tello_{i}",
                    pose=[p_seat[0], p_seat[1], p_seat[2] + 0.05, yaw_of(q_seat)],
                    motors_on=False,
                )
                apparatus.load_mav(mav)
            self.holsters[holster] = Holster(holster, link, apparatus, mav)
        self.camera = self.add_sensor(
            Camera(
                self,
                "camera",
                CAMERA_INTRINSICS,
                CAMERA_CONFIG.with_overrides(camera),
                link="camera_link",
                R_link_optical=OPTICAL_FORWARD,
                depth_noise_per_m=CAMERA_DEPTH_NOISE_PER_M,
            )
        )

    # ----------------------------------------------------------------- arm
    def set_joint_targets(self, q: Vector) -> None:
        """Move the arm toward joint angles ``q`` (6 values, rad; clipped into the joint limits)."""
        self.arm.set_targets(q)
    def hold_arm(self) -> None:
        """Hold the arm joints where they are now (the joint controllers latch their own positions)."""
        self.arm.hold()

    def arm_positions(self) -> np.ndarray:
        """Arm joint angles now (rad), ``arm_joint_1`` … ``arm_joint_6``."""
        return self.arm.positions()
    def arm_encoders(self) -> np.ndarray:
        """Arm joint angles as the joint encoders read them (rad; 12-bit encoders, :mod:`.encoders`)."""
        return self.encoders.read(self.arm.positions())

    def tcp_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """World pose of the tool centre point (between the finger tips)."""
        return self.link_pose(self.tcp_link)

    # ------------------------------------------------------------- gripper
    def _command_fingers(self, opening: float) -> None:
        for finger in self.fingers:
            pybullet.setJointMotorControl2(
                self.body_id, finger, pybullet.POSITION_CONTROL, targetPosition=opening,
                force=FINGER_FORCE_N, maxVelocity=FINGER_SPEED_MPS, physicsClientId=self.cid,
            )

    def open_gripper(self) -> None:
        """Open both fingers fully (gap 2 × 0.04 m), letting go of a held apparatus (:meth:`release`)."""
        self.release()

    def close_gripper(self) -> None:
        """Close both fingers with :data:`FINGER_FORCE_N` each; they stop on whatever is between them.

        An apparatus whose handle they close around is held from then on (:meth:`grasp`, tried every step).
        """
        self._closing = True
        self._command_fingers(0.0)
    def gripper_opening(self) -> float:
        """Gap between the finger pads (m)."""
        states = pybullet.getJointStates(self.body_id, self.fingers, physicsClientId=self.cid)
        return float(states[0][0] + states[1][0])

    def grasp(self, apparatus: LaunchingApparatus) -> bool:
        """Weld ``apparatus`` to the gripper if the fingers are closed around its handle.

        Closed around the handle: both fingers touch the handle and the gap
        between them is the handle width within :data:`GRASP_GAP_TOLERANCE_M`.
        Returns whether the apparatus is now held.
        """
        if self.held is apparatus:
            return True
        if self.held is not None:
            raise ValueError(f"{self.name} already holds {self.held.name}; release() it first")
        touching = all(
            pybullet.getContactPoints(self.body_id, apparatus.body_id, finger, -1, physicsClientId=self.cid)
            for finger in self.fingers
        )
        gap_ok = abs(self.gripper_opening() - apparatus.handle_size[1]) <= GRASP_GAP_TOLERANCE_M
        if not (touching and gap_ok):
            return False
        apparatus.unlatch()
        apparatus.move_to(*self._squared_in_jaws(apparatus))
        self._grip_weld = weld(self.body_id, self.gripper_link, apparatus.body_id, -1, WELD_FORCE_N, self.cid)
        self.held = apparatus
        return True

    def _squared_in_jaws(self, apparatus: LaunchingApparatus) -> tuple[np.ndarray, np.ndarray]:
        """The world pose (m, quaternion) the handle takes as the parallel jaws close on it, freed from its holster.

        The flat jaws square the handle's width (its y) along the closing axis (the tcp's y), removing its turn
        about the other two axes, and the coupled fingers centre it between them; its offset along and across
        the jaws and its turn about the closing axis stay as they were at contact (nothing in the jaws fixes
        them). Without this the weld would keep whatever the fingers met: measured up to 0.8° of yaw and
        4 mm off-centre, a centimetre at the MAV 0.3 m away, the whole clearance of a tight aperture.
        """
        p_tcp, q_tcp = self.tcp_pose()
        p_handle, q_handle = apparatus.handle_pose()
        T_tcp = transform(p_tcp, rotation_matrix(q_tcp))
        T_handle = transform(p_handle, rotation_matrix(q_handle))
        T_rel = np.linalg.inv(T_tcp) @ T_handle  # the handle in the tcp frame
        width = T_rel[:3, 1]
        closing = np.array([0.0, math.copysign(1.0, width[1]), 0.0])
        axis = np.cross(width, closing)
        angle = math.atan2(float(np.linalg.norm(axis)), float(width @ closing))
        if np.linalg.norm(axis) > 1e-12:
            k = axis / np.linalg.norm(axis)
            K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
            T_rel[:3, :3] = (np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * K @ K) @ T_rel[:3, :3]
        T_rel[1, 3] = 0.0  # centred between the fingers
        T_new = T_tcp @ T_rel
        return T_new[:3, 3], quaternion_from_matrix(T_new[:3, :3])
    def release(self) -> LaunchingApparatus | None:
        """Let go of the held apparatus and open the fingers; returns what was held.

        An apparatus let go at an empty holster (:meth:`_stow`) is latched there.
        """
        held = self.held
        if self._grip_weld is not None:
            pybullet.removeConstraint(self._grip_weld, physicsClientId=self.cid)
            self._grip_weld = None
        self.held = None
        self._closing = False
        self._command_fingers(self.finger_travel)
        if held is not None:
            self._stow(held)
        return held

    def _stow(self, apparatus: LaunchingApparatus) -> None:
        """Latch ``apparatus`` into the empty holster its handle frame lies at, if any (the holster's pose exactly)."""
        p_handle, q_handle = apparatus.handle_pose()
        occupied = {a.holster_link for a in self.apparatuses()}
        for holster in self.holsters.values():
            if holster.link in occupied:
                continue
            p, q = self.link_pose(holster.link)
            turn = pybullet.getDifferenceQuaternion(list(q), list(q_handle))
            angle = 2.0 * math.acos(min(1.0, abs(turn[3])))
            if np.linalg.norm(p_handle - np.asarray(p)) <= STOW_TOLERANCE_M and angle <= STOW_TOLERANCE_RAD:
                pybullet.resetBasePositionAndOrientation(apparatus.body_id, list(p), list(q), physicsClientId=self.cid)
                apparatus.latch(self.body_id, holster.link)
                return

    def apparatuses(self) -> list[LaunchingApparatus]:
        """The launching apparatuses the MMS was loaded with, left then right."""
        return [h.apparatus for h in self.holsters.values()]
    def release_scout(self) -> bool:
        """Open the held apparatus's hold on its MAV (the launch command, §IV-F); whether a MAV was let go."""
        if self.held is None or not self.held.mav_secured:
            return False
        self.held.release_mav()
        return True

    # ------------------------------------------------------------ holsters
    def store(self, mav: Robot) -> None:
        """Seat ``mav`` (a ``tello``) in the first apparatus without one, left holster first (a mission's
        ``stored_on``); ``ValueError`` when it is no tello or every apparatus carries one."""
        if getattr(mav, "kind", None) != "tello":
            raise ValueError(f"the {self.kind}'s launching apparatuses carry tello micro-scouts, not a {mav.kind}")
        for name, holster in self.holsters.items():
            if holster.apparatus.mav is None:
                holster.apparatus.load_mav(mav)
                self.holsters[name] = Holster(name, holster.link, holster.apparatus, mav)
                return
        raise ValueError(f"every launching apparatus of {self.name} already carries a MAV "
                         f"({', '.join(str(h.mav.name) for h in self.holsters.values() if h.mav is not None)})")

    def launch_apparatus(self, which: int | str) -> LaunchingApparatus:
        """The launching apparatus of holster ``which``: 0 / ``"holster_left"`` or 1 / ``"holster_right"``."""
        if isinstance(which, int) and 0 <= which < len(HOLSTERS):
            which = HOLSTERS[which]
        if which not in self.holsters:
            raise UnknownNameError(f"holster of {self.name}", str(which), [*self.holsters, "0", "1"])
        return self.holsters[which].apparatus

    # ------------------------------------------------------------ commands
    def safe_stop(self) -> None:
        """Stop the base and hold the arm (the gripper keeps what it holds)."""
        self.stop()
        self.hold_arm()

    def pre_physics(self, dt: float) -> None:
        """Advance the drive and the arm's joint PID by one physics step."""
        self.diff_drive.pre_physics(dt)
        self.arm.pre_physics(dt)

    def post_physics(self, dt: float) -> None:
        """Advance the odometry; carry the latched apparatuses (and their MAVs) with their holsters."""
        super().post_physics(dt)
        p, q = pybullet.getBasePositionAndOrientation(self.body_id, physicsClientId=self.cid)
        v, w = pybullet.getBaseVelocity(self.body_id, physicsClientId=self.cid)
        for holster in self.holsters.values():
            holster.apparatus.follow(p, q, v, w)
        if self._closing and self.held is None:
            for apparatus in self.apparatuses():
                if self.grasp(apparatus):
                    break

    def state(self) -> dict[str, Any]:
        """Pose, speeds, arm joint angles (rad), gripper gap (m) and the held apparatus."""
        state = super().state()
        state.update(
            arm_q=self.arm_positions().tolist(),
            gripper_opening=self.gripper_opening(),
            held=self.held.name if self.held is not None else None,
        )
        return state
