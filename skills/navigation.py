"""Ground navigation along a guide path with LiDAR-based local obstacle avoidance (``navigate``).

Narváez et al. §V-A: "a basic path γ_mm is traced as a guide for ground
navigation ... γ_mm is modified with the presence of obstacles and
structures detected by the ground and aerial sensors ... Path smoothing is
done to smooth out sharp corners"; §V-B: the robots "were moving
autonomously along a series of set-points given continuously by the
operator"; the UGV's longitudinal speed is limited to 2 m/s, and to
0.5 m/s during docking (§V-B-1).

Not specific to docking: any wheeled robot with a planar ``lidar`` can use
it, hence this module sits beside the generic skills.

What it senses (the sensing boundary): the robot's pose is its onboard
estimate (``robot.estimate()``, the carrier's map localisation in
``usar_docking``: frame ``map``); its speed, the wheel encoders
(``robot.speed()``); obstacles, the echoes of its LiDAR scan placed with
the LiDAR's URDF mount and the estimate at the time they are read
(:mod:`marsupial.sensing`). The guide path is scene knowledge the mission
declares: a path of the building plan (``context.prior("building_plan")``)
or way-points in the mission, in the estimate's navigation frame (the world
frame at the start). Estimation error therefore moves the path relative to
the walls; the LiDAR avoidance is what keeps the robot off them.

Pipeline, all in numpy:

1. :func:`smooth_path` — Chaikin corner cutting of the guide polyline (the
   limit curve is a quadratic B-spline through the segment midpoints that
   stays inside the polyline's convex hull, so it never swings wider than the
   operator's corners), resampled every 0.1 m (:func:`resample`);
2. :class:`PathFollower` — the robot's arc-length progress on the smoothed
   path (projection searched forward from the last one, so a path passing
   near itself is not short-cut) and a pure-pursuit look-ahead point;
3. :func:`subgoal` — when the corridor to the look-ahead point is blocked,
   a sub-goal along the free direction nearest to it (:func:`free_distances`
   over the scan, a vector-field-histogram-like choice of gap);
4. :func:`local_plan` — a dynamic-window planner: constant (v, ω) arcs over a
   horizon, each checked against the LiDAR echoes with the robot's
   rectangular footprint; an arc is admissible when the robot can brake
   before its first collision; the chosen admissible arc comes closest to the
   look-ahead point over its free part, preferring speed, the pure-pursuit
   turn rate and clearance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated, Any, ClassVar

import cv2
import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.api.capabilities import HasBase, HasLidar
from marsupial.sensing import body_pose, in_nav_frame, scan_in_body, sensor_mount
from marsupial.trees.metrics import MetricSpec
from marsupial.trees.milestones import milestone
from marsupial.trees.skill import NodeParams, Skill

MAX_SPEED = 2.0  # m/s, UGV longitudinal speed limit, Narváez §V-B-1
DOCKING_SPEED = 0.5  # m/s, UGV speed limit during docking, Narváez §V-B-1
RESAMPLE_SPACING = 0.1  # m between points of the smoothed path
CLEARANCE_CAP = 1.5  # m: clearances beyond this do not change the planner's choice
SPEED_FRACTIONS = np.array([0.0, 0.05, 0.1, 0.2, 0.35, 0.5, 0.7, 1.0])  # speed samples of the local planner, × limit


# ------------------------------------------------------------------ path
def smooth_path(points: np.ndarray, iterations: int = 3) -> np.ndarray:
    """Chaikin corner cutting of a polyline ``(n, 2)`` (m); the end points are kept.

    Each iteration replaces every segment by its points at 1/4 and 3/4;
    three iterations round a corner over a quarter of its shorter segment.
    """
    p = np.asarray(points, dtype=float)
    for _ in range(iterations):
        if len(p) < 3:
            break
        q = 0.75 * p[:-1] + 0.25 * p[1:]
        r = 0.25 * p[:-1] + 0.75 * p[1:]
        cut = np.empty((2 * len(q), 2))
        cut[0::2], cut[1::2] = q, r
        p = np.vstack((p[:1], cut[1:-1], p[-1:]))
    return p


def resample(points: np.ndarray, spacing: float = RESAMPLE_SPACING) -> tuple[np.ndarray, np.ndarray]:
    """Points every ``spacing`` m along a polyline and their arc lengths (m): ``(m, 2)``, ``(m,)``."""
    p = np.asarray(points, dtype=float)
    s = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))))
    samples = np.linspace(0.0, s[-1], max(2, int(math.ceil(s[-1] / spacing)) + 1))
    return np.column_stack((np.interp(samples, s, p[:, 0]), np.interp(samples, s, p[:, 1]))), samples


class PathFollower:
    """Progress along a smoothed, resampled path and the pure-pursuit look-ahead point (navigation frame, m).

    Args:
        guide: guide polyline ``(n, 2)``.
        iterations: Chaikin iterations of :func:`smooth_path`.
    """

    def __init__(self, guide: np.ndarray, iterations: int = 3):
        self.points, self.s = resample(smooth_path(guide, iterations))
        self.length = float(self.s[-1])
        self.progress_s = 0.0

    def update(self, p_xy: np.ndarray, window: float = 3.0) -> float:
        """Arc length (m) of the closest path point to ``p_xy`` within ``window`` m past the last one."""
        lo = np.searchsorted(self.s, self.progress_s - 0.5)
        hi = np.searchsorted(self.s, self.progress_s + window, side="right")
        d = np.linalg.norm(self.points[lo:hi] - p_xy, axis=1)
        self.progress_s = max(self.progress_s, float(self.s[lo + int(np.argmin(d))]))
        return self.progress_s

    def lookahead(self, distance: float) -> np.ndarray:
        """Path point ``distance`` m past the progress point (the end point beyond the end)."""
        i = min(len(self.s) - 1, int(np.searchsorted(self.s, self.progress_s + distance)))
        return self.points[i]

    @property
    def end(self) -> np.ndarray:
        """Last point of the path."""
        return self.points[-1]


# ------------------------------------------------------------ local planner
@dataclass(frozen=True)
class Footprint:
    """Robot rectangle about ``base_footprint`` (m): ``front``/``rear`` extents along x, ``half_width`` along y."""

    front: float
    rear: float
    half_width: float

    def samples(self, spacing: float = 0.1) -> np.ndarray:
        """Points ``(P, 2)`` (m, robot frame) covering the rectangle and its edges at most ``spacing`` apart."""
        xs = np.linspace(-self.rear, self.front, max(2, int(math.ceil((self.front + self.rear) / spacing)) + 1))
        ys = np.linspace(-self.half_width, self.half_width, max(2, int(math.ceil(2 * self.half_width / spacing)) + 1))
        return np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2)


@dataclass(frozen=True)
class PlannerSettings:
    """Dynamic-window settings (SI): samples, horizon, braking, cost weights.

    Attributes:
        turn_rates: number of ω samples (the speeds are :data:`SPEED_FRACTIONS` of the limit).
        horizon, step: arc duration (s) and time between checked poses (s).
        margin: clearance (m) below which a pose collides.
        max_accel: braking deceleration assumed (m/s²); reaction: delay before braking (s).
        creep_speed, speed_per_clearance: speed cap near obstacles, ``creep + k (clearance − margin)``
            (m/s, 1/s): slow past obstacles, full speed from about a metre away.
        w_goal, w_speed, w_turn, w_clearance: weights of the closest approach to the goal, the speed
            shortfall, the turn-rate mismatch and the clearance deficit below ``clearance_ref`` (m).
    """

    turn_rates: int = 15
    horizon: float = 2.0
    step: float = 0.2
    margin: float = 0.15
    max_accel: float = 0.8
    reaction: float = 0.2
    creep_speed: float = 0.25
    speed_per_clearance: float = 2.0
    w_goal: float = 1.0
    w_speed: float = 0.4
    w_turn: float = 0.1
    w_clearance: float = 0.3
    clearance_ref: float = 0.5


@dataclass(frozen=True)
class LocalPlan:
    """The chosen command ``v`` (m/s), ``omega`` (rad/s), its arc's smallest clearance (m) and free length (m)."""

    v: float
    omega: float
    clearance: float
    free: float


def arc_poses(v: np.ndarray, omega: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Poses ``x, y, yaw`` ``(S, K)`` of unicycle arcs (robot frame at t = 0) for S samples at K times."""
    v, w, t = v[:, None], omega[:, None], times[None, :]
    yaw = w * t
    straight = np.abs(w) < 1e-6
    safe_w = np.where(straight, 1.0, w)
    x = np.where(straight, v * t, v / safe_w * np.sin(yaw))
    y = np.where(straight, 0.0, v / safe_w * (1.0 - np.cos(yaw)))
    return x, y, yaw


class ClearanceField:
    """Distance (m) to the nearest obstacle over a square grid centred on the robot (robot frame).

    The echoes are drawn into a grid of ``cell`` m and OpenCV's Euclidean
    distance transform (5×5 mask, within 2 %) gives every cell's distance to
    the nearest one; echoes outside the grid are farther than ``half_size`` − (whatever
    is queried) and do not matter for clearances below that. Lookups are
    nearest-cell (error ≤ 0.71 ``cell``).
    """

    def __init__(self, obstacles: np.ndarray, half_size: float, cell: float = 0.05):
        self.cell, self.half_size = cell, half_size
        n = int(math.ceil(2.0 * half_size / cell))
        grid = np.full((n, n), 255, dtype=np.uint8)
        ij = np.floor((obstacles + half_size) / cell).astype(np.int64)
        inside = ((ij >= 0) & (ij < n)).all(axis=1)
        grid[ij[inside, 0], ij[inside, 1]] = 0
        self.distance = cv2.distanceTransform(grid, cv2.DIST_L2, 5) * cell
        self.n = n

    def at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Distance (m) to the nearest echo at points ``x``, ``y`` (robot frame, any shape)."""
        i = np.clip(((x + self.half_size) / self.cell).astype(np.int64), 0, self.n - 1)
        j = np.clip(((y + self.half_size) / self.cell).astype(np.int64), 0, self.n - 1)
        return self.distance[i, j]


def arc_clearances(
    obstacles: np.ndarray, x: np.ndarray, y: np.ndarray, yaw: np.ndarray, footprint: Footprint, cap: float
) -> tuple[np.ndarray, float]:
    """Clearance (m, capped at ``cap``) of the footprint at every arc pose ``(S, K)``, and at the robot now.

    The footprint's clearance is the smallest obstacle distance over points
    covering it (:meth:`Footprint.samples`), read from a :class:`ClearanceField`.
    """
    if len(obstacles) == 0:
        return np.full(x.shape, cap), cap
    reach = float(np.max(np.hypot(x, y))) if x.size else 0.0
    samples = footprint.samples()
    field = ClearanceField(obstacles, reach + float(np.max(np.hypot(*samples.T))) + cap)
    c, s = np.cos(yaw)[..., None], np.sin(yaw)[..., None]
    px = x[..., None] + c * samples[:, 0] - s * samples[:, 1]
    py = y[..., None] + s * samples[:, 0] + c * samples[:, 1]
    clearance = np.minimum(field.at(px, py).min(axis=-1), cap)
    now = min(float(field.at(samples[:, 0], samples[:, 1]).min()), cap)
    return clearance, now


def local_plan(
    obstacles: np.ndarray,
    goal: np.ndarray,
    v_ref: float,
    omega_ref: float,
    v_max: float,
    omega_max: float,
    footprint: Footprint,
    settings: PlannerSettings = PlannerSettings(),
) -> LocalPlan:
    """Choose (v, ω) among collision-free arcs toward ``goal`` (robot frame, m; ``obstacles`` ``(m, 2)`` m).

    A sample is admissible when its braking distance ``v²/2a + v·reaction``
    fits in the arc's free length (distance travelled before the footprint
    comes within ``margin`` of an echo, or any closer than it is now when it
    is already inside the margin) and its speed is within the cap of its
    smallest clearance (``creep_speed + speed_per_clearance (clearance −
    margin)``); turning on the spot (v = 0) is admissible when the turn stays
    clear. Among admissible samples the cost

    ``w_goal d/|goal| + w_speed max(0, v_ref − v)/v_max + w_turn |ω − ω_ref|/ω_max
    + w_clearance max(0, 1 − clearance/clearance_ref)``

    is minimised, ``d`` being the arc's closest approach to the goal over its
    free part (so arcs that get around an obstacle beat those that stop at
    it); ``v_ref``, ``ω_ref`` are the pure-pursuit command. With nothing
    admissible the robot stops.
    """
    v = np.repeat(v_max * SPEED_FRACTIONS, settings.turn_rates)
    w = np.tile(np.linspace(-omega_max, omega_max, settings.turn_rates), len(SPEED_FRACTIONS))
    times = np.arange(1, int(round(settings.horizon / settings.step)) + 1) * settings.step
    x, y, yaw = arc_poses(v, w, times)
    clearance_k, now = arc_clearances(obstacles, x, y, yaw, footprint, CLEARANCE_CAP)
    # already closer than the margin (pushed there): poses that get no closer still count as free
    threshold = min(settings.margin, max(now - 0.01, 0.02))
    colliding = clearance_k < threshold
    first = np.where(colliding.any(axis=1), colliding.argmax(axis=1), len(times))
    t_free = np.where(first > 0, times[np.maximum(first - 1, 0)], 0.0)
    free = np.where(first == len(times), np.inf, v * t_free)
    braking = v**2 / (2.0 * settings.max_accel) + v * settings.reaction
    clearance = np.minimum(clearance_k.min(axis=1), now)
    slow_enough = v <= settings.creep_speed + settings.speed_per_clearance * np.maximum(
        clearance - settings.margin, 0.0
    )
    admissible = np.where(v > 1e-9, (free >= braking) & slow_enough, ~colliding.any(axis=1))
    if not admissible.any():
        return LocalPlan(0.0, 0.0, now, 0.0)
    reach = np.hypot(x - goal[0], y - goal[1])
    reach[np.arange(len(times))[None, :] >= first[:, None]] = np.inf  # only the free part of each arc
    goal_distance = max(float(np.hypot(*goal)), 0.1)
    approach = np.minimum(reach.min(axis=1), goal_distance)
    cost = (
        settings.w_goal * approach / goal_distance
        + settings.w_speed * np.maximum(v_ref - v, 0.0) / max(v_max, 1e-9)
        + settings.w_turn * np.abs(w - omega_ref) / omega_max
        + settings.w_clearance * np.maximum(0.0, 1.0 - clearance / settings.clearance_ref)
    )
    cost[~admissible] = np.inf
    i = int(np.argmin(cost))
    return LocalPlan(float(v[i]), float(w[i]), float(clearance[i]), float(free[i]))


def free_distances(obstacles: np.ndarray, angles: np.ndarray, half_width: float, max_range: float) -> np.ndarray:
    """Free travel (m) along each direction ``angles`` (robot frame) of a corridor ``2 half_width`` wide.

    A direction is blocked at the nearest echo ahead whose lateral distance
    from the ray is below ``half_width``; unblocked directions get ``max_range``.
    """
    d = np.column_stack((np.cos(angles), np.sin(angles)))  # (n, 2)
    along = obstacles @ d.T  # (m, n)
    lateral = np.abs(obstacles[:, None, 0] * d[None, :, 1] - obstacles[:, None, 1] * d[None, :, 0])
    blocking = (along > 0.0) & (lateral < half_width)
    return np.where(blocking, along, max_range).min(axis=0, initial=max_range)


def subgoal(
    goal: np.ndarray, obstacles: np.ndarray, half_width: float, previous: float | None, directions: int = 72
) -> tuple[np.ndarray, float | None]:
    """The goal if the corridor to it is free, else a point along the free direction nearest to it (robot frame, m).

    Free directions leave room for at least the goal distance (capped at
    1 m); ties between both sides of an obstacle keep the side of the
    ``previous`` detour direction (rad), so the robot does not dither.
    Returns the sub-goal and its direction (``None`` when the goal itself is free).
    """
    goal_distance = float(np.hypot(*goal))
    goal_angle = math.atan2(goal[1], goal[0])
    if goal_distance < 1e-6:
        return goal, None
    if free_distances(obstacles, np.array([goal_angle]), half_width, goal_distance)[0] >= goal_distance:
        return goal, None
    angles = goal_angle + np.linspace(-math.pi, math.pi, directions, endpoint=False)
    free = free_distances(obstacles, angles, half_width, goal_distance + 1.0)
    needed = min(goal_distance, 1.0)
    off = np.abs(np.remainder(angles - goal_angle + math.pi, math.tau) - math.pi)
    if previous is not None:
        off += 0.3 * np.abs(np.remainder(angles - previous + math.pi, math.tau) - math.pi)
    off[free < needed] = np.inf
    i = int(np.argmin(off)) if np.isfinite(off).any() else int(np.argmax(free))
    reach = max(min(free[i] - half_width, goal_distance), 0.3)
    return reach * np.array([math.cos(angles[i]), math.sin(angles[i])]), float(angles[i])


def pure_pursuit(
    goal_R: np.ndarray, v_limit: float, omega_max: float, turn_in_place: float = math.radians(60)
) -> tuple[float, float]:
    """Speed (m/s) and turn rate (rad/s) toward a point in the robot frame (m).

    Curvature ``κ = 2 y / L²``; beyond ``turn_in_place`` off the heading the robot turns on the spot.
    """
    L2 = float(goal_R @ goal_R)
    if L2 < 1e-9:
        return 0.0, 0.0
    alpha = math.atan2(goal_R[1], goal_R[0])
    if abs(alpha) > turn_in_place:
        return 0.0, math.copysign(omega_max, alpha)
    v = v_limit * math.cos(alpha)
    omega = v * 2.0 * goal_R[1] / L2
    if abs(omega) > omega_max:  # too tight at this speed: slow down to keep the curvature
        v *= omega_max / abs(omega)
        omega = math.copysign(omega_max, omega)
    return v, omega


# -------------------------------------------------------------------- skill
class Navigate(Skill["Navigate.Params"]):
    """Drive a ground robot along a guide path or operator set-points, avoiding obstacles seen by its LiDAR."""

    metrics: ClassVar[tuple[MetricSpec, ...]] = (
        MetricSpec("path_progress", "fraction", "share of the guide path's length covered (on the estimate)"),
    )

    class Params(NodeParams):
        path: str | list[Annotated[list[float], Field(min_length=2, max_length=2)]] | None = "operator_path"
        """Guide path γ_mm (§V-A): a path of the mission's building plan or [x, y] way-points (m, navigation frame).

        None: set-points only.
        """
        setpoints_key: str | None = None
        """Blackboard key of operator set-points ([x, y] or a list of them, m, navigation frame, §V-B).

        They replace the path.
        """
        max_speed: float = Field(MAX_SPEED, gt=0.0, le=MAX_SPEED)
        """Speed limit (m/s): 2 m/s, UGV longitudinal limit (§V-B-1)."""
        docking_speed: float = Field(DOCKING_SPEED, gt=0.0)
        """Speed limit while the docking flag is up (m/s): 0.5 m/s (§V-B-1)."""
        docking_flag: str | None = None
        """Blackboard key of the docking flag set by the docking skills (e.g. ``carrier/docking``)."""
        smoothing: int = Field(3, ge=0)
        """Chaikin corner-cutting iterations of the guide path (§V-A: sharp corners smoothed)."""
        lookahead: float = Field(1.0, gt=0.0)
        """Pure-pursuit look-ahead at rest (m); it grows by 0.5 s × speed."""
        goal_tolerance: float = Field(0.3, gt=0.0)
        """Distance (m) to the path's end at which it is reached."""
        footprint: tuple[float, float, float] = (0.25, 0.25, 0.2)
        """Front, rear, half-width (m) of the robot's rectangle about ``base_footprint``.

        Pioneer 3-DX: 0.455 × 0.381 m.
        """
        margin: float = Field(0.15, ge=0.0)
        """Clearance (m) kept from LiDAR echoes (chosen)."""
        sensor_range: float = Field(5.0, gt=0.0)
        """Echoes farther than this (m) are ignored by the local planner."""
        stuck_timeout: float | None = Field(30.0, gt=0.0)
        """Fail when the progress along the path has not grown by 0.1 m for this long (s); none: never."""

    robot_kinds = (HasBase, HasLidar)  # the wheeled robots with a planar LiDAR
    sensors = ("lidar",)
    claims = ("base",)  # the base only: a carrier's arm belongs to the docking skills
    writes = ("{robot}/path_progress",)

    @classmethod
    def read_keys(cls, params: Navigate.Params, robot: str | None) -> tuple[str, ...]:
        """The optional docking flag and set-point keys, when given."""
        keys = (params.docking_flag, params.setpoints_key)
        return tuple(k.format(robot=robot) for k in keys if k is not None)

    def start(self) -> None:
        self.lidar = self.robot.sensor("lidar")
        self.lidar_mount = sensor_mount(self.robot, "lidar", self.lidar.offset)
        p = self.params
        self.footprint = Footprint(*p.footprint)
        self.settings = PlannerSettings(margin=p.margin)
        self.setpoints: Any = None
        self.follower = self.follower_for_guide()
        self.last_progress, self.last_progress_time = -1.0, self.now
        self.obstacles = np.zeros((0, 2))
        self.last_scan: Any = None
        self.detour: float | None = None  # direction (rad, robot frame) of the detour around an obstacle

    def follower_for_guide(self) -> PathFollower | None:
        """A follower of the guide: the operator's set-points from here if any were written, else the path (or none)."""
        here = self.robot.estimate().position[:2]
        path = self.params.path
        if self.setpoints is not None:
            guide = np.vstack((here, np.asarray(self.setpoints, dtype=float).reshape(-1, 2)))
        elif path is None:
            return None
        else:
            guide = (
                self.context.prior("building_plan").path(path)
                if isinstance(path, str)
                else np.asarray(path, dtype=float)
            )
        follower = PathFollower(guide, self.params.smoothing)
        follower.update(here, window=follower.length)
        return follower

    def step(self) -> Status:
        p = self.params
        if p.setpoints_key is not None:
            setpoints = self.read(p.setpoints_key.format(robot=self.robot_name))
            if setpoints is not None and setpoints is not self.setpoints:
                self.setpoints = setpoints
                self.follower = self.follower_for_guide()
        if self.follower is None:
            self.robot.stop()
            self.feedback_message = "waiting for operator set-points"
            return Status.RUNNING
        estimate = self.robot.estimate()
        xy, yaw = estimate.position[:2], estimate.yaw
        s = self.follower.update(xy)
        progress = s / self.follower.length if self.follower.length > 0 else 1.0
        self.write(f"{self.robot_name}/path_progress", progress)
        self.context.metric("path_progress", progress, robot=self.robot_name)
        to_end = float(np.linalg.norm(self.follower.end - xy))
        if to_end <= p.goal_tolerance and s >= self.follower.length - p.goal_tolerance - 0.5:
            self.robot.stop()
            self.feedback_message = f"path end reached ({to_end:.2f} m)"
            milestone(self, f"reached the end of '{self.name}'" if self.name != self.kind else "reached its path's end")
            return Status.SUCCESS
        if s > self.last_progress + 0.1:
            self.last_progress, self.last_progress_time = s, self.now
        elif p.stuck_timeout is not None and self.now - self.last_progress_time > p.stuck_timeout:
            self.feedback_message = f"blocked at {s:.1f} m of {self.follower.length:.1f} m for {p.stuck_timeout:.0f} s"
            return Status.FAILURE

        docking = p.docking_flag is not None and bool(self.read(p.docking_flag.format(robot=self.robot_name), False))
        v_limit = min(p.docking_speed if docking else p.max_speed, self.robot.limits.max_speed)
        v_limit = min(v_limit, math.sqrt(2.0 * self.settings.max_accel * to_end))  # stop at the end
        omega_max = self.robot.limits.max_omega
        c, s_ = math.cos(yaw), math.sin(yaw)
        R_robot_world = np.array([[c, s_], [-s_, c]])
        goal_R = R_robot_world @ (self.follower.lookahead(p.lookahead + 0.5 * abs(self.robot.speed())) - xy)
        obstacles = self.obstacles_in_robot_frame(estimate, R_robot_world)
        goal_R, self.detour = subgoal(goal_R, obstacles, self.footprint.half_width + p.margin, self.detour)
        v_ref, omega_ref = pure_pursuit(goal_R, v_limit, omega_max)
        plan = local_plan(obstacles, goal_R, v_ref, omega_ref, v_limit, omega_max, self.footprint, self.settings)
        self.robot.drive(plan.v, plan.omega)
        self.feedback_message = (
            f"{progress:.0%} of {self.follower.length:.1f} m, v {plan.v:.2f} m/s, clearance {plan.clearance:.2f} m"
            + (" (docking speed)" if docking else "")
        )
        return Status.RUNNING

    def obstacles_in_robot_frame(self, estimate, R_robot_world: np.ndarray) -> np.ndarray:
        """LiDAR echoes within ``sensor_range`` in the robot frame (m).

        Each new scan is placed in the navigation frame with the estimate
        propagated to the scan's stamp, and kept there until the next one.
        """
        reading = self.lidar.read()
        if reading is not None and reading is not self.last_scan:
            self.last_scan = reading
            lidar_pose = in_nav_frame(body_pose(estimate, reading.stamp), self.lidar_mount)
            self.obstacles = scan_in_body(reading.data, lidar_pose)[:, :2]
        local = (self.obstacles - estimate.position[:2]) @ R_robot_world.T
        return local[np.einsum("ij,ij->i", local, local) <= self.params.sensor_range**2]

    def finish(self, status: Status) -> None:
        self.robot.stop()  # the base only: the arm belongs to the docking skills
