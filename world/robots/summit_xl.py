"""Robotnik Summit XL with the red square landing platform of Palafox et al. (2019).

The UGV of Palafox et al. ("Robust Visual-Aided Autonomous Takeoff,
Tracking, and Landing of a Small UAV on a Moving Landing Platform for
Life-Long Operation", Appl. Sci. 2019): a skid-steer Summit XL
(0.72 × 0.61 × 0.39 m, 65 kg, up to 3 m/s) carrying a flat, rigid,
red-coloured square landing platform (§4.1) that an AR.Drone 2.0 finds from
4 m with an HSV red threshold (§3.2) and lands and rides on.

Geometry (``summit_xl.urdf``): ``base_link`` (centre of mass, 0.20 m above
the floor), ``base_footprint`` (on the floor), ``landing_platform`` (frame
at the centre of the platform's top surface, 0.40 m above the floor,
1.0 × 1.0 m). The paper gives no platform size; 1 m is what the setup
needs: a landing is aborted beyond 0.25 m of error (§3.1) and the drone with
its hull spans ≈0.5 m, so a 1 m square still catches a drone 0.25 m off centre.

Wheel slip (see :data:`SUMMIT_XL_LIMITS`): on the nominal circular track
(v = 0.5 m/s, ω = 0.05 rad/s, a 10 m circle in theory) the simulated
Summit XL drove a 12 m circle "due to the friction coefficient of the
UGV's wheels", and its circles drifted over time (§4.2.1, §4.2.3); on the
straight 0.5 m/s track it stayed within ≈3 cm of the line (§4.2.1, Fig. 6).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import pybullet

from marsupial.api.model import DiffDriveLimits
from marsupial.api.views import PlatformView

from ..estimation.ground import SKID_STEER_ODOMETRY
from .wheeled import WheeledRobot

if TYPE_CHECKING:
    from ..world import World

NOMINAL_RADIUS_M = 10.0  # commanded circle: v / ω = 0.5 / 0.05, §4.2.1
OBSERVED_RADIUS_M = 12.0  # circle the Summit XL actually drove, §4.2.1

SUMMIT_XL_LIMITS = DiffDriveLimits(
    max_speed=3.0,  # Summit XL top speed (m/s); nominal 0.5, rarely above 0.7 (§4.2.3)
    max_omega=1.5,  # rad/s, in-place turns of a skid-steer base of this size
    max_accel=1.0,  # m/s²
    max_alpha=2.0,  # rad/s²
    slip=0.0,  # straight tracks are followed at the commanded speed (§4.2.1, Fig. 6)
    turn_slip=1.0 - NOMINAL_RADIUS_M / OBSERVED_RADIUS_M,  # 1/6 of ω lost: 10 m command -> 12 m circle (§4.2.1)
    drift_per_rad=0.0,  # a sideways drift cannot widen a circle; wheel scrub (turn_slip) does
    # m/s and rad/s per 240 Hz step: ≈3 cm off a 15 m straight line (Fig. 6),
    # circle centres wander ≈0.1 m per lap (§4.2.3, Fig. 11)
    noise_std=0.01,
)
"""Drive limits of the Summit XL with the wheel slip Palafox et al. observed."""


class SummitXL(WheeledRobot):
    """Summit XL skid-steer UGV with a red square landing platform on top.

    Args:
        pose: ``[x, y]``, ``[x, y, yaw]`` or ``[x, y, z, yaw]`` of the footprint (world frame, m, rad).
        limits: drive limits replacing :data:`SUMMIT_XL_LIMITS`, whole or by field.
        localization: ``"odometry"`` (skid-steer figures, :data:`SKID_STEER_ODOMETRY`) or ``"map"``.

    Attributes:
        platform_size: ``(side_x, side_y)`` of the landing platform (m), read from the URDF.
    """

    kind = "summit_xl"
    view_class = PlatformView
    urdf = "summit_xl.urdf"
    default_limits = SUMMIT_XL_LIMITS
    odometry_errors = SKID_STEER_ODOMETRY

    def __init__(
        self,
        world: World,
        name: str,
        pose: Sequence[float] = (0.0, 0.0, 0.0),
        limits: DiffDriveLimits | Mapping[str, float] | None = None,
        localization: str = "odometry",
    ):
        super().__init__(world, name, pose=pose, limits=limits, localization=localization)
        self.platform_link = self.link_index("landing_platform")
        (shape,) = pybullet.getCollisionShapeData(self.body_id, self.platform_link, physicsClientId=self.cid)
        self.platform_size: tuple[float, float] = (float(shape[3][0]), float(shape[3][1]))

    def platform_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """World position (m) of the centre of the platform's top surface and its orientation ``[x, y, z, w]``."""
        return self.link_pose(self.platform_link)

    def state(self) -> dict[str, Any]:
        """Pose, speeds and the platform centre (world frame)."""
        state = super().state()
        state["platform_position"] = self.platform_pose()[0].tolist()
        return state
