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

It knows only what the UAV's computer has (the sensing boundary): the
UAV's onboard interface (bottom camera, sonar, IMU, state estimate, URDF
mounts, flight limits), the platform's size as a static prior (the
``platform_size`` of the team member carrying it), and the simulated time.

Per tick (:meth:`TrackingModule.update`, once per tick whoever asks first)
it reads the sonar (height above the platform, ``p_z`` of the gains and
``Z`` of eq. (3)), the IMU's sample queue (horizontal specific force for the
touchdown test, :mod:`.touchdown`), the state estimate, which it keeps for
a second (:class:`StampedHistory`), and, when a camera frame is of use, the
camera. Frames arrive late (the AR.Drone 2's video ≈ 0.1 s): each is posed
with the estimate and the sonar range nearest its stamp, i.e. the camera's
pose when it was taken, ``T_nav_cam = T_nav_base(estimate) T_base_link
(URDF) T_link_optical``. A located platform (``P_nav = T_nav_cam P_cam``,
§3.3.2: the centroid's ray met with the platform's plane, exact for a
tilted camera too) feeds the tracker. The loss clock counts from the
arrival of the last position, "more than 0.5 s without getting a new
position" (§3.1), not from its capture: a late video is not a lost
platform. World-frame quantities of the paper
are in the estimate's navigation frame: the estimate drifts, but platform
and UAV positions are both taken in it, so the drift cancels in their
difference. Frames are discarded beyond a tilt of 25° (the authors' node:
10°, as their ``P_body`` assumed a level camera): up to the sonar's 15°
half-cone its first echo is the vertical height, 10° beyond it within
1.5 %, so the plane is known, and a UAV leaning into 3 m/s gusts (up to
≈20°) keeps its measurements. A frame whose red fills most of the view
shows the platform right below without locating it (the 1 m platform
covers the whole QVGA view below ≈1 m): it counts as seen for the loss
test; the reactive controller, which has nothing but its latest
measurement, takes it as the platform under the image centre (the paper's
centroid of the visible part), the predictive one extrapolates its filter.

With the velocity feed-forward (ours), the filter follows the estimate's
frame when the optical flow changes between floor and platform
(:mod:`.flowframe`): low over the platform the flow measures the velocity
relative to it, and the platform is nearly still in the estimate's frame.

The tracking errors against ground truth are the run's referee's
(``world/scoring.py``), not the module's. Positions m, velocities m/s,
angles rad, times simulated s.
"""

from __future__ import annotations

import math
from bisect import bisect_left
from collections import deque
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Generic, TypeVar, cast

import cv2
import numpy as np

from marsupial.api.capabilities import HasPlatform
from marsupial.api.errors import UnknownNameError
from marsupial.geometry import heading_rotation, rotation_matrix, yaw_of

from .control import PIGains, PlatformTracker
from .detection import DetectionParams, detect_platform, tilt_of
from .flowframe import FrameShift, flow_surface
from .prediction import KalmanParams

if TYPE_CHECKING:
    from marsupial.trees.skill import MissionNode, RunContext

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
FILLS_VIEW = 0.5  # fraction of red pixels from which a frame shows the platform right below
TILT_BEYOND_CONE_DEG = 10.0  # frames are used up to this tilt beyond the sonar's half-cone (cos 10° = 0.985)
HISTORY_S = 1.0  # s of estimates and sonar ranges kept to pose late camera frames

T = TypeVar("T")


class StampedHistory(Generic[T]):
    """The last ``span_s`` seconds of time-stamped values, to find the one taken nearest a given time.

    Values are added in time order (a value with the stamp of the newest
    replaces it); :meth:`nearest` returns the value whose stamp is closest.
    """

    def __init__(self, span_s: float = HISTORY_S):
        self.span_s = span_s
        self._stamps: deque[float] = deque()
        self._values: deque[T] = deque()

    def add(self, stamp: float, value: T) -> None:
        """Record ``value`` taken at ``stamp`` (s); older entries than the span are dropped."""
        if self._stamps and stamp <= self._stamps[-1]:
            if stamp < self._stamps[-1]:
                return  # out of order: keep the newer one
            self._values[-1] = value
            return
        self._stamps.append(stamp)
        self._values.append(value)
        while self._stamps[0] < stamp - self.span_s:
            self._stamps.popleft()
            self._values.popleft()

    def nearest(self, stamp: float) -> T | None:
        """The value taken nearest ``stamp`` (s), ``None`` while empty."""
        if not self._stamps:
            return None
        i = bisect_left(self._stamps, stamp)
        if i == len(self._stamps) or (i > 0 and stamp - self._stamps[i - 1] <= self._stamps[i] - stamp):
            i -= 1
        return self._values[i]


@dataclass(frozen=True)
class TrackerConfig:
    """How the tracker is built: controller mode, gain schedule, feed-forward, path time (§3.3)."""

    mode: str = "predictive"
    gain_schedule: str = "table1"
    velocity_feedforward: bool = True
    path_time_s: float = 0.0
    integral_band: float | None = None

    def build(self, max_speed: float) -> PlatformTracker:
        """A fresh :class:`PlatformTracker` with this configuration, commands limited to ``max_speed`` (m/s)."""
        if self.gain_schedule not in GAIN_SCHEDULES:
            raise UnknownNameError("gain schedule", self.gain_schedule, GAIN_SCHEDULES)
        return PlatformTracker(
            self.mode,
            GAIN_SCHEDULES[self.gain_schedule],
            KalmanParams(path_time_s=self.path_time_s),
            max_speed=max_speed,
            velocity_feedforward=self.velocity_feedforward,
            integral_band=self.integral_band,
        )


@dataclass(frozen=True)
class CameraPose:
    """Where a camera frame was taken, from the UAV's estimate at its stamp (navigation frame).

    Attributes:
        position: optical centre (m).
        rotation: ``R_nav_optical`` (OpenCV optical frame: x right, y down, z along the axis).
        z_plane: height (m) of the plane the sonar saw (the platform's top, or the ground).
        uav_position: the UAV base's estimated position (m).
        yaw: the UAV's estimated heading (rad).
        tilt: the UAV's estimated tilt (rad), see :func:`.detection.tilt_of`.
    """

    position: np.ndarray
    rotation: np.ndarray
    z_plane: float
    uav_position: np.ndarray
    yaw: float
    tilt: float

    @property
    def height(self) -> float:
        """``Z`` of eq. (3): the plane's distance along the optical axis (m)."""
        return (float(self.position[2]) - self.z_plane) / max(-float(self.rotation[2, 2]), 1e-3)

    def on_plane(self, K: np.ndarray, pixel: np.ndarray) -> np.ndarray:
        """Point (m, navigation frame) where the ray of ``pixel`` (px) meets the plane ``z = z_plane``.

        The inverse pinhole model of eq. (3) taken with the camera's full
        pose (``P_nav = T_nav_cam P_cam``, §3.3.2): for a level camera it is
        eq. (3) with ``Z`` the height; for a tilted one it stays exact.
        """
        ray = self.rotation @ np.array([(pixel[0] - K[0, 2]) / K[0, 0], (pixel[1] - K[1, 2]) / K[1, 1], 1.0])
        depth = (self.z_plane - float(self.position[2])) / min(float(ray[2]), -1e-3)
        return self.position + depth * ray


class TrackingModule:
    """Detection, tracker, loss clock and state machine of one UAV landing on one moving platform.

    Args:
        uav: the UAV's onboard interface (read only here: sensors ``bottom_camera``, ``sonar`` and
            ``imu``, ``estimate()``, ``link_offset()``, ``limits``); the skills command it.
        platform_size: length and width (m) of the landing platform, a static prior (the platform
            robot's model): it completes views cut by the image border.
        context: the run (time, events).
    """

    def __init__(self, uav: Any, platform_size: tuple[float, float], context: RunContext):
        self.uav = uav
        self.context = context
        self.camera = uav.sensor("bottom_camera")
        self.sonar = uav.sensor("sonar")
        self.imu = uav.sensor("imu")
        self.flow_half_angle = float(uav.sensor("flow").half_angle)  # static fact of the flow field (rad)
        # the camera's mount in the base frame, from the URDF: T_base_optical = T_base_link T_link_optical
        p_link, R_link = uav.link_offset("camera_bottom")
        self._p_base_camera = np.asarray(p_link) + np.asarray(R_link) @ np.asarray(self.camera.offset)
        self._R_base_camera = np.asarray(R_link) @ np.asarray(self.camera.R_link_optical)
        self._p_base_sonar = np.asarray(self.sonar.offset, dtype=float)
        self._max_speed = float(uav.limits.max_speed_xy)
        side = float(platform_size[0])
        self._half_side = 0.5 * min(float(platform_size[0]), float(platform_size[1]))
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
        self.last_seen: float | None = None  # loss clock (s): when the last position arrived
        self.pending_relocalization: str | None = None  # why, while a re-localisation is due
        self.relocalizations = 0
        self.offset: np.ndarray | None = None  # last located platform - UAV, heading frame (m), from onboard data
        self.offset_at = -math.inf  # when it arrived (s)
        self.offset_height = math.inf  # sonar height when it was measured (m)
        self.located = 0  # frames that located the platform
        self.platform_yaw: float | None = None  # platform heading from the last located frame (rad, modulo π/2)
        self.frame_shift = FrameShift()  # the estimate frame's velocity change when the flow changes surfaces
        self._flow_on_platform_since: float | None = None  # since when the flow is predicted on the platform (s)
        self._located_at_takeoff = 0
        self.height = math.inf  # newest sonar range (m)
        self.estimate: Any = None  # newest onboard StateEstimate (navigation frame), None before the first update
        self.imu_samples: list[tuple[float, np.ndarray]] = []  # (stamp s, specific force m/s²) since the last tick
        self._imu_stamp = -math.inf
        self._estimates: StampedHistory[Any] = StampedHistory()  # StateEstimates by stamp
        self._heights: StampedHistory[float] = StampedHistory()
        self._updated_at = -math.inf
        self._requested_at = -math.inf  # last time the camera was read (s)
        self._frame_stamp = -math.inf

    @property
    def now(self) -> float:
        """Simulated time (s)."""
        return self.context.now

    # ------------------------------------------------------------ sensing
    def update(self) -> None:
        """Read the sensors and the estimate once per tick (later calls in the same tick return at once)."""
        now = self.now
        if now == self._updated_at:
            return
        self._updated_at = now
        self.estimate = self.uav.estimate()
        self._estimates.add(self.estimate.stamp, self.estimate)
        sonar = self.sonar.read()
        if sonar is not None:
            self.height = float(sonar.data.range)
            self._heights.add(sonar.stamp, self.height)
        self.imu_samples = [(r.stamp, r.data.linear_acceleration) for r in self.imu.read_since(self._imu_stamp)]
        if self.imu_samples:
            self._imu_stamp = self.imu_samples[-1][0]
        self._follow_flow_frame()
        if self._frame_wanted(now):
            self._requested_at = now
            reading = self.camera.read()
            if reading is not None and reading.stamp > self._frame_stamp:
                self._frame_stamp = reading.stamp
                self._look(reading.stamp, reading.data)
        if self.state in FLYING and self.last_seen is None and self.height >= self.acquire_height:
            self.last_seen = now

    def _follow_flow_frame(self) -> None:
        """Carry the estimate frame's velocity change into the filter while the flow changes surfaces (our departure).

        See :mod:`.flowframe`: near the height where the flow's median ray
        switches between floor and platform (predicted from the filter's
        platform, the platform's heading from the detections, the sonar
        height and the flow field's half-angle), the part of the estimated
        velocity's change that the flow made is added to the platform's
        velocity in the filter; once the flow has been predicted on the
        platform for the estimator's transition time, the platform is still
        in the frame and the filter's velocity is held at zero. With the
        velocity feed-forward only (the paper's controller has neither).
        """
        estimate, tracker = self.estimate, self.tracker
        R = rotation_matrix(estimate.orientation)
        on_platform = switching = False
        if tracker is not None and self.state in FLYING and math.isfinite(self.height):
            predictor = tracker.predictor
            if predictor.stamp is not None:
                platform_xy = predictor.filter.position + predictor.filter.velocity * (self.now - predictor.stamp)
                origin = np.asarray(estimate.position, dtype=float) + R @ self._p_base_sonar  # flow: the sonar's origin
                yaw = yaw_of(estimate.orientation) if self.platform_yaw is None else self.platform_yaw
                on_platform, switching = flow_surface(
                    self.flow_half_angle, R, origin[:2], self.height, platform_xy, yaw, self._half_side
                )
        shift = self.frame_shift.step(estimate.stamp, estimate.velocity[:2], R, self.imu_samples, switching)
        if not on_platform:
            self._flow_on_platform_since = None
        elif self._flow_on_platform_since is None:
            self._flow_on_platform_since = estimate.stamp
        if tracker is None or not tracker.velocity_feedforward:
            return
        since = self._flow_on_platform_since
        if since is not None and estimate.stamp - since >= self.frame_shift.settle_s:
            tracker.predictor.shift_velocity(-tracker.predictor.filter.velocity)  # the frame rides the platform
        elif shift[0] or shift[1]:
            tracker.predictor.shift_velocity(shift)

    def _frame_wanted(self, now: float) -> bool:
        """Whether to read the camera now (a read makes the camera take a frame, delivered after its latency).

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
        return now - self._requested_at >= tracker.predictor.params.step_s - 1e-6

    def camera_pose(self, stamp: float) -> CameraPose | None:
        """The camera's pose when it took the frame stamped ``stamp`` (s): estimate and sonar nearest it.

        ``None`` without an estimate or a finite sonar range.
        """
        estimate, height = self._estimates.nearest(stamp), self._heights.nearest(stamp)
        if estimate is None or height is None or not math.isfinite(height):
            return None
        p, R = np.asarray(estimate.position, dtype=float), rotation_matrix(estimate.orientation)
        z_plane = float((p + R @ self._p_base_sonar)[2]) - height
        return CameraPose(
            p + R @ self._p_base_camera,
            R @ self._R_base_camera,
            z_plane,
            p,
            yaw_of(estimate.orientation),
            tilt_of(estimate.orientation),
        )

    def _look(self, stamp: float, frame: Any) -> None:
        """Run Algorithm 1 on one frame (a ``CameraImage``); a located platform feeds the tracker."""
        pose = self.camera_pose(stamp)
        if pose is None:
            return
        detection = detect_platform(frame.rgb, frame.K, pose.height, pose.tilt, self.detection_params)
        if detection is None:
            if pose.tilt <= self.detection_params.max_tilt and self._fills_view(frame.rgb):
                self.last_seen = self.now  # right below the camera, not located
                if self.tracker is not None and self.tracker.mode == "reactive":
                    # the reactive controller has only its latest measurement: an all-red view puts the
                    # platform's centroid at the image centre (the paper's centroid of the visible part)
                    self.tracker.observe(stamp, pose.on_plane(frame.K, frame.K[:2, 2]))
            return
        p_nav = pose.on_plane(frame.K, detection.centroid_px)  # P_nav = T_nav_cam P_cam
        if self.tracker is not None:
            self.tracker.observe(stamp, p_nav)
        self.offset = heading_rotation(pose.yaw) @ (p_nav[:2] - pose.uav_position[:2])
        self.offset_at, self.offset_height = self.now, cast(float, self._heights.nearest(stamp))  # camera_pose had one
        self.platform_yaw = self._heading_of(detection.polygon, frame.K, pose.rotation)
        self.last_seen = self.now
        self.located += 1

    @staticmethod
    def _heading_of(polygon: np.ndarray, K: np.ndarray, R_nav_optical: np.ndarray) -> float:
        """Heading (rad, navigation frame, modulo π/2) of a square platform's sides in a frame."""
        angle = math.radians(cv2.minAreaRect(np.asarray(polygon, dtype=np.float32))[2])
        side = R_nav_optical @ np.array([math.cos(angle) / K[0, 0], math.sin(angle) / K[1, 1], 0.0])
        return math.atan2(float(side[1]), float(side[0])) % (math.pi / 2)

    def _fills_view(self, rgb: np.ndarray) -> bool:
        """Whether the platform's red covers most of the frame (the platform is right below)."""
        p = self.detection_params
        hsv = cv2.cvtColor(np.ascontiguousarray(rgb[::4, ::4]), cv2.COLOR_RGB2HSV)  # a 1/16 sample is plenty
        red = cv2.countNonZero(cv2.inRange(hsv, p.red_low, p.red_high))
        red += cv2.countNonZero(cv2.inRange(hsv, p.red_wrap_low, p.red_wrap_high))
        return red >= FILLS_VIEW * hsv.shape[0] * hsv.shape[1]

    # ------------------------------------------------------------ control
    def configure(self, config: TrackerConfig) -> None:
        """Use a tracker with ``config``: the present one if it matches, else a new one."""
        if self.tracker is None or config != self.config:
            self.config, self.tracker = config, config.build(self._max_speed)

    def command(self) -> np.ndarray:
        """Horizontal velocity command ``[v_x, v_y]`` (m/s, heading frame of the estimated yaw) of the tracker now."""
        assert self.tracker is not None and self.estimate is not None, "configure() and update() before commanding"
        estimate = self.estimate
        return self.tracker.command(self.now, estimate.position, yaw_of(estimate.orientation), self.height)

    # -------------------------------------------------------------- states
    def set_state(self, state: str, node: MissionNode, why: str = "") -> None:
        """Enter ``state`` (one of :data:`STATES`) and record it as a ``state_change`` event."""
        if state == self.state:
            return
        previous, self.state = self.state, state
        self.context.event("state_change", node=node.name, robot=self.uav.name, state=state, previous=previous, why=why)

    def begin_flight(self, config: TrackerConfig, node: MissionNode) -> None:
        """Take-off from the platform: new tracker, loss clock stopped, no re-localisation due.

        With the velocity feed-forward, the filter starts from the platform's
        state the UAV rides on, as its own estimate has it (position and
        velocity), so that the UAV leaves a moving platform without falling
        behind; otherwise the tracker starts empty, as the paper's.
        """
        self.update()
        now = self.now
        self.config, self.tracker = config, config.build(self._max_speed)
        if config.velocity_feedforward and self.estimate is not None:
            estimate = self.estimate
            self.tracker.predictor.start(now, estimate.position[:2], estimate.velocity[:2])
        self.flight_start, self.tracking_start, self.last_seen = now, None, None
        self._located_at_takeoff = self.located
        self.pending_relocalization = None
        self.offset, self.offset_at = None, -math.inf
        self.set_state("taking_off", node)

    def relocalization_due(self, unseen_s: float, max_error: float, final_height: float) -> str | None:
        """Why a re-localisation is due (§3.1, recovery module), ``None`` if it is not; latched once due.

        Due when the platform has been unseen for more than ``unseen_s``, or,
        below ``final_height`` (sonar), the latest location (arrived within
        ``unseen_s``) puts it more than ``max_error`` away horizontally. The
        test is on the UAV's height now, not only the height the location was
        taken at: the 1 m platform fills the view below ≈0.72 m, so the last
        location comes from just above 0.7 m and the paper's abort would
        otherwise never fire.
        """
        if self.state not in FLYING:
            return None
        if self.pending_relocalization is None:
            now = self.now
            if self.last_seen is not None and now - self.last_seen > unseen_s + 1e-9:
                self.pending_relocalization = f"platform unseen for {now - self.last_seen:.2f} s"
            elif (
                self.offset is not None
                and min(self.height, self.offset_height) < final_height
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


def platform_size(node: MissionNode, name: str | None) -> tuple[float, float]:
    """Size (m) of the landing platform: that of team member ``name``, or of the team's only member with one.

    A static prior (the platform robot's model, ``HasPlatform.platform_size``).
    Raises ``UnknownNameError`` / ``ValueError`` naming the candidates.
    """
    context = node.context
    carriers = {n: port for n in context.team() if (port := node.member(n)).provides(HasPlatform)}
    if name is not None:
        if name not in carriers:
            raise UnknownNameError("robot with a landing platform", name, carriers)
        return carriers[name].platform_size
    if len(carriers) != 1:
        raise ValueError(
            f"cannot tell which robot carries the landing platform ({', '.join(carriers) or 'none'}); "
            "expected exactly one (e.g. a summit_xl) or the skill parameter 'platform' naming it"
        )
    return next(iter(carriers.values())).platform_size


def tracking_module(node: MissionNode, platform: str | None) -> TrackingModule:
    """The tracking module of ``node``'s robot from the blackboard (``<robot>/tracking``), created on first use."""
    key = f"{node.robot_name}/tracking"
    module = node.read(key)
    if module is None:
        module = TrackingModule(node.robot, platform_size(node, platform), node.context)
        node.write(key, module)
    return module
