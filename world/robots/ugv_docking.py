"""The UGV–UGV marsupial pair of Zhao et al.: a child UGV with an up-tilted camera, a mother with a lifting station.

From "A coordinated docking approach based on embedded vision" (Zhao, Cao,
Gu, Zhou, Xu, Tan). Numbers from its Table 1: entrance width b_e = 19 cm,
child width b_c = 17 cm, camera tilted up by θ = 15°, the benchmark's
horizontal colour border H_GS is h = 23 cm above the camera, 640×480
images, field of view θ_f = 61°.

Geometry choices the paper leaves open, and why:

* θ_f = 61° is taken as the *vertical* field of view. With θ = 15° and
  h = 23 cm, H_GS leaves the top of the image at a horizontal distance
  h / tan(θ + θ_f/2) = 0.226 m, which is the paper's visual perception
  criterion distance d_e = 22 cm (Table 1): the two agree only this way.
* The benchmark (§2, §3.1, Fig. 1): four equal rectangular blocks in a
  2×2 checkerboard hanging on the lifting platform above the entrance.
  The midpoint search (§3.1) expects red at (i, j), green at (i, j+8),
  red at (i+8, j+8) and green at (i+8, j), and the lateral search red above
  and green below H_GS on the left: red top-left and bottom-right, green
  top-right and bottom-left, as the approaching child sees it. Its width
  follows from s_u^e = 203 px at d_e (Table 1): 203 px × 0.272 m depth /
  407 px focal length = 0.136 m, so each block is 6.8 cm wide; blocks are
  5 cm tall (not given) so that the 8-px checks hold up to ≈2.5 m, the
  farthest start of the repeatability trials (§4.2).
* The child's camera is 0.10 m above the floor, so H_GS is 0.33 m up.
* The lifting platform raises the child by 0.30 m into the storage capsule
  at 0.05 m/s (not given).

Carrying: the child is driven by a :class:`DiffDrive` constraint that holds
its height. When :meth:`MotherUGV.raise_platform` is called with a child on
the platform (:meth:`MotherUGV.child_on_platform`), the mother suspends the
child's drive and welds the child to the platform with a fixed constraint
at their relative pose of that moment; the child rides up, is carried
while the mother drives, and is released (drive resumed from where it
stands) once :meth:`MotherUGV.lower_platform` has brought the platform back
down to the floor.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np
import pybullet

from marsupial.api.model import (
    CAMERA_FOV_V_DEG,
    CAMERA_RESOLUTION,
    ENTRANCE_WIDTH_M,  # noqa: F401 (the slot the URDF models)
    DiffDriveLimits,
    Intrinsics,
)
from marsupial.api.views import BatteryWheeledView, LiftView

from ..energy import Battery, BatteryGauge, BatterySpec, GroundPowerModel
from ..sensors.base import SensorConfig
from ..sensors.camera import OPTICAL_FORWARD, Camera
from .attachment import place_link_at, weld
from .base import rotation_matrix, yaw_of
from .wheeled import WheeledRobot

if TYPE_CHECKING:
    from ..world import World

# embedded CMOS camera (rate not given): pixel noise, 1 % lost frames, 0.1 s latency (chosen, docs/world.md)
CAMERA_CONFIG = SensorConfig(rate_hz=10.0, noise_std=3.0, dropout=0.01, latency_s=0.1)
LIFT_TRAVEL_M = 0.30  # platform travel from the floor to the storage capsule (not given)
LIFT_SPEED_MPS = 0.05  # m/s (not given)
LIFT_FORCE_N = 300.0  # lift motor force limit (N)
LOWERED_TOLERANCE_M = 0.002  # the platform counts as lowered within this height (m)
CARRY_FORCE_N = 1000.0  # strength of the weld holding a carried child on the platform (N)

# The child's pack (the paper gives none): a 2S Li-ion pack of two 18650 cells, 7.2 V nominal, as small UGVs
# carry; the cell figures are Samsung SDI INR18650-25R's datasheet: 2500 mAh, standard charge 1.25 A (CC) to
# 4.20 V a cell (8.4 V for 2S). Open-circuit curve: energy.LIPO_CELL_V (the same Li-ion chemistry family).
CHILD_BATTERY = BatterySpec(capacity_mAh=2500.0, cells=2, charge_current_A=1.25, charge_voltage_V=8.4)
CHILD_POWER = GroundPowerModel(electronics_W=3.0, drive_idle_W=2.0, rolling_resistance=0.05, drive_efficiency=0.5)
"""The child's power (docs/world.md §6): a Raspberry-Pi-3B-class computer (≈ 2 W active) plus its CMOS camera
(≈ 1 W); 2 W of gear-motor no-load losses while the wheels turn; C_rr = 0.05 (small rubber wheels on a lab
floor); 50 % motor + gearbox + driver efficiency. 7.4 W at 0.3 m/s (3 W standing): 2.6 h of driving on the
19.1 Wh pack (2.5 Ah × 7.65 V mean open-circuit voltage), the order of a TurtleBot3 Burger's (ROBOTIS e-manual:
19.98 Wh, "2 h 30 min")."""
CHILD_BATTERY_GAUGE = SensorConfig(rate_hz=1.0, noise_std=0.01)  # V, as the quadrotors' gauges

CHILD_LIMITS = DiffDriveLimits(max_speed=0.3, max_omega=1.5, max_accel=0.5, max_alpha=3.0)
"""Small indoor/outdoor differential child robot (the paper gives no speeds)."""
MOTHER_LIMITS = DiffDriveLimits(max_speed=0.5, max_omega=0.5, max_accel=0.5, max_alpha=1.0)
"""The mother turns slowly on the spot while the child docks (§3.3); no speeds given."""


class ChildUGV(WheeledRobot):
    """Child UGV, 17 cm wide, with a forward CMOS camera tilted up by 15°.

    Sensors: ``camera`` (:class:`Camera` on ``camera_link``, 640×480, 61°
    vertical field of view, 10 Hz by default) and ``battery`` (the
    :class:`BatteryGauge` of its :data:`CHILD_BATTERY` pack, 1 Hz).

    Battery: drawn at :data:`CHILD_POWER` while on the ground, charged at
    the pack's charging current while the mother carries it on its lift (from
    the moment the platform takes it up until it is released on the floor).

    Args:
        pose: footprint pose ``[x, y]``, ``[x, y, yaw]`` or ``[x, y, z, yaw]`` (world frame, m, rad).
        limits: drive limits replacing :data:`CHILD_LIMITS`, whole or by field.
        camera_resolution: ``(width, height)`` in pixels; a smaller image keeps the
            61° field of view (the paper's pixel thresholds assume 640×480).
        camera: :class:`SensorConfig` overrides of the camera (``rate_hz``, ``noise_std``, …).
        battery_soc: initial state of charge in [0, 1].
        battery_capacity_mAh: capacity of the pack (mAh) in place of :data:`CHILD_BATTERY`'s.

    Attributes:
        size: ``(length, width)`` of the footprint (m), from the URDF.
        carrier: the :class:`MotherUGV` carrying this child on its platform, or ``None``.
        battery: the :class:`Battery`; ``power`` the electrical power (W) drawn in the last step.
    """

    kind = "child_ugv"
    view_class = BatteryWheeledView
    urdf = "child_ugv.urdf"
    default_limits = CHILD_LIMITS

    def __init__(
        self,
        world: World,
        name: str,
        pose: Sequence[float] = (0.0, 0.0, 0.0),
        limits: DiffDriveLimits | Mapping[str, float] | None = None,
        localization: str = "odometry",
        camera_resolution: Sequence[int] = CAMERA_RESOLUTION,
        camera: Mapping[str, Any] | None = None,
        battery_soc: float = 1.0,
        battery_capacity_mAh: float | None = None,
    ):
        super().__init__(world, name, pose=pose, limits=limits, localization=localization)
        capacity = CHILD_BATTERY.capacity_mAh if battery_capacity_mAh is None else battery_capacity_mAh
        self.battery = Battery(replace(CHILD_BATTERY, capacity_mAh=capacity), battery_soc)
        self.power = 0.0
        self._mass = sum(
            pybullet.getDynamicsInfo(self.body_id, link, physicsClientId=self.cid)[0]
            for link in range(-1, pybullet.getNumJoints(self.body_id, physicsClientId=self.cid))
        )
        self.add_sensor(BatteryGauge(world, f"{name}/battery", self.battery, CHILD_BATTERY_GAUGE))
        (shape,) = pybullet.getCollisionShapeData(self.body_id, -1, physicsClientId=self.cid)
        self.size: tuple[float, float] = (float(shape[3][0]), float(shape[3][1]))
        self.carrier: MotherUGV | None = None
        width, height = (int(n) for n in camera_resolution)
        self.camera = Camera(
            self,
            "camera",
            Intrinsics(width, height, CAMERA_FOV_V_DEG, near=0.02, far=10.0),
            CAMERA_CONFIG.with_overrides(camera),
            link="camera_link",
            R_link_optical=OPTICAL_FORWARD,
            measures_depth=False,
        )
        self.add_sensor(self.camera)

    def footprint_corners(self) -> np.ndarray:
        """The four corners of the footprint rectangle in the world frame, ``(4, 3)`` (m)."""
        p, q = self.footprint_pose()
        R = rotation_matrix(q)
        half_l, half_w = self.size[0] / 2, self.size[1] / 2
        local = np.array(
            [[half_l, half_w, 0.0], [half_l, -half_w, 0.0], [-half_l, -half_w, 0.0], [-half_l, half_w, 0.0]]
        )
        return p + local @ R.T

    def set_carrier(self, carrier: MotherUGV | None) -> None:
        """Hand the base over to ``carrier`` (drive suspended) or take it back (``None``: drive resumes here)."""
        self.carrier = carrier
        if carrier is not None:
            self.diff_drive.stop()
            pybullet.changeConstraint(self.diff_drive.constraint, maxForce=0.0, physicsClientId=self.cid)
        else:
            p, q = self.pose()
            self.diff_drive.teleport(p, yaw_of(q))

    def drive(self, v: float, omega: float) -> None:
        """Command ``v`` (m/s) and ``omega`` (rad/s); ignored while carried by the mother."""
        if self.carrier is None:
            super().drive(v, omega)

    def pre_physics(self, dt: float) -> None:
        """Advance the drive and draw its power; carried by the mother: charge instead."""
        if self.carrier is not None:
            self.power = 0.0
            self.battery.charge(dt)
            return
        self.diff_drive.pre_physics(dt)
        self.power = CHILD_POWER.power(self._mass, self.diff_drive.v, self.diff_drive.omega)
        self.battery.draw(self.power, dt)

    @property
    def charging(self) -> bool:
        """True while carried on the mother's lift and the battery is not full."""
        return self.carrier is not None and self.battery.soc < 1.0

    def state(self) -> dict[str, Any]:
        """Pose, speeds, the name of the carrier (``None`` on the ground) and the battery."""
        state = super().state()
        b = self.battery
        state.update(
            carrier=self.carrier.name if self.carrier is not None else None,
            battery_soc=b.soc, battery_voltage=b.voltage, battery_current=b.current_A, charging=self.charging,
        )
        return state


class MotherUGV(WheeledRobot):
    """Mother UGV with a lifting docking station at its rear (entrance facing the base's -x).

    Links: ``base_link``, ``base_footprint``, ``lift_platform`` (frame at the
    centre of the plate's top surface, prismatic ``lift_joint`` along z,
    0 … 0.30 m), ``benchmark`` (frame at I_h on the benchmark's face; the
    child approaches along the base's +x, its image left is the base's +y).

    Args:
        pose: footprint pose ``[x, y]``, ``[x, y, yaw]`` or ``[x, y, z, yaw]`` (world frame, m, rad).
        limits: drive limits replacing :data:`MOTHER_LIMITS`, whole or by field.

    Attributes:
        entrance_width: b_e (m).
        lift_travel: platform height at the storage capsule (m).
        plate_size: ``(length, width)`` of the platform's floor plate (m), from the URDF.
        carried: the children welded to the platform now.
    """

    kind = "mother_ugv"
    view_class = LiftView
    urdf = "mother_ugv.urdf"
    default_limits = MOTHER_LIMITS

    def __init__(
        self,
        world: World,
        name: str,
        pose: Sequence[float] = (0.0, 0.0, 0.0),
        limits: DiffDriveLimits | Mapping[str, float] | None = None,
        localization: str = "odometry",
    ):
        super().__init__(world, name, pose=pose, limits=limits, localization=localization)
        self.entrance_width = ENTRANCE_WIDTH_M
        self.lift_travel = LIFT_TRAVEL_M
        self.lift_joint = self.link_index("lift_platform")  # a link's index is its parent joint's
        self.benchmark_link = self.link_index("benchmark")
        plate = pybullet.getCollisionShapeData(self.body_id, self.lift_joint, physicsClientId=self.cid)[0]
        self.plate_size: tuple[float, float] = (float(plate[3][0]), float(plate[3][1]))
        self.carried: dict[str, tuple[ChildUGV, int]] = {}
        self._lift_target = 0.0
        floor = world.scene.floor
        if floor is not None:  # the lowered plate is sunk flush into the floor
            pybullet.setCollisionFilterPair(
                self.body_id, floor.body_id, self.lift_joint, -1, 0, physicsClientId=self.cid
            )
        self._command_lift(0.0)

    # ------------------------------------------------------------ platform
    def _command_lift(self, height: float) -> None:
        self._lift_target = height
        pybullet.setJointMotorControl2(
            self.body_id,
            self.lift_joint,
            pybullet.POSITION_CONTROL,
            targetPosition=height,
            force=LIFT_FORCE_N,
            maxVelocity=LIFT_SPEED_MPS,
            physicsClientId=self.cid,
        )
    def platform_height(self) -> float:
        """Height of the platform above its lowered position (m): 0 on the floor, :attr:`lift_travel` at the capsule."""
        return float(pybullet.getJointState(self.body_id, self.lift_joint, physicsClientId=self.cid)[0])

    def platform_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """World pose of the centre of the platform plate's top surface."""
        return self.link_pose(self.lift_joint)

    def benchmark_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """World pose of I_h, the crossing of the benchmark's colour borders (frame x points into the station)."""
        return self.link_pose(self.benchmark_link)

    def entrance_pose(self) -> tuple[np.ndarray, float]:
        """Centre of the entrance on the floor (world frame, m) and the heading (rad) a child must have to drive in."""
        p_entrance, q = self.benchmark_pose()  # the benchmark hangs in the entrance plane
        p_entrance[2] = self.footprint_pose()[0][2]
        return p_entrance, yaw_of(q)

    def child_on_platform(self, child: ChildUGV) -> bool:
        """Whether ``child`` stands wholly on the platform plate, inside the entrance walls.

        Every footprint corner must lie within the plate's length and within
        the entrance width across, and the footprint within 2 cm of the plate's top.
        """
        p_plate, q = self.platform_pose()
        R = rotation_matrix(q)
        corners = (child.footprint_corners() - p_plate) @ R  # in the platform frame
        return bool(
            np.all(np.abs(corners[:, 0]) <= self.plate_size[0] / 2)
            and np.all(np.abs(corners[:, 1]) <= self.entrance_width / 2)
            and np.all(np.abs(corners[:, 2]) <= 0.02)
        )
    def platform_switch(self) -> bool:
        """The load switch under the platform plate: pressed while a child UGV stands wholly on the plate.

        Simulated as :meth:`child_on_platform` for every child of the world
        (a real station senses this with a load cell or limit switches at the
        plate's end; the switch reports only pressed or not, no identity).
        """
        return any(
            isinstance(robot, ChildUGV) and self.child_on_platform(robot) for robot in self.world.robots.values()
        )

    def raise_platform(self) -> list[str]:
        """Lift the platform to the storage capsule, carrying the children standing on it.

        Returns the names of the children taken up (welded to the platform).
        """
        for robot in self.world.robots.values():
            if isinstance(robot, ChildUGV) and robot.carrier is None and self.child_on_platform(robot):
                self._attach(robot)
        self._command_lift(self.lift_travel)
        return list(self.carried)

    def store(self, child: ChildUGV) -> None:
        """Start the run with ``child`` stored: platform up at the capsule with the child welded on it."""
        pybullet.resetJointState(self.body_id, self.lift_joint, self.lift_travel, physicsClientId=self.cid)
        self._command_lift(self.lift_travel)
        place_link_at(child, "base_footprint", *self.platform_pose())
        self._attach(child)

    def lower_platform(self) -> None:
        """Bring the platform down to the floor; carried children are released once it is there."""
        self._command_lift(0.0)

    def _attach(self, child: ChildUGV) -> None:
        child.set_carrier(self)
        constraint = weld(self.body_id, self.lift_joint, child.body_id, -1, CARRY_FORCE_N, self.cid)
        self.carried[child.name] = (child, constraint)

    def _release_all(self) -> None:
        for child, constraint in self.carried.values():
            pybullet.removeConstraint(constraint, physicsClientId=self.cid)
            child.set_carrier(None)
        self.carried.clear()

    # ------------------------------------------------------------ commands
    def hold_lift(self) -> None:
        """Hold the platform where it is."""
        self._command_lift(self.platform_height())

    def safe_stop(self) -> None:
        """Stop the base and hold the platform where it is."""
        self.stop()
        self.hold_lift()

    def pre_physics(self, dt: float) -> None:
        """Advance the drive; release carried children once the platform is back on the floor."""
        self.diff_drive.pre_physics(dt)
        if self.carried and self._lift_target == 0.0 and self.platform_height() < LOWERED_TOLERANCE_M:
            self._release_all()

    def state(self) -> dict[str, Any]:
        """Pose, speeds, platform height (m) and the names of the carried children."""
        state = super().state()
        state.update(platform_height=self.platform_height(), carried=list(self.carried))
        return state


# ------------------------------------------------------------ entry geometry (truth, for tests and calibration)
def entry_geometry(mother: MotherUGV, child: ChildUGV) -> tuple[float, float, float]:
    """The child's true pose relative to the benchmark in Zhao et al.'s terms (Fig. 2): ``(α, x_e, y_e)``.

    {R} is the child's ground frame: origin under the camera's optical centre,
    Y_R along the camera's horizontal viewing direction (the heading), X_R to
    its right. ``(x_e, y_e)`` (m) is E, the ground projection of I_h, in {R};
    α (rad) the angle from X_R to VE, the benchmark's normal into the station
    (α = π/2: the child heads along the entry direction). World truth: for
    tests, calibration and scoring, not for skills.
    """
    p_cam, R_cam = child.camera.optical_pose()
    forward = R_cam[:2, 2] / np.linalg.norm(R_cam[:2, 2])
    right = np.array([forward[1], -forward[0]])
    p_bench, q_bench = mother.benchmark_pose()
    normal = rotation_matrix(q_bench)[:2, 0]
    offset = p_bench[:2] - p_cam[:2]
    return float(math.atan2(normal @ forward, normal @ right)), float(offset @ right), float(offset @ forward)


def place_child(mother: MotherUGV, child: ChildUGV, alpha: float, x_e: float, y_e: float) -> None:
    """Teleport ``child`` (at rest) to the relative pose ``(α, x_e, y_e)`` of :func:`entry_geometry` (rad, m)."""
    p_bench, q_bench = mother.benchmark_pose()
    heading = yaw_of(q_bench) + math.pi / 2 - alpha  # VE is at α from X_R = heading - π/2
    forward = np.array([math.cos(heading), math.sin(heading)])
    right = np.array([forward[1], -forward[0]])
    p_link, R_link = child.link_offset("camera_link")
    p_optical = p_link + R_link @ child.camera.offset  # camera centre in the base frame (the mount is level)
    origin = p_bench[:2] - x_e * right - y_e * forward  # O_R, under the camera
    base = origin - (p_optical[0] * forward - p_optical[1] * right)
    child.diff_drive.teleport(base, heading)
