"""Ground robots on wheels or tracks: a URDF body standing on the floor, driven by :class:`DiffDrive`.

Every wheeled URDF of the world has a ``base_footprint`` link: the ground
projection of the base (z = floor contact plane, x forward). A robot is
spawned with that link on the floor (or at the ``z`` of a 4-value pose);
``pose()`` stays the pose of the base link, whose origin is its centre of
mass. Commands are in the base frame: ``v`` forward (m/s), ``omega``
counter-clockwise (rad/s).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
import pybullet

from marsupial.api.model import DiffDriveLimits
from marsupial.api.views import WheeledView
from marsupial.geometry import Vector

from ..estimation.ground import LOCALIZATIONS, MapErrors, MapLocalization, OdometryErrors, WheelOdometry
from .base import Robot, pose_from_list, yaw_of
from .diff_drive import DiffDrive

if TYPE_CHECKING:
    from ..world import World


def limits_with(defaults: DiffDriveLimits, overrides: DiffDriveLimits | Mapping[str, float] | None) -> DiffDriveLimits:
    """``defaults`` with the fields named in ``overrides`` replaced (a full :class:`DiffDriveLimits` wins).

    Unknown field names raise a :class:`ValueError` listing the known ones.
    """
    if overrides is None:
        return defaults
    if isinstance(overrides, DiffDriveLimits):
        return overrides
    known = {f.name for f in dataclasses.fields(DiffDriveLimits)}
    unknown = set(overrides) - known
    if unknown:
        raise ValueError(f"unknown drive limit(s) {sorted(unknown)}; expected some of {sorted(known)}")
    return dataclasses.replace(defaults, **{k: float(v) for k, v in overrides.items()})


class WheeledRobot(Robot):
    """A robot whose base is the URDF ``urdf`` driven on the floor by a :class:`DiffDrive`.

    Args:
        pose: ``[x, y]``, ``[x, y, yaw]`` or ``[x, y, z, yaw]`` of ``base_footprint``
            in the world frame (m, rad); z defaults to the floor height.
        limits: drive limits replacing :attr:`default_limits`, whole or by field
            (e.g. ``{"noise_std": 0.0}``).
        localization: ``"odometry"`` (default: :class:`WheelOdometry`, frame ``odom``,
            drifts with distance) or ``"map"`` (:class:`MapLocalization` against the
            mission's declared map, frame ``map``, bounded error).

    Attributes:
        odometry: the :class:`WheelOdometry` (also behind a map localiser).
        estimator: the onboard estimator the skills read.
    """

    view_class = WheeledView
    #: file under ``world/assets/`` with a ``base_footprint`` link
    urdf: str = ""
    #: drive limits of the kind (subclasses set the paper's values)
    default_limits: DiffDriveLimits = DiffDriveLimits(max_speed=1.0, max_omega=1.0)
    #: wheel-odometry figures of the kind (differential base by default; skid-steer kinds worse)
    odometry_errors: OdometryErrors = OdometryErrors()
    #: map-localisation figures (AMCL-like)
    map_errors: MapErrors = MapErrors()

    def __init__(
        self,
        world: World,
        name: str,
        pose: Vector = (0.0, 0.0, 0.0),
        limits: DiffDriveLimits | Mapping[str, float] | None = None,
        localization: str = "odometry",
    ):
        if localization not in LOCALIZATIONS:
            raise ValueError(f"localization must be one of {LOCALIZATIONS}, got '{localization}'")
        super().__init__(world, name)
        floor = world.scene.floor
        p_footprint, q = pose_from_list(pose, default_z=floor.height if floor is not None else 0.0)
        self.load_urdf(self.urdf, p_footprint, q)
        # the URDF places base_footprint below the base origin: lift the body so it stands at p_footprint
        p_fp_now, _ = self.link_pose("base_footprint")
        p_base, q_base = self.pose()
        pybullet.resetBasePositionAndOrientation(
            self.body_id, p_base + (p_footprint - p_fp_now), q_base, physicsClientId=self.cid
        )
        self.limits = limits_with(self.default_limits, limits)
        self.diff_drive = DiffDrive(world, self.body_id, self.limits, f"{name}/drive")
        p0, q0 = self.footprint_pose()  # the start pose the mission declares
        self.odometry = WheelOdometry(self, p0, yaw_of(q0), self.odometry_errors)
        self.estimator = (
            self.odometry if localization == "odometry" else MapLocalization(self, self.odometry, self.map_errors)
        )

    # ------------------------------------------------------------ commands
    def drive(self, v: float, omega: float) -> None:
        """Command forward speed ``v`` (m/s) and yaw rate ``omega`` (rad/s, CCW), clipped to the limits."""
        self.diff_drive.command(v, omega)

    def stop(self) -> None:
        """Command zero speed; the base decelerates within its acceleration limits."""
        self.diff_drive.stop()

    def safe_stop(self) -> None:
        """Stop the base."""
        self.stop()

    # --------------------------------------------------------------- state
    def speed(self) -> float:
        """Measured forward speed of the base (m/s, along its heading)."""
        v, _ = self.velocity()
        yaw = yaw_of(self.pose()[1])
        return float(v[0] * math.cos(yaw) + v[1] * math.sin(yaw))
    def wheel_speed(self) -> float:
        """Forward speed (m/s) as the wheel encoders measure it (last odometry sample)."""
        return self.odometry.speed

    def true_yaw_rate(self) -> float:
        """True yaw rate of the base (rad/s; the odometry's gyro input, world side)."""
        return float(pybullet.getBaseVelocity(self.body_id, physicsClientId=self.cid)[1][2])

    def footprint_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """World pose of ``base_footprint`` (the base projected on the ground)."""
        return self.link_pose("base_footprint")

    def estimate_frame_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """True pose of ``base_footprint``, the frame the odometry estimates."""
        return self.footprint_pose()

    def state(self) -> dict[str, Any]:
        """Pose plus measured forward speed (m/s), yaw rate (rad/s) and the commanded v, omega."""
        state = super().state()
        _, w = self.velocity()
        state.update(
            speed=self.speed(),
            yaw_rate=float(w[2]),
            v_cmd=self.diff_drive.v_cmd,
            omega_cmd=self.diff_drive.omega_cmd,
        )
        return state

    # ------------------------------------------------------------ stepping
    def pre_physics(self, dt: float) -> None:
        """Advance the drive reference by one physics step."""
        self.diff_drive.pre_physics(dt)

    def post_physics(self, dt: float) -> None:
        """Advance the onboard estimator by one physics step."""
        self.estimator.update(dt)
