"""The tracking module of Palafox et al. (2019): what the landing skills of one UAV share (§3.1–3.3).

Take-off, tracking, landing and re-localisation are separate skills, but the
paper's tracking module runs through all of them: the detection of the
platform in every camera frame (Algorithm 1, §3.2), the tracker that turns
it into velocity commands (§3.3), the time the platform was last seen and
the state of the five-state machine (§3.1). One :class:`TrackingModule` per
UAV holds them; the skills and conditions of :mod:`.skills` and
:mod:`.conditions` find it on the blackboard under ``<uav>/tracking``
(:func:`tracking_module`), so the filter and the PI integral carry over from
one skill to the next.

Per tick (:meth:`TrackingModule.update`, once per simulated time step
whoever asks first) it reads the sonar (height above the platform, ``p_z``
of the gains and ``Z`` of eq. (3)), the IMU (tilt for discarding frames,
horizontal specific force for the landed test) and, when the 30 Hz camera
has a new frame, runs the detection. A located platform (world frame,
``P_world = T_world_cam P_cam``, §3.3.2: the centroid's ray met with the
platform's plane, exact for a tilted camera too) feeds the tracker. Frames
are discarded beyond a tilt of 25° (the authors' node: 10°, as their
``P_body`` assumed a level camera): up to the sonar's 15° half-cone its
first echo is the vertical height, 10° beyond it within 1.5 %, so the
plane is known, and a UAV leaning into 3 m/s gusts (up to ≈20°) keeps its
measurements. A frame whose
red fills most of the view shows the platform right below without locating
it (the 1 m platform covers the whole QVGA view below ≈1 m): it counts as
seen for the loss test; the reactive controller, which has nothing but its
latest measurement, takes it as the platform under the image centre (the
paper's centroid of the visible part), the predictive one extrapolates its
filter.

Ground truth for the metrics (never for control): the platform robot's
``platform_pose()``; errors are the platform centre relative to the UAV in
its heading frame (x forward, y left), as the paper reports them (§4.2.1).
Positions m, velocities m/s, angles rad, times simulated s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np

from marsupial.world.errors import UnknownNameError
from marsupial.world.robots.base import rotation_matrix, yaw_of

from .control import PIGains, PlatformTracker
from .detection import DetectionParams, detect_platform, tilt_of
from .prediction import KalmanParams

if TYPE_CHECKING:
    from marsupial.trees.skill import MissionNode, RunContext
    from marsupial.world import World

#: gain schedules ``K = Q·exp(-T·p_z)`` selectable by name (see :mod:`.control`)
GAIN_SCHEDULES: dict[str, PIGains] = {
    # the printed law K_p = 0.7 e^(-0.002 p_z), K_i = 0.2 e^(-0.002 p_z) with p_z in metres:
    # it reproduces Table 1 (0.694 / 0.198 at 4 m, 0.697 / 0.199 at 2 m), §3.3.1
    "table1": PIGains(T_p=0.002, T_i=0.002),
    # T fitted to the authors' manual trackbar values K_p = 0.45, K_i = 0.1 at 4 m
    "manual_fit": PIGains(),
}
#: the five states of the paper's state machine (§3.1, Fig. 2)
STATES = ("landed", "taking_off", "tracking", "landing", "relocalizing")
FLYING = frozenset(STATES) - {"landed"}
METRIC_PERIOD_S = 0.1  # s between ground-truth error samples in the log
FILLS_VIEW = 0.5  # fraction of red pixels from which a frame shows the platform right below
TILT_BEYOND_CONE_DEG = 10.0  # frames are used up to this tilt beyond the sonar's half-cone (cos 10° = 0.985)


@dataclass(frozen=True)
class TrackerConfig:
    """How the tracker is built: controller mode, gain schedule, feed-forward, path time (§3.3)."""

    mode: str = "predictive"
    gain_schedule: str = "table1"
    velocity_feedforward: bool = True
    path_time_s: float = 0.0
    integral_band: float | None = None

    def build(self) -> PlatformTracker:
        """A fresh :class:`PlatformTracker` with this configuration."""
        if self.gain_schedule not in GAIN_SCHEDULES:
            raise UnknownNameError("gain schedule", self.gain_schedule, GAIN_SCHEDULES)
        return PlatformTracker(
            self.mode,
            GAIN_SCHEDULES[self.gain_schedule],
            KalmanParams(path_time_s=self.path_time_s),
            velocity_feedforward=self.velocity_feedforward,
            integral_band=self.integral_band,
        )


class TrackingModule:
    """Detection, tracker, loss clock and state machine of one UAV landing on one moving platform.

    Args:
        world: the run's world.
        uav: the quadrotor (read only: sensors and pose).
        platform: the robot carrying the landing platform (``platform_pose()``,
            ``platform_size``): its size completes views cut by the image
            border; its pose is ground truth for the metrics only.
        context: the run (events and metrics).
    """

    def __init__(self, world: World, uav: Any, platform: Any, context: RunContext):
        self.world = world
        self.uav = uav
        self.platform = platform
        self.context = context
        self.camera = uav.sensor("bottom_camera")
        self.sonar = uav.sensor("sonar")
        self.imu = uav.sensor("imu")
        side = float(platform.platform_size[0])
        # frames are used while the sonar's first echo gives the height within 1.5 % (cone half-angle + 10°)
        max_tilt = float(self.sonar.half_angle) + math.radians(TILT_BEYOND_CONE_DEG)
        self.detection_params = DetectionParams(platform_side_m=side, max_tilt=max_tilt)
        f, intrinsics = self.camera.K[1, 1], self.camera.intrinsics
        # the loss clock starts at the first detection of a flight, or once the whole platform fits the view
        self.acquire_height = side * f / min(intrinsics.width, intrinsics.height)
        # below this, a UAV over the platform's centre sees no side of it: frames of the take-off are of no use
        self.first_side_height = side * f / max(intrinsics.width, intrinsics.height)
        self.config: TrackerConfig | None = None
        self.tracker: PlatformTracker | None = None
        self.state = "landed"
        self.flight_start: float | None = None
        self.tracking_start: float | None = None
        self.last_seen: float | None = None  # loss clock (s)
        self.pending_relocalization: str | None = None  # why, while a re-localisation is due
        self.relocalizations = 0
        self.offset: np.ndarray | None = None  # last located platform - UAV, heading frame (m)
        self.offset_at = -math.inf  # its time (s)
        self.offset_height = math.inf  # sonar height when it was measured (m)
        self.located = 0  # frames that located the platform
        self._located_at_takeoff = 0
        self.height = math.inf  # sonar range (m)
        self.accel_xy = 0.0  # horizontal specific force (m/s², body frame) of the last IMU sample
        self._step = -1
        self._frame_stamp = -math.inf
        self._next_metric = -math.inf

    # ------------------------------------------------------------ sensing
    def update(self) -> None:
        """Read the sensors once per physics step (later calls in the same step return at once)."""
        clock = self.world.clock
        if clock.steps == self._step:
            return
        self._step = clock.steps
        now = clock.now
        sonar = self.sonar.read()
        if sonar is not None:
            self.height = float(sonar.data.range)
        imu = self.imu.read()
        tilt = tilt_of(imu.data.orientation) if imu is not None else 0.0
        if imu is not None:
            self.accel_xy = float(np.hypot(*imu.data.linear_acceleration[:2]))
        reading = self.camera.read() if self._frame_wanted(now) else None
        if reading is not None and reading.stamp > self._frame_stamp:
            self._frame_stamp = reading.stamp
            self._look(reading.stamp, reading.data, tilt)
        if self.state in FLYING:
            if self.last_seen is None and self.height >= self.acquire_height:
                self.last_seen = now
            if now + 1e-9 >= self._next_metric:
                self._next_metric = now + METRIC_PERIOD_S
                error = self.true_offset()
                self.context.metric("tracking_error_x", error[0], robot=self.uav.name)
                self.context.metric("tracking_error_y", error[1], robot=self.uav.name)

    def _frame_wanted(self, now: float) -> bool:
        """Whether a camera frame is of use now.

        The reactive controller and the search for the platform use every
        30 Hz frame. The predictive controller's filter fuses one frame per
        0.1 s step (§3.3.2): between steps a frame would only be thrown away,
        and rendering it is what costs most in a simulated run. Taking off
        from the platform's centre, the view is all red until a side of the
        platform can come into it; frames start there.
        """
        tracker = self.tracker
        if self.state == "taking_off" and self.located == self._located_at_takeoff:
            return self.height >= self.first_side_height
        if tracker is None or tracker.mode == "reactive" or self.state == "relocalizing":
            return True
        stamp = tracker.predictor.stamp
        return stamp is None or now - stamp >= tracker.predictor.params.step_s - 1e-6

    def _look(self, stamp: float, frame: Any, tilt: float) -> None:
        """Run Algorithm 1 on one frame; a located platform feeds the tracker."""
        if not math.isfinite(self.height):
            return
        p_base, q_base = self.uav.pose()
        z_plane = float((p_base + rotation_matrix(q_base) @ np.asarray(self.sonar.offset))[2]) - self.height
        Z = (float(frame.position[2]) - z_plane) / max(-float(frame.rotation[2, 2]), 1e-3)  # along the optical axis
        detection = detect_platform(frame.rgb, frame.K, Z, tilt, self.detection_params)
        if detection is None:
            if tilt <= self.detection_params.max_tilt and self._fills_view(frame.rgb):
                self.last_seen = stamp  # right below the camera, not located
                if self.tracker is not None and self.tracker.mode == "reactive":
                    # the reactive controller has only its latest measurement: an all-red view puts the
                    # platform's centroid at the image centre (the paper's centroid of the visible part)
                    self.tracker.observe(stamp, _on_plane(frame, frame.K[:2, 2], z_plane))
            return
        p_world = _on_plane(frame, detection.centroid_px, z_plane)  # P_world = T_world_cam P_cam
        if self.tracker is not None:
            self.tracker.observe(stamp, p_world)
        p_uav, yaw = self._pose()
        self.offset = _heading(yaw) @ (p_world[:2] - p_uav[:2])
        self.offset_at, self.offset_height = stamp, self.height
        self.last_seen = stamp
        self.located += 1

    def _fills_view(self, rgb: np.ndarray) -> bool:
        """Whether the platform's red covers most of the frame (the platform is right below)."""
        p = self.detection_params
        hsv = cv2.cvtColor(np.ascontiguousarray(rgb[::4, ::4]), cv2.COLOR_RGB2HSV)  # a 1/16 sample is plenty
        red = cv2.countNonZero(cv2.inRange(hsv, p.red_low, p.red_high))
        red += cv2.countNonZero(cv2.inRange(hsv, p.red_wrap_low, p.red_wrap_high))
        return red >= FILLS_VIEW * hsv.shape[0] * hsv.shape[1]

    def _pose(self) -> tuple[np.ndarray, float]:
        p, q = self.uav.pose()
        return p, yaw_of(q)

    def true_offset(self) -> np.ndarray:
        """Ground truth: platform centre minus UAV position in the UAV's heading frame (x, y in m)."""
        p_uav, yaw = self._pose()
        return _heading(yaw) @ (self.platform.platform_pose()[0][:2] - p_uav[:2])

    # ------------------------------------------------------------ control
    def configure(self, config: TrackerConfig) -> None:
        """Use a tracker with ``config``: the present one if it matches, else a new one."""
        if self.tracker is None or config != self.config:
            self.config, self.tracker = config, config.build()

    def command(self) -> np.ndarray:
        """Horizontal velocity command ``[v_x, v_y]`` (m/s, heading frame) of the tracker now."""
        assert self.tracker is not None, "configure() the tracking module before commanding"
        p_uav, yaw = self._pose()
        return self.tracker.command(self.world.now, p_uav, yaw, self.height)

    # -------------------------------------------------------------- states
    def set_state(self, state: str, node: MissionNode, why: str = "") -> None:
        """Enter ``state`` (one of :data:`STATES`) and record it as a ``state_change`` event."""
        if state == self.state:
            return
        previous, self.state = self.state, state
        self.context.event(
            "state_change", node=node.name, robot=self.uav.name, state=state, previous=previous, why=why
        )

    def begin_flight(self, config: TrackerConfig, node: MissionNode) -> None:
        """Take-off from the platform: new tracker, loss clock stopped, no re-localisation due.

        With the velocity feed-forward, the filter starts from the platform's
        state the UAV rides on (its own position and velocity), so that the
        UAV leaves a moving platform without falling behind; otherwise the
        tracker starts empty, as the paper's.
        """
        now = self.world.now
        self.config, self.tracker = config, config.build()
        if config.velocity_feedforward:
            p, _ = self._pose()
            self.tracker.predictor.start(now, p[:2], self.uav.velocity()[0][:2])
        self.flight_start, self.tracking_start, self.last_seen = now, None, None
        self._located_at_takeoff = self.located
        self.pending_relocalization = None
        self.offset, self.offset_at = None, -math.inf
        self._next_metric = -math.inf
        self.set_state("taking_off", node)

    def relocalization_due(self, unseen_s: float, max_error: float, final_height: float) -> str | None:
        """Why a re-localisation is due (§3.1, recovery module), ``None`` if it is not; latched once due.

        Due when the platform has been unseen for more than ``unseen_s``, or a
        location taken below ``final_height`` (sonar) puts it more than
        ``max_error`` away horizontally. It stays due until
        :meth:`end_relocalization`.
        """
        if self.state not in FLYING:
            return None
        if self.pending_relocalization is None:
            now = self.world.now
            if self.last_seen is not None and now - self.last_seen > unseen_s + 1e-9:
                self.pending_relocalization = f"platform unseen for {now - self.last_seen:.2f} s"
            elif (
                self.offset is not None
                and self.offset_height < final_height
                and now - self.offset_at <= unseen_s
                and float(np.hypot(*self.offset)) > max_error
            ):
                self.pending_relocalization = (
                    f"error {float(np.hypot(*self.offset)):.2f} m at {self.offset_height:.2f} m above the platform"
                )
        return self.pending_relocalization

    def end_relocalization(self) -> None:
        """The re-localisation is over: new land commands may be processed again."""
        self.pending_relocalization = None


def _on_plane(frame: Any, pixel: np.ndarray, z_plane: float) -> np.ndarray:
    """World point (m) where the ray of ``pixel`` (px) meets the horizontal plane ``z = z_plane``.

    The inverse pinhole model of eq. (3) taken with the camera's full world
    pose (``P_world = T_world_cam P_cam``, §3.3.2): for a level camera it is
    eq. (3) with ``Z`` the height; for a tilted one it stays exact.
    """
    K = frame.K
    ray_world = frame.rotation @ np.array([(pixel[0] - K[0, 2]) / K[0, 0], (pixel[1] - K[1, 2]) / K[1, 1], 1.0])
    depth = (z_plane - float(frame.position[2])) / min(float(ray_world[2]), -1e-3)
    return frame.position + depth * ray_world


def _heading(yaw: float) -> np.ndarray:
    """``R_heading_world`` (2×2): world x-y into the heading frame of a vehicle with heading ``yaw``."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, s], [-s, c]])


def platform_robot(world: World, name: str | None) -> Any:
    """The robot carrying the landing platform: ``name``, or the world's only robot with one.

    Raises ``UnknownNameError`` / ``ValueError`` naming the candidates.
    """
    carriers = {n: r for n, r in world.robots.items() if hasattr(r, "platform_pose") and hasattr(r, "platform_size")}
    if name is not None:
        if name not in carriers:
            raise UnknownNameError("robot with a landing platform", name, carriers)
        return carriers[name]
    if len(carriers) != 1:
        raise ValueError(
            f"cannot tell which robot carries the landing platform ({', '.join(carriers) or 'none'}); "
            "expected exactly one (e.g. a summit_xl) or the skill parameter 'platform' naming it"
        )
    return next(iter(carriers.values()))


def tracking_module(node: MissionNode, platform: str | None) -> TrackingModule:
    """The tracking module of ``node``'s robot from the blackboard (``<robot>/tracking``), created on first use."""
    key = f"{node.robot_name}/tracking"
    module = node.read(key)
    if module is None:
        world = node.world
        module = TrackingModule(world, world.robot(node.robot_name), platform_robot(world, platform), node.context)
        node.write(key, module)
    return module
