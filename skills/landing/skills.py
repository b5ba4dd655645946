"""Skills of Palafox et al. (2019): take off from, track, land on and re-localise a moving platform.

The skills of the UAV (an ``ardrone2`` landing on the red platform of a
``summit_xl``) share one :class:`~.tracking.TrackingModule` through the
blackboard key ``<uav>/tracking``: the detection (Algorithm 1), the tracker (§3.3) and
the state machine's clocks carry over from one skill to the next.

- ``takeoff`` — landed → taking off: motors on, climb at 1 m/s to the 4 m
  nominal height while tracking (§3.1).
- ``follow`` — tracking: hold the nominal height over the platform (§3.1),
  with the controller chosen by ``mode``; ``track_reactive`` and
  ``track_predictive`` are ``follow`` with the controller fixed, so that a
  mission can also swap them by name (or pin one in place of ``follow``).
- ``land`` — landing: descend at 0.3 m/s while the sonar reads more than
  0.7 m, then at 2.0 m/s (§3.3.1), tracking all the way; landed when the
  sonar stays below a threshold and the IMU feels the moving platform
  (:mod:`.touchdown`), then motors off: the UAV rides the platform.
- ``relocalize`` — re-localizing: climb at 1 m/s with the x-y control off
  until the platform is seen again, then track while climbing back to the
  nominal height, after which a land command is processed again (§3.1).
- ``drive_pattern`` — the UGV's linear (0.5 m/s) or circular (v, ω)
  trajectory (§4.2.1); the wheel-slip drift is the ``summit_xl``'s own.

Every flying skill chooses the controller with ``mode`` (reactive: the
measured platform position, §3.3.1; predictive: the Kalman prediction,
§3.3.2), the gain schedule with ``gain_schedule`` (``table1``: the printed
law, default; ``manual_fit``: see :mod:`.control`) and, beyond the paper,
``velocity_feedforward`` (predictive mode, on by default: the filter's
platform velocity is added to the PI output, and the filter follows the
estimate's frame when the optical flow changes between floor and platform,
:mod:`.flowframe`; off reproduces the paper's predictive controller). Heights are sonar readings above the platform (m),
speeds m/s, times simulated s.
"""

from __future__ import annotations

import math
from typing import Annotated, ClassVar, Literal, TypeVar, get_args

import numpy as np
from py_trees.common import Status
from pydantic import Field, model_validator

from marsupial.api.capabilities import HasBase, HasPlatform, Rotorcraft
from marsupial.trees.metrics import MetricSpec
from marsupial.trees.milestones import milestone
from marsupial.trees.skill import NodeParams, Skill, TeamMember

from .touchdown import TouchdownParams, TouchdownTest
from .tracking import GAIN_SCHEDULES, TrackerConfig, TrackingModule, tracking_module

GainSchedule = Literal["table1", "manual_fit"]  # the names of GAIN_SCHEDULES
if set(get_args(GainSchedule)) != set(GAIN_SCHEDULES):
    raise ImportError(f"GainSchedule {get_args(GainSchedule)} must name the gain schedules {sorted(GAIN_SCHEDULES)}")
PAPER_PATH_TIME_S = 0.1  # path time of the prediction, §3.3.2


class FlightParams(NodeParams):
    """Parameters every flying skill of the landing cycle shares (tracker and nominal height)."""

    mode: Literal["reactive", "predictive"] = "predictive"
    """Tracking controller.

    ``reactive``: PI on the measured platform (§3.3.1); ``predictive``: PI on the Kalman prediction (§3.3.2).
    """
    gain_schedule: GainSchedule = "table1"
    """PI gains K = Q·exp(-T·p_z).

    ``table1`` (T = 0.002 /m, the printed law, Table 1) or ``manual_fit`` (T fitted to K_p 0.45, K_i 0.1 at 4 m).
    """
    velocity_feedforward: bool = True
    """Predictive mode: add the Kalman filter's platform velocity to the PI output.

    That velocity is kept in the estimate's frame when the optical flow changes surfaces (not in the paper;
    ``false``: the paper's predictive controller). The reactive controller has no filter and never uses it.
    """
    path_time_s: float | None = Field(None, ge=0.0)
    """How far ahead the prediction is taken (s).

    Default: 0.1 s (§3.3.2) without the feed-forward, 0 with it (the feed-forward supplies the lead).
    """
    integral_band: float = Field(0.1, gt=0.0)
    """With the feed-forward: integrate the PI error only while it is within this distance (m).

    A large transient (e.g. the take-off) then does not wind the integral up (not in the paper).
    """
    nominal_height: float = Field(4.0, gt=0.0)  # nominal tracking height, §3.1
    """Nominal tracking height above the platform (m), §3.1."""
    platform: Annotated[str, TeamMember(HasPlatform)] | None = None
    """Team member carrying the landing platform (default: the only robot with one)."""

    def tracker_config(self) -> TrackerConfig:
        """The tracker these parameters ask for (defaults resolved)."""
        feedforward = self.mode == "predictive" and self.velocity_feedforward
        path_time = self.path_time_s if self.path_time_s is not None else (0.0 if feedforward else PAPER_PATH_TIME_S)
        return TrackerConfig(
            self.mode, self.gain_schedule, feedforward, path_time, self.integral_band if feedforward else None
        )


PF = TypeVar("PF", bound=FlightParams)


class FlightSkill(Skill[PF]):
    """Base of the UAV skills: the shared tracking module and the one command per tick."""

    reads = ("{robot}/tracking",)
    writes = ("{robot}/tracking",)
    robot_kinds = (Rotorcraft,)
    sensors = ("bottom_camera", "sonar", "imu", "battery")
    claims = ("rotors",)

    def start(self) -> None:
        self.module: TrackingModule = tracking_module(self, self.params.platform)
        self.module.configure(self.params.tracker_config())
        self.motors_seen = False  # the flight controller has reported its motors running since the start

    def motors_stopped(self) -> bool:
        """Whether the motors have stopped under the skill (an empty battery stops them); says so in the feedback.

        Motors the skill has just started count as running until the flight controller first reports them
        (its arming state arrives with the next tick's readings).
        """
        if self.robot.motors_on:
            self.motors_seen = True
            return False
        if not self.motors_seen:
            self.feedback_message = "starting the motors"
            return False
        battery = self.robot.battery()  # the battery monitor
        level = "unknown" if battery is None else f"{battery.soc_percent:.0f}%"
        self.feedback_message = f"motors stopped, battery at {level}"
        return True

    def fly(self, vz: float, track: bool = True) -> None:
        """Send this tick's command: the tracker's x-y velocity (or none) and ``vz`` (m/s, up)."""
        vx, vy = self.module.command() if track else (0.0, 0.0)
        self.robot.command_velocity(vx, vy, vz, 0.0, frame="body")

    def hold_height(self, height: float, gain: float, max_speed: float) -> float:
        """Vertical speed (m/s) bringing the sonar height to ``height`` (P law, clipped)."""
        return float(np.clip(gain * (height - self.module.height), -max_speed, max_speed))

    def climb_tracking(self, p: ClimbParams) -> bool:
        """Climb at ``climb_speed`` towards the nominal height while tracking; True (no command) once there.

        Before the first sonar reading the height is unknown (``inf``): the UAV climbs.
        """
        if math.isfinite(self.module.height) and self.module.height >= p.nominal_height - p.tolerance:
            return True
        self.fly(min(p.climb_speed, self.hold_height(p.nominal_height, p.height_gain, p.climb_speed)))
        return False


class ClimbParams(FlightParams):
    """Parameters of the skills that climb to the nominal height (take-off, re-localisation)."""

    climb_speed: float = Field(1.0, gt=0.0)  # 1 m/s along z, §3.1
    """Climb speed (m/s), §3.1."""
    height_gain: float = Field(1.5, gt=0.0)
    """Proportional gain of the height hold near the nominal height (1/s)."""
    tolerance: float = Field(0.1, gt=0.0)
    """Height error (m) at which the nominal height counts as reached."""


class Takeoff(FlightSkill[ClimbParams]):
    """Take off from the platform and climb to the nominal height while tracking it (§3.1)."""

    def start(self) -> None:
        super().start()
        if not self.robot.motors_on:  # landed: a new flight
            self.module.begin_flight(self.params.tracker_config(), self)
            self.robot.set_motors(True)
        else:
            self.module.set_state("taking_off", self)

    def step(self) -> Status:
        module = self.module
        module.update()
        if self.motors_stopped():
            return Status.FAILURE
        self.feedback_message = f"{module.height:.2f} m above the platform"
        if not self.climb_tracking(self.params):
            return Status.RUNNING
        if module.tracking_start is None:
            module.tracking_start = self.now
        module.set_state("tracking", self, "nominal height reached")
        milestone(self, "took off", detail="tracking the platform")
        return Status.SUCCESS


class Follow(FlightSkill["Follow.Params"]):
    """Track the platform at the nominal height, for a time or until stopped (§3.1, tracking)."""

    class Params(FlightParams):
        seconds: float | None = Field(None, gt=0.0)
        """How long to track (simulated s); none: until the parent stops it (e.g. at a land signal)."""
        height_gain: float = Field(1.5, gt=0.0)
        """Proportional gain of the height hold (1/s)."""
        max_climb_speed: float = Field(1.0, gt=0.0)
        """Vertical speed limit of the height hold (m/s)."""

    def start(self) -> None:
        super().start()
        self._until = None if self.params.seconds is None else self.now + self.params.seconds
        self.module.set_state("tracking", self)

    def step(self) -> Status:
        module, p = self.module, self.params
        module.update()
        if self.motors_stopped():
            return Status.FAILURE
        seen = "not located yet" if module.offset is None else f"{np.hypot(*module.offset):.2f} m away"
        self.feedback_message = f"platform {seen}, {module.height:.2f} m above it"
        if self._until is not None and self.now + 1e-9 >= self._until:
            return Status.SUCCESS
        self.fly(self.hold_height(p.nominal_height, p.height_gain, p.max_climb_speed))
        return Status.RUNNING


class TrackReactive(Follow):
    """Track the platform with the reactive controller (PI on the measured position, §3.3.1)."""

    class Params(Follow.Params):
        mode: Literal["reactive"] = "reactive"
        """Tracking controller: always ``reactive`` (§3.3.1) for this skill."""


class TrackPredictive(Follow):
    """Track the platform with the predictive controller (PI on the Kalman prediction, §3.3.2)."""

    class Params(Follow.Params):
        mode: Literal["predictive"] = "predictive"
        """Tracking controller: always ``predictive`` (§3.3.2) for this skill."""


class Land(FlightSkill["Land.Params"]):
    """Descend onto the moving platform while tracking it; motors off once landed on it (§3.1, §3.3.1).

    Landed (§3.3.1, :mod:`.touchdown`): the sonar reads less than
    ``landed_range`` for ``landed_hold_s`` in a row AND the IMU's horizontal
    specific force over that time, every sample at the IMU's rate, is that of
    a vehicle riding a moving platform (RMS at least ``ride_accel``; at rest
    on the ground it is only the sensor noise, ≈0.07 m/s² for the AR.Drone 2
    model, while the moving Summit XL shakes its rider with ≈0.3–0.45 m/s²).
    Sonar low but IMU still: the UAV came down on the ground, the skill fails.

    The tracker carries over from the tracking state: the PI integral is
    not reset at the land command (the authors' node resets it, and a PI
    without a feed-forward then trails while it learns the platform's speed
    again). The model's vertical speed limit (1 m/s) caps the 2.0 m/s final
    descent.
    """

    metrics: ClassVar[tuple[MetricSpec, ...]] = (
        MetricSpec("landed", "flag", "the UAV landed on the moving platform", "count"),
        MetricSpec("ground_landing", "flag", "the UAV came down on the ground, not on the platform", "count"),
    )

    class Params(FlightParams):
        descent_speed: float = Field(0.3, gt=0.0)  # 0.3 m/s while the sonar reads > 0.7 m, §3.3.1
        """Descent speed (m/s) above ``final_height``, §3.3.1."""
        final_height: float = Field(0.7, gt=0.0)  # 0.7 m, §3.3.1
        """Sonar height (m) below which the final descent starts, §3.3.1."""
        final_speed: float = Field(2.0, gt=0.0)  # 2.0 m/s below 0.7 m, §3.3.1
        """Descent speed (m/s) of the final stage (the vehicle's vertical limit may cap it), §3.3.1."""
        landed_range: float = Field(TouchdownParams.landed_range, gt=0.0)
        """Sonar reading (m) below which the UAV may be down.

        The paper gives no value; the AR.Drone 2 sonar reads ≥ 0.2 m.
        """
        landed_hold_s: float = Field(TouchdownParams.hold_s, gt=0.0)
        """How long (s) the sonar must stay below ``landed_range`` ("for a certain period of time", §3.3.1)."""
        ride_accel: float = Field(TouchdownParams.ride_accel, gt=0.0)
        """RMS horizontal specific force (m/s²) over that time from which the IMU shows a moving platform, §3.3.1."""

    def start(self) -> None:
        super().start()
        p = self.params
        self._touchdown = TouchdownTest(TouchdownParams(p.landed_range, p.landed_hold_s, p.ride_accel))
        self.module.set_state("landing", self)

    def step(self) -> Status:
        module, p = self.module, self.params
        module.update()
        if self.motors_stopped():
            return Status.FAILURE
        verdict = self._touchdown.update(self.now, module.height, module.imu_samples)
        if verdict is not None:
            return self._down(verdict == "platform")
        vz = -p.descent_speed if module.height > p.final_height else -p.final_speed
        self.feedback_message = f"{module.height:.2f} m above the platform, descending at {-vz:.1f} m/s"
        self.fly(vz)
        return Status.RUNNING

    def _down(self, on_platform: bool) -> Status:
        """Down for ``landed_hold_s``: on the moving platform (motors off, SUCCESS) or on the ground (FAILURE)."""
        test, name = self._touchdown, self.robot_name
        ride = f"{test.ride_rms:.2f} m/s² RMS over {test.samples} IMU samples"
        self.robot.set_motors(False)
        if not on_platform:
            self.context.metric("ground_landing", 1.0, robot=name)
            self.feedback_message = f"down but the IMU feels no motion ({ride}): landed on the ground"
            milestone(self, "came down on the ground", detail="not on the platform")
            return Status.FAILURE
        self.context.metric("landed", 1.0, robot=name)
        self.module.set_state("landed", self, f"sonar below {self.params.landed_range} m, IMU {ride}")
        self.feedback_message = f"landed on the moving platform (IMU {ride})"
        milestone(self, "landed", detail="on the moving platform")
        return Status.SUCCESS

    def finish(self, status: Status) -> None:
        if status != Status.SUCCESS:
            self.leave_safe()


class Relocalize(FlightSkill["Relocalize.Params"]):
    """Find the platform again: climb with the x-y control off until seen, then track up to the nominal height (§3.1).

    The search never gives up (the paper's neither): above ``max_height``
    the UAV hovers and keeps looking, until the platform comes into view or
    the mission's time limit ends the run.
    """

    metrics: ClassVar[tuple[MetricSpec, ...]] = (
        MetricSpec("relocalizations", "count", "re-localisation searches started so far", "total"),
    )

    class Params(ClimbParams):
        max_height: float = Field(5.5, gt=0.0)
        """Highest sonar height (m) of the search; the UAV keeps looking there (the sonar reaches 6 m)."""

    def start(self) -> None:
        super().start()
        module = self.module
        module.relocalizations += 1
        self.context.metric("relocalizations", module.relocalizations, robot=self.robot_name)
        module.set_state("relocalizing", self, module.pending_relocalization or "")
        assert module.tracker is not None, "configured by FlightSkill.start"
        module.tracker.pi.reset()  # the authors reset the PI on re-localisation; the filter keeps the platform's motion
        self._located_at_start = module.located

    def step(self) -> Status:
        module, p = self.module, self.params
        module.update()
        if self.motors_stopped():
            return Status.FAILURE
        if module.state == "relocalizing":
            if module.located > self._located_at_start:
                module.set_state("tracking", self, "platform seen again")
            else:
                self.feedback_message = f"searching at {module.height:.2f} m"
                self.fly(min(p.climb_speed, self.hold_height(p.max_height, p.height_gain, p.climb_speed)), track=False)
                return Status.RUNNING
        if not self.climb_tracking(p):
            self.feedback_message = f"tracking back up at {module.height:.2f} m"
            return Status.RUNNING
        module.end_relocalization()
        self.feedback_message = "platform found, back at the nominal height"
        milestone(self, "found the platform again")
        return Status.SUCCESS


class DrivePattern(Skill["DrivePattern.Params"]):
    """Drive the UGV along a straight line or a circle, for a time or until stopped (§4.2.1)."""

    class Params(NodeParams):
        pattern: Literal["linear", "circular"] = "circular"
        """``linear`` (straight ahead) or ``circular`` (constant v and ω), §4.2.1."""
        v: float = Field(0.5, gt=0.0)  # 0.5 m/s along the UGV's x axis, §4.2.1
        """Forward speed (m/s), §4.2.1."""
        omega: float | None = None
        """Yaw rate (rad/s) of the circular pattern; default 0.05 (§4.2.1). Must be unset or 0 for ``linear``."""
        seconds: float | None = Field(None, gt=0.0)
        """How long to drive (simulated s); none: until the parent stops it."""

        @model_validator(mode="after")
        def _linear_goes_straight(self) -> DrivePattern.Params:
            if self.pattern == "linear" and self.omega not in (None, 0.0):
                raise ValueError(f"a linear pattern drives straight: leave omega unset or 0 (got {self.omega})")
            return self

    robot_kinds = (HasBase,)
    claims = ("base",)
    CIRCLE_OMEGA: ClassVar[float] = 0.05  # rad/s, §4.2.1

    def start(self) -> None:
        p = self.params
        self._omega = 0.0 if p.pattern == "linear" else (self.CIRCLE_OMEGA if p.omega is None else p.omega)
        self._start = self.now

    def step(self) -> Status:
        p = self.params
        elapsed = self.now - self._start
        self.feedback_message = f"{p.pattern} at {p.v} m/s, {self._omega} rad/s for {elapsed:.1f} s"
        if p.seconds is not None and elapsed + 1e-9 >= p.seconds:
            return Status.SUCCESS
        self.robot.drive(p.v, self._omega)
        return Status.RUNNING
