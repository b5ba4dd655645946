"""Initial encounter (Narváez §IV, Fig. 3): the UAV meets the carrier over its arm and the eye-in-hand camera finds it.

"The initial encounter is when the two robot platforms reach a meeting
point; the end-effector searches for the UAV with the camera pointed
upward. When the UAV marker enters the vision field, the UAV relative
position is extracted, and the tracking task starts" (§IV).

The meeting point is fixed in the manipulator frame M: the UAV's Part B
``meeting_height`` above Part A of the ``docking_ready`` arm pose, the UAV
heading ``yaw_M`` in M (default: the carrier's forward axis); the UAV flies there and holds it while
the carrier drives on (:func:`~.relative_hold.command_hold`). Until the
marker is seen, the UAV's place in M comes from the two robots' own
estimates only (the UAV's over the team link, the carrier's onboard:
:mod:`.relative_pose`); each frame in which the bundle is measured then
re-anchors it, so the last metres are flown on the camera. The arm goes to
``docking_ready`` and, until the bundle is detected, sweeps the camera's
axis over an upward cone (:func:`search_offsets`: base yaw and wrist pitch
in a Lissajous pattern); once detected the arm holds still. The skill
succeeds when the bundle has been measured in ``stable_detections``
consecutive frames whose UAV positions in M agree within ``stable_spread``,
with the UAV arrived at the meeting point.

While it runs, the carrier's docking flag is up (``navigate`` slows to the
docking speed, 0.5 m/s, §V-B-1); it stays up after success for ``track``
and ``contact`` and is cleared on failure or preemption.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.api.capabilities import Rotorcraft
from marsupial.trees.phases import Phased, Transition, go, phase_event
from marsupial.trees.skill import NodeParams, Skill

from ..common.carrier_frame import CarrierFrame
from .observer import EyeInHandObserver, position_spread
from .relative_hold import HoldGains, command_hold, relative_pose_of, target_above_part_a
from .relative_pose import RelativeState
from .team import DOCKING_FLAG, UAV_POSE, CarrierName, carrier_port

SEARCH_JOINTS = (0, 4)  # arm joints swept by the search: base yaw (joint 1) and wrist pitch (joint 5)


def search_offsets(t: float, yaw_amplitude: float, tilt_amplitude: float, period: float) -> np.ndarray:
    """Offsets (rad) of the base-yaw and wrist-pitch joints at ``t`` s into the search.

    With the camera pointing up, the wrist pitch tilts its axis in the arm's
    plane and the base yaw turns that plane about the vertical, so the axis
    sweeps a cone of half-angle ``tilt_amplitude``: a 1:2 Lissajous figure of
    period ``period`` s (yaw at 1/period, tilt at 2/period) starting at the
    upright view.
    """
    w = math.tau / period
    return np.array([yaw_amplitude * math.sin(w * t), tilt_amplitude * math.sin(2.0 * w * t)])


@dataclass(frozen=True)
class _Tick:
    """What one tick of the encounter reads: the UAV's pose in M, its distance to the meeting point, the arm."""

    state: RelativeState
    """The UAV's pose in M (:mod:`.relative_pose`)."""
    distance: float
    """Distance (m) of the UAV from the meeting point (:func:`~.relative_hold.command_hold`)."""
    arm_ready: bool
    """The arm is at ``arm_pose`` (its encoders within ``tolerance``)."""


class Rendezvous(Phased, Skill["Rendezvous.Params"]):
    """Fly the UAV to the meeting point over the carrier's arm while the eye-in-hand camera searches for its marker."""

    class Params(NodeParams):
        carrier: CarrierName = "carrier"
        """Team member carrying the arm and its eye-in-hand camera (a mobile_manipulator)."""
        meeting_height: float = Field(0.8, gt=0.0)
        """Height (m) of Part B above Part A of ``arm_pose`` at the meeting point (chosen: the bundle in full view)."""
        arm_pose: str = "docking_ready"
        """Arm pose of the encounter: Part A and the camera pointing up (§IV, Fig. 3)."""
        yaw_M: float = 0.0
        """UAV heading in M at the meeting point (rad; 0: facing the carrier's forward axis)."""
        approach_speed: float = Field(1.0, gt=0.0, le=4.0)
        """Largest UAV speed relative to the carrier on the way (m/s; ≤ 4 m/s lateral limit, §V-B)."""
        search_yaw: float = Field(1.2, ge=0.0)
        """Amplitude (rad) of the base-yaw sweep of the search."""
        search_tilt: float = Field(0.35, ge=0.0)
        """Amplitude (rad) of the wrist-pitch sweep: half-angle of the searched cone."""
        search_period: float = Field(8.0, gt=0.0)
        """Period (s) of the search pattern (its fastest joint stays below the 15 rpm limit, §V-B)."""
        stable_detections: int = Field(5, ge=1)
        """Consecutive frames with the bundle measured needed to succeed."""
        stable_spread: float = Field(0.05, gt=0.0)
        """Largest distance (m) of those measurements from their mean."""
        arrival_tolerance: float = Field(0.15, gt=0.0)
        """Distance (m) from the meeting point (and 0.15 rad from its heading) within which the UAV has arrived."""
        tolerance: float = Field(0.02, gt=0.0)
        """Largest joint error (rad) at which the arm has reached ``arm_pose``."""

    class Phase(Enum):
        """The encounter's phases."""

        MEET = "meet"
        """The UAV flies to the meeting point, the arm to ``arm_pose``."""
        SEARCH = "search"
        """The camera sweeps the search pattern until the bundle is seen, then holds still on it."""

    robot_kinds = (Rotorcraft,)
    sensors = ("{carrier}/eye_in_hand",)
    claims = ("rotors", "{carrier}/arm")
    runs_on = "carrier"  # Narváez §V-B-2: computed on the carrier, sent to the UAV over Wi-Fi
    writes = (f"{{carrier}}/{DOCKING_FLAG}", f"{{carrier}}/{UAV_POSE}")
    phase: Phase

    def start(self) -> None:
        p = self.params
        self.carrier = carrier_port(self, p.carrier)
        self.q_ready = self.carrier.arm_pose(p.arm_pose)
        self.p_meet_M = target_above_part_a(self.carrier, self.robot, p.meeting_height, p.arm_pose, p.yaw_M)
        self.gains = HoldGains(max_speed=p.approach_speed)
        self.observer = EyeInHandObserver.of(self.context, self.carrier)
        self.relative = relative_pose_of(self, self.carrier)
        self.enter(go(self.Phase.MEET, event=None))
        self.search_started: float | None = None
        self.q_hold: np.ndarray | None = None  # arm pose held once the marker is seen
        self.seen: list[np.ndarray] = []  # UAV positions in M of the consecutive detections
        self.last_stamp = -1.0
        self.write(f"{p.carrier}/{DOCKING_FLAG}", True)
        if not self.robot.motors_on and not self.robot.docked:
            self.robot.set_motors(True)

    def step(self) -> Status:
        if self.robot.docked:
            self.feedback_message = f"{self.robot_name} is docked: nothing to meet"
            return Status.FAILURE
        state = self.relative.update(self.now)
        distance = command_hold(
            self.robot, state, self.p_meet_M, self.params.yaw_M, CarrierFrame.of(self.carrier), self.gains
        )
        if distance is None:
            self.feedback_message = "waiting for the UAV's estimate over the team link"
            return Status.RUNNING
        arm_ready = float(np.max(np.abs(self.carrier.joint_positions() - self.q_ready))) <= self.params.tolerance
        return self.step_phase(_Tick(state, distance, arm_ready))

    def _step_meet(self, tick: _Tick) -> Status | Transition:
        self.carrier.set_joint_targets(self.q_ready)
        self.feedback_message = f"to the meeting point: {tick.distance:.2f} m"
        if not tick.arm_ready:
            return Status.RUNNING
        self.search_started = self.now
        return go(self.Phase.SEARCH, uav_distance=tick.distance)

    def _step_search(self, tick: _Tick) -> Status:
        state, distance = tick.state, tick.distance
        observation = self.observer.observe(self.now)
        if observation is not None and observation.stamp != self.last_stamp:
            self.last_stamp = observation.stamp
            if observation.pose is not None:  # the bundle was measured (observation.seen)
                self.write(f"{self.params.carrier}/{UAV_POSE}", observation)
                if not self.seen:
                    phase_event(self, "marker_seen", tags=list(observation.pose.ids))
                self.seen.append(observation.pose.p_uav_M)
            else:
                self.seen.clear()
        self.command_arm()
        recent = self.seen[-self.params.stable_detections :]
        stable = len(recent) >= self.params.stable_detections and position_spread(recent) <= self.params.stable_spread
        assert state.yaw_M is not None, "command_hold had a pose"
        heading_error = abs(math.remainder(state.yaw_M - self.params.yaw_M, math.tau))
        arrived = distance <= self.params.arrival_tolerance and heading_error <= 0.15
        if stable and arrived:
            self.feedback_message = f"marker detected stably in {len(recent)} frames"
            phase_event(self, "marker_stable", p_uav_M=[round(float(v), 4) for v in recent[-1]])
            return Status.SUCCESS
        self.feedback_message = (
            f"marker seen in {len(self.seen)} consecutive frames"
            if self.seen
            else f"searching; UAV {distance:.2f} m from the meeting point"
        )
        return Status.RUNNING

    def command_arm(self) -> None:
        """Hold the arm where it is while the marker is seen, else sweep the search pattern from ``arm_pose``."""
        if self.seen:
            if self.q_hold is None:
                self.q_hold = self.carrier.joint_positions()
            self.carrier.set_joint_targets(self.q_hold)
            return
        self.q_hold = None
        q = self.q_ready.copy()
        p = self.params
        assert self.search_started is not None, "the search began"
        t = self.now - self.search_started
        q[list(SEARCH_JOINTS)] += search_offsets(t, p.search_yaw, p.search_tilt, p.search_period)
        self.carrier.set_joint_targets(q)

    def finish(self, status: Status) -> None:
        if status != Status.SUCCESS:
            self.write(f"{self.params.carrier}/{DOCKING_FLAG}", False)
            self.carrier.hold_arm()
        self.leave_safe()
