"""The MAV's pre-launch pose and the three launch phases (Arora & Papachristos, §IV-E output, §IV-F, Definition 2).

"The valid poses in V are eventually transformed into 3-D 'prelaunch poses'"
(§IV-E): a profile-analysis configuration {p, θ} (pixel p of the
fronto-parallel image I, slope θ of the MAV's major axis) is lifted back
through I's pinhole model onto the model plane, giving ξ_MAV "centered
within the aperture plane". Then (§IV-F):

- Phase I — the goal g = d_l·n̂ + [x y z]ᵀ (ξ_MAV's position offset by the
  apparatus length d_l along the plane normal n̂);
- Phase II — "with g as start state and ξ_MAV as end effector goal state":
  the insertion line from g along −n̂, d_l long;
- Phase III — the launch pose ξ_MAV^ref, "mostly rotational", whose roll and
  pitch must satisfy |φ|, |θ| ≤ α_launch (Definition 2).

Reading of the phases (the paper says no more): g and ξ_MAV are goals of the
end effector holding the apparatus's handle, the MAV riding d_l ahead of it
along −n̂; at the end of Phase I the MAV is therefore centred in the
aperture plane at ξ_MAV's position (and rotated by θ to fit), and at the end
of Phase II it has "egressed from the back side", d_l past the plane — where
Definition 2 wants the launch pose's translation. The MAV's heading (body x)
lies along the insertion, −n̂ (it goes through nose first,
:mod:`.silhouette`). Phase III levels the MAV by turning the apparatus about
the insertion axis, by at most ``max_level_roll`` (default: any fit's roll;
the boom, still in the aperture, turns about its own axis, and the turn is
collision-checked): that removes up to that much of the fit's roll; the pitch, set by the plane's
tilt, is not changed. The launch attitude is accepted when its residual roll
and its pitch are within α_launch.

Frames and units: the navigation frame (z up), metres, radians. The MAV's
attitude ``R_nav_mav`` has columns its body axes (x forward, y left, z up);
roll φ, pitch θ, yaw ψ are its Z-Y-X Euler angles (R = Rz(ψ) Ry(θ) Rx(φ)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .detection import ApertureCandidate, FrontoParallelView, InertialFrame
from .profile import LaunchConfiguration

D_L_M = 0.30  # d_l: handle centre to MAV seat of the launching apparatus (launching_apparatus.urdf), §IV-F
ALPHA_LAUNCH = math.radians(15.0)  # α_launch (rad), Definition 2: chosen, the paper gives no value

#: the MAV's body axes in the fronto-parallel frame at θ = 0: x along z_fp (into the plane), y = −x_fp (image
#: left), z = −y_fp (image up); the image's u = −y_body, v = −z_body (:mod:`.silhouette`)
_BODY_IN_FP = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])


@dataclass(frozen=True)
class LaunchParams:
    """Parameters of launch planning (§IV-F).

    Attributes:
        d_l: d_l (m), the launching apparatus's length (handle centre to MAV seat).
        alpha_launch: α_launch (rad), largest roll and pitch at take-off (Definition 2; chosen, none given).
        max_level_roll: largest turn (rad) of the apparatus about the insertion axis in Phase III (chosen: π/2, any
            fit's roll, θ ∈ (−π/2, π/2]; the turn is collision-checked like every segment, and past the wall the
            boom turns about its own axis. At 20° the amoeba's fits along its minor axis were all refused).
    """

    d_l: float = D_L_M
    alpha_launch: float = ALPHA_LAUNCH
    max_level_roll: float = math.pi / 2


@dataclass(frozen=True)
class LaunchPlan:
    """The pre-launch pose ξ_MAV, the Phase I–III set-points and the launch attitude check.

    Attributes:
        pre_launch: ξ_MAV's position (nav, m): the MAV's centre of mass on the aperture plane.
        R_pre_launch: ξ_MAV's attitude ``R_nav_mav`` (body x = −n̂, rolled by the fit's θ).
        normal: n̂, the plane's unit normal toward the sensor (nav).
        goal: g = ξ_MAV + d_l·n̂ (nav, m), Phase I's end-effector goal.
        insertion: ``(start, end)`` of Phase II's end-effector line, g → ξ_MAV along −n̂ (nav, m).
        launch_position: the MAV's position at the end of Phase II, d_l past the plane (nav, m).
        R_launch: the launch attitude after Phase III's levelling.
        roll, pitch: φ, θ of ``R_launch`` (rad).
        feasible: |φ| ≤ α_launch and |θ| ≤ α_launch.
        rim: ``(n, 3)`` the aperture's contour C_a on the model plane (nav, m), for the rim checks of §IV-F.
    """

    pre_launch: np.ndarray
    R_pre_launch: np.ndarray
    normal: np.ndarray
    goal: np.ndarray
    insertion: tuple[np.ndarray, np.ndarray]
    launch_position: np.ndarray
    R_launch: np.ndarray
    roll: float
    pitch: float
    feasible: bool
    rim: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)), repr=False)

    def summary(self) -> dict[str, object]:
        """A JSON-ready record (m, rad, rounded)."""
        def r(v: np.ndarray) -> list[float]:
            return [round(float(x), 4) for x in v]
        return {"pre_launch": r(self.pre_launch), "goal": r(self.goal), "launch": r(self.launch_position),
                "roll": round(self.roll, 4), "pitch": round(self.pitch, 4), "feasible": self.feasible}


def rot_x(angle: float) -> np.ndarray:
    """Rotation about x by ``angle`` (rad)."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def roll_pitch_yaw(R: np.ndarray) -> tuple[float, float, float]:
    """Z-Y-X Euler angles (φ, θ, ψ) (rad) of ``R_nav_body`` = Rz(ψ) Ry(θ) Rx(φ)."""
    pitch = -math.asin(float(np.clip(R[2, 0], -1.0, 1.0)))
    return math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])


def attitude_ok(R: np.ndarray, alpha_launch: float = ALPHA_LAUNCH) -> bool:
    """Definition 2's take-off constraint |φ|, |θ| ≤ α_launch on the attitude ``R_nav_mav``."""
    roll, pitch, _ = roll_pitch_yaw(R)
    return abs(roll) <= alpha_launch and abs(pitch) <= alpha_launch


def pre_launch_pose(config: LaunchConfiguration, view: FrontoParallelView, frame: InertialFrame
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ξ_MAV of a configuration: position (nav, m), attitude ``R_nav_mav``, and the plane normal n̂ (nav).

    The pixel p goes back through I's pinhole onto the model plane (:meth:`FrontoParallelView.pixel_to_I`),
    then to the navigation frame; the MAV's body x is −n̂ and its major axis (body y) lies along θ in I.
    """
    position = frame.to_nav(view.pixel_to_I(np.asarray(config.center_px, dtype=float)))
    R_nav_fp = frame.R_nav_I @ view.R_fp.T  # columns: the fronto-parallel axes in nav; z_fp = −n̂
    R = R_nav_fp @ _BODY_IN_FP @ rot_x(config.angle)
    return position, R, -R_nav_fp[:, 2]


def plan_launch(config: LaunchConfiguration, view: FrontoParallelView, frame: InertialFrame,
                params: LaunchParams | None = None, rim: np.ndarray | None = None) -> LaunchPlan:
    """ξ_MAV, g, the insertion line, the launch pose and its attitude check for one configuration (§IV-F);
    ``rim``: the aperture's contour on the plane (nav, m), kept with the plan."""
    params = params or LaunchParams()
    position, R_pre, normal = pre_launch_pose(config, view, frame)
    goal = position + params.d_l * normal  # Phase I: g = d_l·n̂ + [x y z]ᵀ
    roll, _, _ = roll_pitch_yaw(R_pre)
    correction = float(np.clip(roll, -params.max_level_roll, params.max_level_roll))
    R_launch = R_pre @ rot_x(-correction)  # Phase III: a turn about body x, the insertion axis
    launch_roll, launch_pitch, _ = roll_pitch_yaw(R_launch)
    return LaunchPlan(position, R_pre, normal, goal, (goal, position), position - params.d_l * normal, R_launch,
                      launch_roll, launch_pitch, attitude_ok(R_launch, params.alpha_launch),
                      np.zeros((0, 3)) if rim is None else rim)


def plan_launches(candidate: ApertureCandidate, configs: list[LaunchConfiguration],
                  params: LaunchParams | None = None) -> list[LaunchPlan]:
    """:func:`plan_launch` of each configuration of ``candidate``'s profile analysis, the feasible ones, in order."""
    rim = candidate.frame.to_nav(candidate.view.pixel_to_I(candidate.contour_px.astype(float)))
    plans = [plan_launch(c, candidate.view, candidate.frame, params, rim) for c in configs]
    return [p for p in plans if p.feasible]
