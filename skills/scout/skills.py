"""``scout`` and ``object_found``: the carrier's visually-servoed guidance of a micro-scout until it finds an object.

Arora & Papachristos, §IV-G and §V. The MAV (``robot:``, a Tello) streams its
front camera to the carrier (``carrier``) over the team link (:mod:`.relay`);
the carrier turns each relayed frame into a dense depth map
(:mod:`.depth`, the pluggable ``depth_estimator``), the map into one of
three actions (:mod:`.policy`: forward, clockwise, counter-clockwise, with the
direction ``bias``) and sends the MAV that velocity command back over the
link, as it "remotely guide[s] the MAV"; the MAV flies the newest command it
received (forward in its heading frame at its held height, or a yaw turn) and
hovers when none arrived for ``command_timeout``. The carrier also runs the
pluggable object ``detector`` (:mod:`.detection`) on every relayed frame; an
object of ``object_class`` seen in ``confirm_frames`` successive relayed
frames ends the run (SUCCESS).

What it senses: the MAV's front camera (its JPEG through the link), its state
estimate (the breadcrumbs of its path), and the commands the carrier sends.
Nothing on the carrier is commanded (it only computes).

Blackboard, under the MAV's name: writes ``{robot}/object_found``
(:class:`ObjectSighting`, ``None`` until found) and ``{robot}/scout_path``
(the estimated positions every ``breadcrumb_spacing`` m along the flight,
navigation frame, oldest first: the way back for ``scout_return``). Events: a
``state_change`` with phase ``object_found`` (class, pixel box, frame stamp,
estimated position). Metrics (labelled with the robot): ``scout_frames_sent``,
``scout_frames_received``, ``scout_frames_lost``, ``scout_time_to_find`` (s from the start).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Any, ClassVar

import numpy as np
from py_trees.common import Status
from pydantic import Field, model_validator

from marsupial.api.capabilities import Rotorcraft
from marsupial.trees.metrics import MetricSpec
from marsupial.trees.milestones import milestone
from marsupial.trees.phases import phase_event
from marsupial.trees.skill import Condition, NodeParams, Skill, TeamMember

from .depth import DepthEstimator
from .detection import Detection, ObjectDetector
from .plugins import DEPTH_GROUP, DETECTOR_GROUP, build, resolve
from .policy import CLOCKWISE, COUNTER_CLOCKWISE, FORWARD, decide, velocity_command
from .relay import RelayedFrame, VideoReceiver, VideoSender

COMMAND_TOPIC = "scout_command"
"""Team-link topic of the carrier's guidance commands (payload: :class:`ScoutCommand`)."""
OBJECT_FOUND = "object_found"
"""Blackboard key (under the MAV's name) of the :class:`ObjectSighting` that ended the run."""
SCOUT_PATH = "scout_path"
"""Blackboard key (under the MAV's name) of the breadcrumbs of its path (list of (3,) arrays, m, navigation frame)."""


@dataclass(frozen=True)
class ScoutCommand:
    """A guidance command the carrier sends: its run (the start time, s), forward speed (m/s), yaw rate (rad/s)."""

    run: float
    vx: float
    yaw_rate: float
    action: str


@dataclass(frozen=True)
class ObjectSighting:
    """The object that ended a scout's run: the detection, the relayed frame's stamp and the time found (sim s).

    ``position`` is the MAV's estimated position (m, its navigation frame) when it was found.
    """

    detection: Detection
    frame_stamp: float
    found_at: float
    position: tuple[float, float, float]


class Scout(Skill["Scout.Params"]):
    """Visually-servoed exploration of a micro-scout guided by the carrier, until an object of interest is found."""

    metrics: ClassVar[tuple[MetricSpec, ...]] = (
        MetricSpec("scout_frames_sent", "count", "video frames the scout sent over the relay", "total"),
        MetricSpec("scout_frames_received", "count", "relayed video frames the carrier received", "total"),
        MetricSpec("scout_frames_lost", "count", "relayed video frames lost on the way", "total"),
        MetricSpec("scout_time_to_find", "s", "time from the scout's start to its sighting of the object", "each"),
    )

    class Params(NodeParams):
        carrier: Annotated[str, TeamMember()] = "mms"
        """The team member that receives the video, estimates depth, detects and sends the guidance."""
        object_class: str = "fire_extinguisher"
        """Class of the object of interest that ends the run (the detector's classes)."""
        bias: float = Field(0.0, ge=-1.0, le=1.0)
        """Direction bias b of the action vector (§V): > 0 favours clockwise (right) turns, < 0 counter-clockwise."""
        forward_speed: float = Field(0.4, gt=0.0)
        """Speed of the forward action (m/s)."""
        turn_speed: float = Field(0.0, ge=0.0)
        """Forward speed while turning (m/s); 0: the turns are yaws on the spot."""
        yaw_rate: float = Field(0.6, gt=0.0)
        """Yaw rate of the clockwise and counter-clockwise actions (rad/s)."""
        rows: tuple[float, float] = (0.35, 0.65)
        """Band of image rows averaged, fractions of the height from the top ((0, 1): the whole columns of §IV-G).

        The default, the band around the horizon, keeps the mockup's open top out of the averages: its sky,
        at the network's largest depth, makes every wall lower than the view look deep (docs/scout.md)."""
        jpeg_quality: int = Field(80, ge=1, le=100)
        """JPEG quality of the relayed frames."""
        command_timeout: float = Field(0.5, gt=0.0)
        """The MAV hovers when the newest command it received is older than this (s)."""
        confirm_frames: int = Field(2, ge=1)
        """Successive relayed frames that must show the object before it counts as found."""
        height: float | None = Field(0.7, gt=0.0, le=3.0)
        """Height (m) above the floor the MAV holds on its estimate while it explores (none: the height it had
        at the start). Launched from the apparatus it starts ≈1.1 m up; the objects stand on the floor and
        the Tello's camera looks level, so at that height the extinguisher (0.6 m tall) was missed from the
        hallway's far side (chosen: 0.7 m, the corridor flight of Fig. 5)."""
        stuck_time: float | None = Field(3.0, gt=0.0)
        """Seconds of forward commands during which the MAV's estimate moved less than ``stuck_distance``
        after which it counts as stuck against something and turns away (none: never, as in §IV-G)."""
        stuck_distance: float = Field(0.15, gt=0.0)
        """Distance (m) the estimate must move in ``stuck_time`` of forward commands."""
        unstick_angle: float = Field(1.57, gt=0.0, le=6.3)
        """Yaw (rad) the stuck MAV turns, in the bias's direction (clockwise when ``bias`` ≥ 0)."""
        breadcrumb_spacing: float = Field(0.25, gt=0.0)
        """Distance (m) between the recorded points of the path (``scout_path``)."""
        depth_estimator: str = "monocular_error_model"
        """Depth estimator: a ``marsupial.scout.depth_estimators`` entry-point name or 'package.module:Class'."""
        depth_options: dict[str, Any] = {}
        """Options of the depth estimator (its ``Options``; see docs/scout.md)."""
        detector: str = "hsv_colour"
        """Object detector: a name of the ``marsupial.scout.detectors`` entry points or 'package.module:Class'."""
        detector_options: dict[str, Any] = {}
        """Options of the object detector (its ``Options``; see docs/scout.md)."""

        @model_validator(mode="after")
        def _plugins_exist(self) -> Scout.Params:
            """The plug-ins resolve, their options validate and the detector knows ``object_class``."""
            depth = resolve(DEPTH_GROUP, self.depth_estimator, DepthEstimator)
            depth.Options.model_validate(self.depth_options)
            detector = resolve(DETECTOR_GROUP, self.detector, ObjectDetector)
            detector.Options.model_validate(self.detector_options)
            classes = detector.classes  # type: ignore[attr-defined]
            if classes and self.object_class not in classes:
                raise ValueError(f"detector '{self.detector}' knows no object class '{self.object_class}'; "
                                 f"expected one of {', '.join(classes)}")
            return self

    robot_kinds = (Rotorcraft,)
    sensors = ("front_camera",)
    claims = ("rotors",)
    writes = (f"{{robot}}/{OBJECT_FOUND}", f"{{robot}}/{SCOUT_PATH}")

    def start(self) -> None:
        p, robot = self.params, self.robot_name
        self.robot.set_motors(True)
        self.estimator: DepthEstimator = build(DEPTH_GROUP, p.depth_estimator, DepthEstimator, p.depth_options,
                                               rng=self.context.rng(f"{robot}/scout_depth"))
        self.detector: ObjectDetector = build(DETECTOR_GROUP, p.detector, ObjectDetector, p.detector_options)
        self.camera = self.robot.sensor("front_camera")
        self.sender = VideoSender(self.link, p.jpeg_quality, self.estimator.uses_rendered_depth)
        self.carrier_link = self.link_of(p.carrier)
        self.receiver = VideoReceiver(self.carrier_link, str(robot))
        self.started = self.now
        self.seen = 0
        self.path = [self.robot.estimate().position.copy()]
        self.hold_height = float(self.path[0][2]) if p.height is None else p.height
        self.forward_since: tuple[float, np.ndarray] | None = None  # when the forward commands began, and where
        self.unstick_until = -np.inf
        self.write(f"{robot}/{OBJECT_FOUND}", None)
        self.write(f"{robot}/{SCOUT_PATH}", list(self.path))

    def step(self) -> Status:
        self._fly_newest_command()
        reading = self.camera.read()
        if reading is not None:
            image = reading.data
            self.sender.offer(reading.stamp, image.rgb, image.K, image.depth)
        self._drop_breadcrumb()
        frame = self.receiver.newest()
        if frame is None:
            if self.receiver.received == 0:
                self.feedback_message = "waiting for the first relayed frame"
            return Status.RUNNING
        return self._guide(frame)

    def finish(self, status: Status) -> None:
        robot = self.robot_name
        self.context.metric("scout_frames_sent", self.sender.sent, robot=robot)
        self.context.metric("scout_frames_received", self.receiver.received, robot=robot)
        self.context.metric("scout_frames_lost", self.receiver.lost, robot=robot)
        self.leave_safe()

    # ----------------------------------------------------------- the MAV
    def _fly_newest_command(self) -> None:
        """Fly the carrier's newest command of this run, or hover when it is older than ``command_timeout``."""
        message = self.link.latest(self.params.carrier, COMMAND_TOPIC)
        if (message is None or self.now - message.sent > self.params.command_timeout
                or message.payload.run != self.started):
            self.robot.hover()
            return
        command: ScoutCommand = message.payload
        climb = float(np.clip(self.hold_height - self.robot.estimate().position[2], -0.3, 0.3))
        self.robot.command_velocity(command.vx, 0.0, climb, command.yaw_rate, frame="body")

    def _drop_breadcrumb(self) -> None:
        """Record the estimated position when it lies ``breadcrumb_spacing`` from the last recorded one."""
        position = self.robot.estimate().position
        if float(np.linalg.norm(position - self.path[-1])) >= self.params.breadcrumb_spacing:
            self.path.append(position.copy())
            self.write(f"{self.robot_name}/{SCOUT_PATH}", list(self.path))

    # -------------------------------------------------------- the carrier
    def _guide(self, frame: RelayedFrame) -> Status:
        """On the carrier: detect in the relayed frame, else decide the action and send it to the MAV."""
        p = self.params
        self.context.image(f"{self.robot_name}/relayed", frame.rgb, stamp=frame.stamp)
        detections = self.detector.detect(frame.rgb, p.object_class)
        self.seen = self.seen + 1 if detections else 0
        if self.seen >= p.confirm_frames:
            return self._found(detections[0], frame)
        decision = decide(self.estimator.estimate(frame), p.bias, p.rows)
        action = self._unstuck(decision.action)
        vx, yaw_rate = velocity_command(action, p.forward_speed, p.turn_speed, p.yaw_rate)
        self.carrier_link.send(COMMAND_TOPIC, ScoutCommand(self.started, vx, yaw_rate, action))
        columns = ", ".join(f"{c:.2f}" for c in decision.columns)
        self.feedback_message = (f"action {action} (columns l/c/r {columns}); frames "
                                 f"{self.receiver.received} received, {self.receiver.lost} lost")
        return Status.RUNNING

    def _unstuck(self, action: str) -> str:
        """``action``, or a turn in the bias's direction while the MAV gets unstuck: forward commands for
        ``stuck_time`` that moved its estimate less than ``stuck_distance`` (pressed against something its depth
        map does not tell from open space) start a turn of ``unstick_angle`` (a ``state_change`` ``stuck``)."""
        p = self.params
        if self.now < self.unstick_until:
            return CLOCKWISE if p.bias >= 0 else COUNTER_CLOCKWISE
        if action != FORWARD or p.stuck_time is None:
            self.forward_since = None
            return action
        position = self.robot.estimate().position
        if self.forward_since is None:
            self.forward_since = (self.now, position.copy())
            return action
        since, where = self.forward_since
        if self.now - since < p.stuck_time:
            return action
        moved = float(np.hypot(*(position[:2] - where[:2])))
        self.forward_since = (self.now, position.copy())
        if moved >= p.stuck_distance:
            return action
        self.unstick_until = self.now + p.unstick_angle / p.yaw_rate
        phase_event(self, "stuck", moved=round(moved, 3), position=[round(float(c), 3) for c in position])
        return CLOCKWISE if p.bias >= 0 else COUNTER_CLOCKWISE

    def _found(self, detection: Detection, frame: RelayedFrame) -> Status:
        """Record the sighting (blackboard, event, metric) and end the run."""
        position = self.robot.estimate().position
        sighting = ObjectSighting(detection, frame.stamp, self.now, (float(position[0]), float(position[1]),
                                                                     float(position[2])))
        self.write(f"{self.robot_name}/{OBJECT_FOUND}", sighting)
        phase_event(self, OBJECT_FOUND, object_class=detection.object_class, box=list(detection.box),
                    area_px=detection.area_px, frame_stamp=round(frame.stamp, 3),
                    position=[round(c, 3) for c in sighting.position])
        self.context.metric("scout_time_to_find", self.now - self.started, robot=self.robot_name)
        milestone(self, f"found {detection.object_class}", detail=f"{self.now - self.started:.1f} s after its start")
        self.feedback_message = f"{detection.object_class} found at box {detection.box} ({detection.area_px} px)"
        return Status.SUCCESS


class ObjectFound(Condition["ObjectFound.Params"]):
    """Holds once the MAV's scout run found an object of interest (of the class named, if one is)."""

    class Params(NodeParams):
        object_class: str | None = None
        """Class the sighting must be of; ``None``: any object of interest."""

    primary: ClassVar[str] = "object_class"
    robot_kinds = (Rotorcraft,)
    reads = (f"{{robot}}/{OBJECT_FOUND}",)

    def check(self) -> bool:
        sighting = self.read(f"{self.robot_name}/{OBJECT_FOUND}")
        wanted = self.params.object_class
        return sighting is not None and (wanted is None or sighting.detection.object_class == wanted)
