"""Aerial exploration around the carrier (Narváez §II, §V-A).

The UAV surveys, stops every D_e to sweep the yaw and stays within D_team.

§V-A: "the aerial robot performs a series of movements to explore different
building areas. It tries to follow a path γ_UAV that allows covering the
available zones ... every D_e distance, the UAV stops and performs yaw
variations to make detailed measurements of the scene in a static
position", and it never flies "farther than a radius distance D_team
measured from the ground robot, which is a safety measure considering that
D_team can be traveled and a docking process can be executed with less than
20% of UAV energy". The paper gives no values for D_e and D_team; they are
chosen here (see the parameters).

Behaviour (one state per phase, one velocity command per tick):

- ``climb`` — motors on, climb to the cruise height;
- ``plan`` — choose the next goal (:func:`~.coverage.next_goal` over the
  flight map, among reachable cells within the leash disc, less the blending
  zone, of the carrier both now and where its velocity takes it by the end
  of the next sweep, so that the UAV leads a moving carrier), plan a grid path to it (:func:`~.coverage.geodesic`,
  :func:`~.coverage.shortcut`) and cut it at D_e (the next stop); nothing
  left to survey: fly back near the carrier and plan again later;
- ``fly`` — follow the path at ``speed``, braking onto the stop point (the
  distance flown in this phase is what D_e counts);
- ``sweep`` — hover and turn the heading through ``sweep_angle``.

Hard constraint (every phase): the horizontal distance to the carrier is
held below D_team − ``leash_margin`` (reduced for the height difference, so
the 3-D distance stays below D_team). Over the last metre inside that limit
the exploring command blends into a catch-up flight along the free path to
the carrier, faster than the carrier; at the limit the UAV only catches up
(phase ``catch_up``, a sweep is abandoned) until it is well inside again.
Goals are only chosen inside the limit.

What the skill senses (the sensing boundary): the UAV's position and
heading are its onboard estimate (``odom``: IMU, optical flow, sonar — it
drifts); the carrier's, the latest ``estimate`` telemetry the carrier sent
over the team link (its map localisation), extrapolated to now with the
velocity it reported; with no telemetry for ``link_timeout`` the UAV
hovers. Both estimates start in the world frame, so their difference is the
leash distance up to both estimation errors. The building's walls, door
frames and zones are the plan the mission declares
(``context.prior("building_plan")``); debris is not on it (it lies below
the flight band).

Coverage (blackboard ``coverage_key``, read by ``area_explored``): the share
of the survey area's cells — zones tagged ``area_tags`` within the D_team
disc of the carrier and reachable inside it — inside the front camera's
view. The Bebop 2's front camera is a plain RGB camera: it measures no
depth. A frame's view is therefore its horizontal field of view from the
estimated camera pose (UAV estimate ∘ URDF mount, :func:`~.coverage.view_bearings`)
cut at ``view_range`` and at the first wall of the plan
(:func:`~.coverage.plan_ranges`, :func:`~.coverage.visible_cells`): what
the camera would see of the declared building, not what it measured.

Target search: the target is found when a blob of its declared colour
(``target_rgb``, the casualty's high-visibility orange) shows in a
front-camera frame (:func:`~.coverage.detect_colour`; walls hide it as they
hide it from the renderer) and the floor point under its lowest pixel
(:func:`~.coverage.floor_point`, a monocular range for an object lying on
the floor) is within ``target_range``; then ``target_found`` is written, a
``target_found`` phase event gives that estimated position, and, with
``stop_at_target``, the skill succeeds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum
from typing import Annotated, ClassVar

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.api.capabilities import HasBase, Rotorcraft
from marsupial.api.errors import UnknownNameError
from marsupial.sensing import EstimateHistory, in_nav_frame, sensor_mount
from marsupial.trees.metrics import MetricSpec
from marsupial.trees.milestones import milestone
from marsupial.trees.phases import Phased, Transition, go, phase_event
from marsupial.trees.skill import NodeParams, Skill, TeamMember

from .coverage import (
    FlightMap,
    detect_colour,
    floor_point,
    geodesic,
    grid_path,
    next_goal,
    plan_ranges,
    shortcut,
    truncate,
    view_bearings,
    visible_cells,
)

D_E = 2.0  # m, D_e (§V-A): chosen — a stop per room-sized step; the front camera surveys ~4 m around each stop
SOFT_ZONE = 1.0  # m inside the leash radius over which exploring blends into catching up with the carrier
D_TEAM = 6.0  # m, D_team (§V-A): chosen — a room's reach indoors; flying it back and docking takes < 1 % of the
#                2700 mAh battery (≈ 6 s + 25 s at 85 W), far below the paper's 20 % bound


@dataclass
class _Tick:
    """One tick of the exploration: what the phase works from, and the horizontal command it gives.

    Positions in the world frame (m) as the two robots' estimates have them, the heading in rad.
    """

    xy: np.ndarray
    """The UAV's horizontal position (m)."""
    z: float
    """The UAV's height (m)."""
    yaw: float
    """The UAV's heading (rad)."""
    carrier_xy: np.ndarray
    """The carrier's horizontal position (m), from its telemetry."""
    radius: float
    """The leash radius (m, :meth:`Explore.leash_radius`)."""
    v_xy: np.ndarray = field(default_factory=lambda: np.zeros(2))
    """The phase's horizontal velocity command (m/s, world; none: hold)."""
    yaw_rate: float = 0.0
    """The phase's yaw rate (rad/s)."""


class Explore(Phased, Skill["Explore.Params"]):
    """Survey the rooms around the carrier with the UAV, within D_team of the carrier.

    The UAV stops every D_e for a yaw sweep.
    """

    metrics: ClassVar[tuple[MetricSpec, ...]] = (
        MetricSpec("coverage", "fraction", "share of the plan's target cells the UAV's camera has seen"),
        MetricSpec("target_found", "flag", "the UAV's camera found the target", "count"),
    )

    class Params(NodeParams):
        carrier: Annotated[str, TeamMember(HasBase)] = "carrier"
        """Team member the UAV must stay near (the ground robot of §V-A)."""
        D_e: float = Field(D_E, gt=0.0)
        """D_e (§V-A): distance flown between stops for a yaw sweep (m; chosen: 2 m)."""
        D_team: float = Field(D_TEAM, gt=0.0)
        """D_team (§V-A): largest distance from the carrier (m; chosen: 6 m, see module notes)."""
        height: float = Field(1.5, gt=0.0)
        """Cruise height above the floor (m; chosen: below the 2.1 m door lintels, above furniture and the arm)."""
        speed: float = Field(1.0, gt=0.0, le=4.0)
        """Cruise speed (m/s; ≤ 4 m/s lateral limit, §V-B)."""
        sweep_angle: float = Field(math.tau, gt=0.0)
        """Heading change of each yaw sweep (rad)."""
        sweep_rate: float = Field(1.2, gt=0.0, le=math.radians(100.0))
        """Yaw rate of the sweeps (rad/s; ≤ 100°/s autopilot limit)."""
        view_range: float = Field(4.0, gt=0.0)
        """Range (m) within which the front camera's view counts as surveyed."""
        view_period: float = Field(0.5, gt=0.0)
        """Time between front-camera frames used for coverage and the target (s)."""
        area_tags: tuple[str, ...] = ("room", "hall", "corridor")
        """Tags of the building plan's zones to survey (every cell when the plan has no such zone)."""
        cell: float = Field(0.25, gt=0.0)
        """Side of the flight map's cells (m)."""
        clearance: float = Field(0.45, gt=0.0)
        """Distance (m) kept from obstacles by the planned paths (UAV half-span 0.2 m + margin)."""
        leash_margin: float = Field(0.5, ge=0.0)
        """Distance (m) inside D_team at which the UAV is held (room for the carrier's acceleration)."""
        coverage_key: str = "coverage"
        """Blackboard key of the surveyed fraction (0..1), read by ``area_explored``."""
        target: str | None = "target"
        """Name of the searched object (in the events); none: no target search."""
        target_rgb: tuple[int, int, int] = (255, 120, 20)
        """Colour (0-255 RGB) of the searched object: the casualty's high-visibility orange."""
        target_pixels: int = Field(40, ge=1)
        """Fewest pixels of that colour that count as a detection.

        The 0.5 × 1.7 m casualty at 6 m spans a few hundred at 320 × 240.
        """
        target_range: float = Field(6.0, gt=0.0)
        """Farthest distance (m) at which the target counts as found.

        Horizontal, from the floor point under the detection.
        """
        camera_link: str = "camera_front"
        """URDF link carrying the front camera (its mount composes the camera pose with the UAV estimate)."""
        link_timeout: float = Field(1.0, gt=0.0)
        """Age (s) of the carrier's latest telemetry beyond which the UAV hovers and waits for it."""
        target_key: str = "target_found"
        """Blackboard key set to True when the target is found."""
        stop_at_target: bool = True
        """Succeed when the target is found (else keep exploring)."""

    class Phase(Enum):
        """The exploration's phases (module docstring)."""

        CLIMB = "climb"
        PLAN = "plan"
        FLY = "fly"
        SWEEP = "sweep"
        CATCH_UP = "catch_up"

    robot_kinds = (Rotorcraft,)
    sensors = ("front_camera",)
    claims = ("rotors",)
    writes = ("{coverage_key}", "{target_key}")
    phase: Phase

    # ------------------------------------------------------------ life cycle
    def start(self) -> None:
        p = self.params
        team = self.context.team()
        if p.carrier not in team or p.carrier == self.robot_name:
            others = [n for n in team if n != self.robot_name]
            raise UnknownNameError(f"carrier of {self.name} (a team member)", p.carrier, others)
        self.camera = self.robot.sensor("front_camera")
        self.camera_mount = sensor_mount(self.robot, p.camera_link, self.camera.offset, self.camera.R_link_optical)
        estimate = self.robot.estimate()
        self.history = EstimateHistory()
        self.history.add(estimate)
        here = np.asarray(estimate.position[:2])
        extent = (here - p.D_team, here + p.D_team)
        plan = self.context.prior("building_plan")
        self.map = FlightMap.from_plan(plan, p.height, 0.5, p.clearance, p.area_tags, p.cell, extent)
        self.seen = np.zeros(self.map.shape, dtype=bool)
        self.found = False
        self.stops: list[np.ndarray] = []
        self.enter(go(self.Phase.CLIMB, event=None))
        self.waypoints = np.zeros((0, 2))
        self.flown = 0.0
        self.last_xy = here
        self.heading_turned = 0.0
        self.last_yaw = estimate.yaw
        self.next_view = self.now
        self.replan_at = math.inf
        self.catch_up_until = -math.inf
        self.catch_up_direction = np.zeros(2)
        self.carrier_velocity = np.zeros(3)
        if not self.robot.motors_on and not self.robot.docked:
            self.robot.set_motors(True)

    def wanted_sensors(self) -> frozenset[tuple[str, str]]:
        """The front camera only for the tick of the next view (every ``view_period``): it is not rendered between."""
        due = self.now + self.context.tick_period + 1e-9 >= self.next_view
        return self.reads_sensors if due else frozenset()

    def step(self) -> Status:
        p = self.params
        if self.robot.docked:
            self.feedback_message = f"{self.robot_name} is docked: deploy it before exploring"
            return Status.FAILURE
        estimate = self.robot.estimate()
        self.history.add(estimate)
        position, yaw = estimate.position, estimate.yaw
        xy = np.asarray(position[:2])
        carrier = self.carrier_state()
        if carrier is None:
            self.robot.hover()
            self.feedback_message = f"waiting for {self.params.carrier}'s telemetry"
            return Status.RUNNING
        if self.phase is self.Phase.FLY:  # exploration flight only: drift while sweeping or catching up does not count
            self.flown += float(np.linalg.norm(xy - self.last_xy))
        self.heading_turned += abs(math.remainder(yaw - self.last_yaw, math.tau))
        self.last_xy, self.last_yaw = xy, yaw
        carrier_xy, self.carrier_velocity = carrier[0][:2], carrier[1]
        radius = self.leash_radius(position[2], carrier[0][2])
        if self.now + 1e-9 >= self.next_view:
            self.next_view = self.now + p.view_period
            self.look()
            if self.found and p.stop_at_target:
                self.feedback_message = "target found"
                return Status.SUCCESS

        tick = _Tick(xy, position[2], yaw, carrier_xy, radius)
        self.step_phase(tick)
        v_xy, vz, yaw_rate = tick.v_xy, float(np.clip(1.0 * (p.height - position[2]), -0.5, 0.5)), tick.yaw_rate
        v_xy = self.leash(v_xy, xy, carrier_xy, radius)
        if self.phase is self.Phase.CATCH_UP:
            yaw_rate = self.face(v_xy, yaw)
        self.robot.command_velocity(v_xy[0], v_xy[1], vz, yaw_rate, frame="world")
        return Status.RUNNING

    def carrier_state(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The carrier's position (m) and velocity (m/s) from its telemetry, extrapolated to now.

        ``None`` if too old.
        """
        message = self.link.latest(self.params.carrier)
        if message is None or self.now - message.sent > self.params.link_timeout:
            return None
        estimate = message.payload
        velocity = np.asarray(estimate.velocity, dtype=float)
        return np.asarray(estimate.position, dtype=float) + velocity * (self.now - estimate.stamp), velocity

    # ------------------------------------------------------------- phases
    def face(self, v_xy: np.ndarray, yaw: float) -> float:
        """Yaw rate (rad/s) turning the front camera toward the direction of flight."""
        if float(np.linalg.norm(v_xy)) < 0.2:
            return 0.0
        error = math.remainder(math.atan2(v_xy[1], v_xy[0]) - yaw, math.tau)
        return float(np.clip(2.0 * error, -self.params.sweep_rate, self.params.sweep_rate))

    def _step_climb(self, tick: _Tick) -> Status | Transition:
        """Climb to the cruise height (the climb rate is every phase's height hold)."""
        self.feedback_message = f"climbing to {self.params.height:.1f} m"
        if abs(self.params.height - tick.z) < 0.15:
            return go(self.Phase.PLAN, event=None)
        return Status.RUNNING

    def _step_plan(self, tick: _Tick) -> Status | Transition:
        """Plan the next leg when a plan is due (at once, then every 2 s while there is none); hover meanwhile."""
        if self.now + 1e-9 >= self.replan_at or math.isinf(self.replan_at):
            leg = self.plan(tick.xy, tick.carrier_xy, tick.radius)
            if leg is not None:
                return leg
        return Status.RUNNING

    def _step_fly(self, tick: _Tick) -> Status | Transition:
        """Fly the leg, facing the way; at its end or after D_e flown, stop for a sweep."""
        v_xy, arrived = self.follow(tick.xy)
        if arrived or self.flown >= self.params.D_e:
            return self.start_sweep(tick.xy)
        tick.v_xy, tick.yaw_rate = v_xy, self.face(v_xy, tick.yaw)
        return Status.RUNNING

    def _step_sweep(self, tick: _Tick) -> Status | Transition:
        """Hover and turn the heading through ``sweep_angle``; then plan the next leg."""
        p = self.params
        turned = self.heading_turned
        self.feedback_message = f"yaw sweep {math.degrees(turned):.0f}° of {math.degrees(p.sweep_angle):.0f}°"
        if turned >= p.sweep_angle:
            self.replan_at = math.inf
            return go(self.Phase.PLAN, event=None)
        tick.yaw_rate = min(p.sweep_rate, 2.0 * (p.sweep_angle - turned) + 0.05)
        return Status.RUNNING

    def _step_catch_up(self, tick: _Tick) -> Status | Transition:
        """The leash commands the catch-up flight (:meth:`leash`); well inside the leash again, plan anew."""
        if float(np.linalg.norm(tick.xy - tick.carrier_xy)) < tick.radius - SOFT_ZONE - 0.5:
            self.replan_at = math.inf
            return go(self.Phase.PLAN, event=None)
        return Status.RUNNING

    def plan(self, xy: np.ndarray, carrier_xy: np.ndarray, radius: float) -> Transition | None:
        """Choose the next goal, plan the path there and cut it at D_e (the leg flown at once); or head back to the
        carrier. ``None`` while there is nothing to fly to."""
        p = self.params
        # goals inside the leash disc now and where the carrier will be by the end of the next sweep
        horizon = p.D_e / p.speed + p.sweep_angle / p.sweep_rate
        ahead = carrier_xy + self.carrier_velocity[:2] * horizon
        allowed = self.map.disc(carrier_xy, radius - SOFT_ZONE) & self.map.disc(ahead, radius - SOFT_ZONE)
        if not allowed.any():
            allowed = self.map.disc(ahead, radius - SOFT_ZONE)
        passable = self.map.disc(carrier_xy, radius) | allowed | self.map.disc(xy, 1.0)
        start = self.map.nearest_free(xy, passable)
        self.replan_at = self.now + 2.0
        if start is None:
            self.feedback_message = "no free cell near the UAV"
            return None
        distance, parent = geodesic(self.map, start, passable)
        target_cells = self.target_cells(carrier_xy, radius)
        self.write_coverage(target_cells)
        excluded = np.zeros(self.map.shape, dtype=bool)
        for stop in self.stops[-20:]:  # not back to where the last stops already looked
            excluded |= self.map.disc(stop, 1.0)
        goal = next_goal(
            self.map, np.where(allowed, distance, np.inf), target_cells & ~self.seen, 2.0, 2.0 * p.D_e, excluded
        )
        if goal is None:  # nothing left to survey within reach: stay close to the carrier
            near = self.map.disc(carrier_xy, 1.5) & np.isfinite(distance)
            if not near.any() or self.map.disc(xy, 2.0)[self.map.index(carrier_xy)]:
                self.feedback_message = "area surveyed: holding near the carrier"
                return None
            goal = min(map(tuple, np.argwhere(near)), key=lambda c: distance[c])
        cells = shortcut(self.map, grid_path(self.map, parent, goal))
        points = np.vstack(
            [xy] + [self.map.point(c) for c in cells[1:]] if len(cells) > 1 else [xy, self.map.point(goal)]
        )
        self.waypoints = truncate(points, p.D_e - self.flown if self.flown < p.D_e else p.D_e)
        goal_xy, stop_xy = self.map.point(goal), self.waypoints[-1]
        return go(self.Phase.FLY, at_once=True, goal=[round(float(v), 2) for v in goal_xy],
                  to=[round(float(v), 2) for v in stop_xy])

    def follow(self, xy: np.ndarray) -> tuple[np.ndarray, bool]:
        """Velocity along the way-points (m/s, world) braking onto the last one; whether it is reached."""
        p = self.params
        while len(self.waypoints) > 2 and np.linalg.norm(self.waypoints[1] - xy) < 0.3:
            self.waypoints = self.waypoints[1:]  # passed a corner of the path
        target = self.waypoints[1] if len(self.waypoints) > 1 else self.waypoints[0]
        to_end = float(np.linalg.norm(self.waypoints[-1] - xy))
        direction = target - xy
        norm = float(np.linalg.norm(direction))
        self.feedback_message = f"flying, {to_end:.1f} m to the next stop ({self.flown:.1f} m since the last)"
        if to_end < 0.1:
            return np.zeros(2), True
        speed = min(p.speed, math.sqrt(2.0 * 1.5 * to_end), 1.5 * to_end + 0.05)
        return direction / max(norm, 1e-9) * speed, False

    def start_sweep(self, xy: np.ndarray) -> Transition:
        """Stop here for a yaw sweep (recorded as a ``sweep`` phase with the distance flown since the last stop)."""
        sweep = go(self.Phase.SWEEP, position=[round(float(v), 3) for v in xy], flown=round(self.flown, 3))
        self.stops.append(xy.copy())
        self.flown, self.heading_turned = 0.0, 0.0
        return sweep

    # -------------------------------------------------------- constraints
    def leash_radius(self, z: float, carrier_z: float) -> float:
        """Horizontal distance (m) to the carrier the UAV is held within.

        D_team − margin, less the height difference.
        """
        p = self.params
        limit = p.D_team - p.leash_margin
        dz = z - carrier_z
        return math.sqrt(max(limit**2 - dz**2, 0.0))

    def leash(self, v_xy: np.ndarray, xy: np.ndarray, carrier_xy: np.ndarray, radius: float) -> np.ndarray:
        """``v_xy`` blended, over the last ``SOFT_ZONE`` m inside ``radius``, into a catch-up flight toward the carrier.

        The catch-up velocity follows the free path to the carrier (never
        straight through a wall) at the carrier's speed + 0.5 m/s (at least
        ``speed``). Fully blended, the phase becomes ``catch_up`` whatever it
        was (a sweep or a leg is abandoned; the one transition made outside
        the phase methods, after the phase's command) until the UAV is back
        ``SOFT_ZONE`` + 0.5 m inside (:meth:`_step_catch_up`).
        """
        d = float(np.linalg.norm(xy - carrier_xy))
        fade = float(np.clip((d - (radius - SOFT_ZONE)) / SOFT_ZONE, 0.0, 1.0))
        catching_up = self.phase is self.Phase.CATCH_UP
        if fade <= 0.0 and not catching_up:
            return v_xy
        v_carrier = float(np.linalg.norm(self.carrier_velocity[:2]))
        v_catch = self.path_direction(xy, carrier_xy) * max(self.params.speed, v_carrier + 0.5)
        if fade >= 1.0 and not catching_up:
            self.enter(go(self.Phase.CATCH_UP, distance=round(d, 3)))
        if self.phase is self.Phase.CATCH_UP:
            self.feedback_message = f"catching up with {self.params.carrier}: {d:.1f} m away"
            return v_catch
        return (1.0 - fade) * v_xy + fade * v_catch

    def path_direction(self, xy: np.ndarray, carrier_xy: np.ndarray) -> np.ndarray:
        """Unit vector (world) along the free grid path from the UAV to the carrier (refreshed every 0.5 s)."""
        if self.now < self.catch_up_until:
            return self.catch_up_direction
        self.catch_up_until = self.now + 0.5
        reach = float(np.linalg.norm(xy - carrier_xy)) + 2.0
        allowed = self.map.disc(carrier_xy, reach)
        start = self.map.nearest_free(carrier_xy, allowed)
        uav_cell = self.map.nearest_free(xy, allowed & self.map.disc(xy, 1.0))
        direction = carrier_xy - xy
        if start is not None and uav_cell is not None:
            _, parent = geodesic(self.map, start, allowed)
            cells = shortcut(self.map, grid_path(self.map, parent, uav_cell)[::-1])
            if len(cells) > 1:
                direction = self.map.point(cells[1]) - xy
        self.catch_up_direction = direction / max(float(np.linalg.norm(direction)), 1e-9)
        return self.catch_up_direction

    # ------------------------------------------------------------ sensing
    def target_cells(self, carrier_xy: np.ndarray, radius: float) -> np.ndarray:
        """Cells of the survey area within the leash disc and reachable inside it from the carrier."""
        allowed = self.map.disc(carrier_xy, radius)
        start = self.map.nearest_free(carrier_xy, allowed)
        if start is None:
            return np.zeros(self.map.shape, dtype=bool)
        distance, _ = geodesic(self.map, start, allowed)
        return self.map.area & np.isfinite(distance)

    def write_coverage(self, target_cells: np.ndarray) -> None:
        total = int(target_cells.sum())
        coverage = float((target_cells & self.seen).sum() / total) if total else 1.0
        self.write(self.params.coverage_key, coverage)
        self.context.metric("coverage", coverage, robot=self.robot_name)

    def look(self) -> None:
        """Survey with the front camera's latest frame: mark the cells in its view of the plan, look for the target.

        The camera pose is the UAV's estimate at the frame's stamp (a late
        frame was taken earlier; :class:`~marsupial.sensing.EstimateHistory`)
        composed with the camera's mount.
        """
        reading = self.camera.read()
        if reading is None:
            return
        p = self.params
        frame = reading.data
        body = self.history.at(reading.stamp)
        if body is None:  # no estimate yet
            return
        position, R_nav_optical = in_nav_frame(body, self.camera_mount)
        bearings = view_bearings(frame.K, frame.rgb.shape[1], R_nav_optical)
        ranges = plan_ranges(self.map, position[:2], bearings, p.view_range)
        self.seen |= visible_cells(self.map, position[:2], bearings, ranges, p.view_range)
        if self.found or p.target is None:
            return
        blob = detect_colour(frame.rgb, p.target_rgb, p.target_pixels)
        if blob is None:
            return
        point = floor_point(frame.K, position, R_nav_optical, blob.bottom)
        if point is None or float(np.linalg.norm(point[:2] - position[:2])) > p.target_range:
            return
        self.found = True
        self.write(p.target_key, True)
        phase_event(
            self,
            "target_found",
            target=p.target,
            at=[round(float(v), 2) for v in point[:2]],
            uav=[round(float(v), 2) for v in position],
            pixels=blob.area,
        )
        self.context.metric("target_found", 1.0, robot=self.robot_name)
        milestone(self, f"found {p.target}", detail=f"at ({point[0]:.1f}, {point[1]:.1f}) m")
