"""Contact phase (Narváez §IV-B, eqs. 13–15; docking device §IV-C, Fig. 12): Part A rises to Part B and locks it.

"The Contact Phase is executed simultaneously with the Tracking Phase and
starts with the authorization of the human operator and supervises the
end-effector movement for a slow vertical approach toward the UAV" (§IV-B).
This skill runs beside ``track`` (:mod:`.track`), which drives the arm; it
steers that skill's Motion Engine through the blackboard
(``<carrier>/contact_target``, a :class:`~.track.ContactTarget`) and reads
how tracking goes (``<carrier>/tracking``, a :class:`~.track.TrackingState`).

Phases (``state_change`` events with ``phase``):

- ``authorization_requested`` — the operator is asked for the command
  ``authorization`` (default ``authorize_contact``; the request is an event,
  so it shows on the log); ``authorization: null`` authorizes at once
  (benchmarks) and records ``authorized`` with ``by=parameter``;
- ``settling`` — authorized; waits until the marker is seen, the UAV holds
  its pose in M and the camera is centred under the bundle (both within
  ``settle_error``) for ``settle_time``;
- ``approach`` — P_RC is P_R raised by eq. (15), z_C = z + k_c·ln(t_c + 1),
  written as the gap s(t_c) = s_0 − k_c·ln(t_c + 1) that Part A leaves below
  Part B (s_0: the gap when the approach began; never below 0). The contact
  clock t_c stops while the last ``align_gap`` would be closed on a Part B
  farther than ``align_tolerance`` from Part A's axis (the supervision: no
  push on a misaligned UAV). The UAV's downward sonar cone is a prohibited
  zone of the local map (§IV-B), so the end effector never enters the beam;
- ``capture`` — Part A holds still within D_c of Part B (the approach stops
  at ``rest_gap``), both read from the camera's estimate of Part B in Part
  A's frame (``TrackingState.p_B_A``: the bundle pose by eq. (1) composed
  with the forward kinematics of the encoders, propagated with the robots'
  estimates between frames): the electromagnet pulls Part B into contact,
  closing the gap to 0 mm (§IV-C, Fig. 12b). When the magnet has not
  seated Part B after ``CAPTURE_TIME`` (the device's contact switch stays
  open) the capture failed: the magnet goes off and the approach aims
  ``capture_step`` higher, so an estimate that reads the gap short is
  closed by the arm;
- ``locking`` — the contact switch closed: the servo levers close on Part
  B's ring (Fig. 12c); once the lever end switch reports the lock and the
  docking device stops the UAV's motors, the skill succeeds (``locked``,
  with the metrics ``contact_time`` and ``docking_time``: from the start of
  tracking to the lock; the UAV's heading on Part A, from the camera's last
  estimate, goes to the blackboard for the deployment's hand-over). Levers
  that close on nothing (no end switch) with the contact switch still
  closed close again (``lock_failed``); with it open, Part B was knocked off
  the face before they held it and the contact is cancelled (below): the end
  effector drops back to regain sight rather than keep rising, blind, at a
  UAV knocked aside.

The eq. (15) samples are logged as the metrics ``contact_t`` (t_c) and
``contact_z_C`` (z_C of Part A in M).

A capture lost that way, losing the marker for ``lost_timeout`` while Part
B is farther than ``blind_range``, or for ``blind_timeout`` closer than that
(the camera is too near the bundle to see all of it; the pose estimate
carries on with the two robots' estimates, whose drift grows with the
time), or an approach longer than ``timeout``, cancels the contact
(``contact_cancelled``): the magnet goes off, the target is withdrawn so
that the end effector drops back to the tracking standoff to regain sight
(§IV-B: "the value for z_C_eff will decrease quickly to a low position to
enhance the camera field of view"), and authorization is requested again
("for safety, the contact authorization is requested after any
cancellation", §IV-B). After ``max_cancellations`` the skill fails.

Every decision reads the device's states (coil, contact switch, lever end
switch) or the camera's estimate; none reads the true gap.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import ClassVar

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.api.capabilities import Rotorcraft
from marsupial.geometry import yaw_of_rotation
from marsupial.trees.metrics import MetricSpec
from marsupial.trees.milestones import milestone
from marsupial.trees.phases import Phased, Transition, go, phase_event
from marsupial.trees.skill import Condition, NodeParams, Skill

from .gust_guard import GuardLimits, GustGuard
from .pose import invert
from .relative_hold import PART_A_LINK, part_b_transform
from .team import DOCKING_FLAG, PART_B_YAW, CarrierName, carrier_port
from .track import CONTACT_TARGET, TRACKING, ContactTarget, TrackingState

CAPTURE_TIME = 1.0  # s the magnet may take to bring Part B into contact before the capture is retried
SETTLED_SPEED = 0.01  # m/s: Part A counts as holding still below Part B (the magnet is not switched on a moving arm)
GUARD_MARGIN = 0.02  # m above guard_gap within which a guarded approach stays guarded (estimate noise)
K_C = 0.18  # m, k_c of eq. (15): the paper prints no value; chosen so a 0.35 m gap closes in 6 s (2.6 cm/s at the end)


def contact_height(z0: float, t_c: float, k_c: float = K_C) -> float:
    """Eq. (15): z_C = z + k_c·ln(t_c + 1), the end effector's height (m) t_c s into the contact phase."""
    return z0 + k_c * math.log(max(t_c, 0.0) + 1.0)


@dataclass(frozen=True)
class _Closing:
    """What one tick of the approach read (the camera's estimate of Part B in Part A's frame, the switches)."""

    at: float
    """Simulated time (s) of the tick."""
    gap: float
    """Estimated gap (m) from Part A's face up to Part B's, along Part A's axis."""
    aligned: bool
    """Part B is within ``align_tolerance`` of Part A's axis."""
    settled: bool
    """Part A holds still below Part B (the gap changed by less than ``SETTLED_SPEED``)."""
    unsteady: bool
    """The gust guard holds Part A back."""
    abandoned: bool
    """The gust guard turned unsteady in this tick and abandoned a capture under way (magnet off)."""
    switch: bool
    """The contact switch is closed (Part B seated on Part A)."""
    standoff: float
    """The gap (m) Part A leaves below Part B now (eq. (15) on the contact clock, held by the supervision)."""


class Contact(Phased, Skill["Contact.Params"]):
    """After the operator's authorization, raise Part A to the UAV's Part B by eq. (15).

    Then magnet and levers lock it.
    """

    metrics: ClassVar[tuple[MetricSpec, ...]] = (
        MetricSpec("contact_t", "s", "contact clock t_c of eq. (15) during the approach"),
        MetricSpec("contact_z_C", "m", "height z_C of Part A in M during the approach, eq. (15)"),
        MetricSpec("contact_time", "s", "time from the start of the approach to the lock", "each"),
        MetricSpec("docking_time", "s", "time from the start of tracking to the lock on Part A", "each"),
    )

    class Params(NodeParams):
        carrier: CarrierName = "carrier"
        """Team member carrying the arm and Part A of the docking device (a mobile_manipulator)."""
        authorization: str | None = "authorize_contact"
        """Operator command that authorizes the contact phase (§IV-B); none: authorized at once (benchmarks)."""
        k_c: float = Field(K_C, gt=0.0)
        """Gain k_c of eq. (15) (m): fast approach first, slower at the end."""
        settle_error: float = Field(0.04, gt=0.0)
        """Largest UAV distance from its hold pose in M and camera offset from the bundle (m) to begin the approach."""
        settle_time: float = Field(0.5, ge=0.0)
        """Time (s) tracking must stay settled before the approach begins."""
        blind_range: float = Field(0.22, ge=0.0)
        """Gap (m) between Part A and Part B below which an unseen marker is expected (the camera is too close)."""
        lost_timeout: float = Field(0.3, gt=0.0)
        """Time (s) without the marker, farther than ``blind_range``, that cancels the contact."""
        blind_timeout: float = Field(2.0, gt=0.0)
        """Time (s) without the marker, within ``blind_range``, that cancels the contact.

        It bounds the estimates' drift since the last frame.
        """
        align_gap: float = Field(0.03, ge=0.0)
        """Gap (m) the approach holds until Part B is within ``align_tolerance`` of Part A's axis.

        No push on a misaligned UAV.
        """
        align_tolerance: float = Field(0.008, gt=0.0)
        """Lateral offset (m) of Part B from Part A's axis within which the last ``align_gap`` is closed.

        It is inside the magnet's 10 mm reach.
        """
        D_c: float = Field(0.010, gt=0.0)
        """Estimated gap D_c (m) at which the electromagnet is switched on, §IV-C.

        Its 10 mm reach (it closes the gap to 0 mm); a gap the estimate reads short is caught by the capture retry.
        """
        rest_gap: float = Field(0.005, ge=0.0)
        """Gap (m) at which Part A stops below Part B (inside D_c): the magnet, not the arm, makes the contact."""
        capture_step: float = Field(0.004, ge=0.0)
        """After each failed capture the approach aims this much (m) higher.

        Down to ``-2·capture_step`` below the estimated face.
        """
        guard_gap: float = Field(0.08, ge=0.0)
        """Gap (m) Part A backs off to while the UAV is unsteady (the gust guard, :mod:`.gust_guard`; 0: off)."""
        guard_lateral: float = Field(0.025, gt=0.0)
        """Lateral offset (m) of Part B from Part A's axis that makes the UAV unsteady (within ``guard_gap``)."""
        guard_speed: float = Field(0.15, gt=0.0)
        """UAV speed relative to M (m/s, its estimate) that makes it unsteady (within ``guard_gap``)."""
        guard_calm_time: float = Field(0.5, ge=0.0)
        """Time (s) the UAV must stay within both limits before the approach resumes."""
        sonar_cone: bool = True
        """Map the UAV's downward range-finder cone as a prohibited zone (§IV-B)."""
        timeout: float = Field(30.0, gt=0.0)
        """Longest approach (s) before it is cancelled (a UAV that never holds still enough)."""
        max_cancellations: int = Field(3, ge=0)
        """Cancellations after which the skill fails."""

    class Phase(Enum):
        """The contact's phases (module docstring); the log names them by their values."""

        AUTHORIZATION_REQUESTED = "authorization_requested"
        SETTLING = "settling"
        APPROACH = "approach"
        CAPTURE = "capture"
        LOCKING = "locking"

    robot_kinds = (Rotorcraft,)
    sensors = ("sonar", "{carrier}/eye_in_hand")
    claims = ("{carrier}/docking",)  # the UAV and the arm are track's, which runs beside it
    runs_on = "carrier"  # Narváez §V-B-2: computed on the carrier, sent to the UAV over Wi-Fi
    reads = (f"{{carrier}}/{TRACKING}",)
    writes = (f"{{carrier}}/{CONTACT_TARGET}", f"{{carrier}}/{DOCKING_FLAG}", f"{{carrier}}/{PART_B_YAW}")
    phase: Phase

    @property
    def operator_commands(self) -> tuple[str, ...]:
        """The operator command this skill consumes (the compiler accepts it in a mission's operator script)."""
        return () if self.params.authorization is None else (self.params.authorization,)

    # ------------------------------------------------------------ life cycle
    def start(self) -> None:
        self.carrier = carrier_port(self, self.params.carrier)
        self.device = self.carrier.docking
        sonar = self.robot.sensor("sonar")
        self.sonar = (sonar.half_angle, sonar.max_range)
        self.cancellations = 0
        self.failed_captures = 0
        self.measured: _Closing | None = None
        self.key = f"{self.params.carrier}/{CONTACT_TARGET}"
        self.write(self.key, None)
        self.enter(self.request_authorization("contact requested"))

    def step(self) -> Status:
        state: TrackingState | None = self.read(f"{self.params.carrier}/{TRACKING}")
        if self.device.locked and self.robot.docked:  # the lever end switch and the UAV's dock-lock signal
            return self.locked(state)
        status = self.step_phase(state)
        if status == Status.RUNNING and self.phase in (self.Phase.APPROACH, self.Phase.CAPTURE, self.Phase.LOCKING):
            self.hold_target()
        return status

    def finish(self, status: Status) -> None:
        if status != Status.SUCCESS:
            self.device.magnet_off()
            if not self.device.locked:
                self.write(f"{self.params.carrier}/{DOCKING_FLAG}", False)
        self.write(self.key, None)
        self.leave_safe()

    # ------------------------------------------------------------- phases
    def request_authorization(self, why: str) -> Transition:
        """Enter ``authorization_requested``: ask the operator (a ``state_change`` event), or authorize at once."""
        self.t0: float | None = None
        self.settled_since: float | None = None
        command = self.params.authorization
        if command is None:
            return go(self.Phase.SETTLING, event="authorized", by="parameter", why=why)
        self.feedback_message = f"waiting for the operator's '{command}' ({why})"
        return go(self.Phase.AUTHORIZATION_REQUESTED, command=command, why=why)

    def _step_authorization_requested(self, state: TrackingState | None) -> Status | Transition:
        command = self.params.authorization
        channel = self.context.operator
        said = None if channel is None or command is None else channel.handle(command)
        if said is None:
            return Status.RUNNING
        return go(self.Phase.SETTLING, event="authorized", by="operator", command=command, why=said.why)

    def _step_settling(self, state: TrackingState | None) -> Status | Transition:
        """Wait for stable tracking under the UAV before the approach (P_R is the start of eq. 15)."""
        p = self.params
        now = self.now
        settled = (
            state is not None and state.seen and state.p_B_A is not None
            and state.hold_error <= p.settle_error and state.camera_offset <= p.settle_error
        )
        if not settled or state is None or state.p_B_A is None:  # (the last two: for the type checker)
            self.settled_since = None
            self.feedback_message = "authorized: waiting for stable tracking under the UAV"
            return Status.RUNNING
        if self.settled_since is None:
            self.settled_since = now
        if now - self.settled_since + 1e-9 < p.settle_time:
            return Status.RUNNING
        self.t0, self.s0 = now, float(state.p_B_A[2])
        self.t_c, self.last_t = 0.0, now
        self.last_axial, self.last_tick = math.inf, now
        self.guard = GustGuard(GuardLimits(p.guard_lateral, p.guard_speed, p.guard_calm_time))
        self.cone = None  # the sonar beam, from the UAV down to the floor (§IV-B)
        if p.sonar_cone:  # the beam down to its echo (the floor), as the sonar reads it
            reading = self.robot.sensor("sonar").read()
            echo = reading.data.range if reading is not None else math.inf
            self.cone = (self.sonar[0], min(self.sonar[1], echo))
        q = self.carrier.joint_positions()
        self.z0 = float(self.carrier.arm_kinematics.forward(q, PART_A_LINK)[0][2])  # z of P_R in M, eq. (15)
        return go(self.Phase.APPROACH, at_once=True, gap=round(self.s0, 4), k_c=p.k_c)

    def _step_approach(self, state: TrackingState | None) -> Status | Transition:
        """Eq. (15) on the standoff; at D_c (camera estimate) the magnet: Fig. 12b, Part A holds still at D_c and
        the magnet forces the initial contact (at once, on a closed contact switch)."""
        m = self.measure(state)
        if not isinstance(m, _Closing):
            return m
        if m.switch or (m.gap <= self.params.D_c and m.aligned and m.settled and not m.unsteady):
            self.device.magnet_on()
            self.captured_at = m.at
            return go(self.Phase.CAPTURE, at_once=True, t_c=round(self.t_c, 3), gap_estimate=round(m.gap, 4),
                      contact_switch=m.switch)
        return Status.RUNNING

    def _step_capture(self, state: TrackingState | None) -> Status | Transition:
        """The magnet holds Part B; on the contact switch the levers close (Fig. 12c). Not seated after
        ``CAPTURE_TIME``: the magnet goes off and the approach aims higher."""
        m = self.measure(state)
        if not isinstance(m, _Closing):
            return m
        if m.abandoned:  # by the gust guard (its switch is open): back to the approach, not counted as failed
            return go(self.Phase.APPROACH, event=None)
        if not m.switch and m.at - self.captured_at > CAPTURE_TIME:
            self.device.magnet_off()
            self.failed_captures += 1
            return go(self.Phase.APPROACH, event="capture_failed", gap_estimate=round(m.gap, 4),
                      failed=self.failed_captures)
        if m.switch and self.device.lock():
            return go(self.Phase.LOCKING, t_c=round(self.t_c, 3))
        return Status.RUNNING

    def _step_locking(self, state: TrackingState | None) -> Status | Transition:
        """The levers close on Part B's ring; closed on nothing, they close again while Part B is still seated."""
        m = self.measure(state)
        if not isinstance(m, _Closing):
            return m
        if self.device.locking or self.device.locked:
            return Status.RUNNING
        if not m.switch:  # Part B got away from the face before the levers held it: an external force (§IV-B)
            return self.cancel(f"capture lost: the levers closed on nothing (estimated gap {m.gap:.3f} m)")
        return go(self.Phase.CAPTURE, event="lock_failed", at_once=True, gap_estimate=round(m.gap, 4))

    def measure(self, state: TrackingState | None) -> _Closing | Status | Transition:
        """This tick's reading of the approach (once a tick), or the cancellation when Part B is unseen too long.

        It runs the contact clock t_c and the gust guard.
        """
        if self.measured is not None and self.measured.at == self.now:
            return self.measured
        p = self.params
        now = self.now
        p_B_A = state.p_B_A if state is not None else None
        gap = float(p_B_A[2]) if p_B_A is not None else math.inf
        if state is None or p_B_A is None:
            return self.cancel("no estimate of Part B")
        reason = self.cancel_reason(state, gap)
        if reason is not None:
            return self.cancel(reason)
        lateral = math.hypot(float(p_B_A[0]), float(p_B_A[1]))
        aligned = lateral <= p.align_tolerance
        unsteady, abandoned = self.supervise(now, gap, lateral, state)
        standoff = self.standoff(now, aligned, unsteady)
        settled = abs(gap - self.last_axial) <= SETTLED_SPEED * max(now - self.last_tick, 1e-9)
        self.last_axial, self.last_tick = gap, now
        switch = self.device.contact_switch
        self.measured = _Closing(now, gap, aligned, settled, unsteady, abandoned, switch, standoff)
        return self.measured

    def hold_target(self) -> None:
        """Write this tick's target (the standoff and the sonar cone) for ``track``, and the eq. (15) samples."""
        assert self.measured is not None, "the approach measured this tick"
        p, m = self.params, self.measured
        self.write(self.key, ContactTarget(m.standoff, self.cone))
        self.context.metric("contact_t", self.t_c, robot=self.robot_name)
        self.context.metric("contact_z_C", contact_height(self.z0, self.t_c, p.k_c), robot=self.robot_name)
        self.feedback_message = (
            f"{self.phase.value}: t_c {self.t_c:.1f} s, estimated gap {m.gap:.3f} m (target {m.standoff:.3f} m)"
        )

    def standoff(self, now: float, aligned: bool, unsteady: bool) -> float:
        """The gap (m) Part A leaves below Part B now: eq. (15) on the contact clock t_c, held by the supervision.

        The clock stops while the last ``align_gap`` would be closed on a misaligned Part B, and while the UAV
        is unsteady (then the gap is at least ``guard_gap``).
        """
        p = self.params
        closing = self.s0 - p.k_c * math.log(self.t_c + 1.0) > p.align_gap
        if not unsteady and (aligned or closing):
            self.t_c += now - self.last_t
        self.last_t = now
        rest = max(p.rest_gap - p.capture_step * self.failed_captures, -2.0 * p.capture_step)
        standoff = max(self.s0 - p.k_c * math.log(self.t_c + 1.0), rest)  # eq. (15) as the gap P_RC leaves
        if not aligned:
            standoff = max(standoff, p.align_gap)
        if unsteady:
            standoff = max(standoff, p.guard_gap)
        return standoff

    def supervise(self, now: float, gap: float, lateral: float, state: TrackingState) -> tuple[bool, bool]:
        """The gust guard (:mod:`.gust_guard`): whether Part A must keep ``guard_gap`` below an unsteady UAV, and
        whether it abandoned a capture under way whose contact switch is still open (magnet off; not counted as
        failed, :meth:`_step_capture` goes back to the approach).

        Once the switch closed (Part B seated on the magnet) or the levers close, the guard no longer acts.
        """
        p = self.params
        if p.guard_gap <= 0.0 or self.phase is self.Phase.LOCKING or self.device.contact_switch:
            return False, False
        was = self.guard.unsteady_since is not None
        near = gap <= p.guard_gap + (GUARD_MARGIN if was else 0.0)  # farther down, a shove cannot reach Part A
        speed = float(np.linalg.norm(state.v_M))
        unsteady = self.guard.update(now, lateral if near else 0.0, speed if near else 0.0)
        abandoned = unsteady and not was and self.phase is self.Phase.CAPTURE  # the switch is open (above)
        if abandoned:
            self.device.magnet_off()
        if unsteady and not was:
            self.guard_event("unsteady", why=self.guard.reason, gap_estimate=round(gap, 4))
        elif was and not unsteady:
            self.guard_event("calm", gap_estimate=round(gap, 4))
        return unsteady, abandoned

    def guard_event(self, guard: str, **fields: object) -> None:
        """Record a change of the gust guard: a ``state_change`` event with ``guard`` and no ``phase`` (it stays)."""
        self.context.event(
            "state_change", node=self.name, skill=self.kind, robot=self.robot_name, guard=guard, **fields
        )

    def cancel_reason(self, state: TrackingState, gap: float) -> str | None:
        """Why the approach stops now (marker unseen too long at this ``gap`` in m, no lock in time), else ``None``."""
        p = self.params
        if not state.seen and state.age() > (p.blind_timeout if gap <= p.blind_range else p.lost_timeout):
            return f"marker lost {gap:.2f} m from Part B ({state.age():.1f} s unseen)"
        if self.t0 is not None and self.now - self.t0 > p.timeout:  # t0: set when the approach began
            return f"no lock after {p.timeout:.0f} s of approach"
        return None

    def locked(self, state: TrackingState | None) -> Status:
        """Docked: record the contact time t_c and the docking time (from the start of tracking), succeed."""
        now = self.now
        fields = {"t_c": round(self.t_c, 3) if self.t0 is not None else None}
        if self.t0 is not None:
            self.context.metric("contact_time", now - self.t0, robot=self.robot_name)
        if state is not None:
            fields["docking_time"] = round(now - state.started, 3)
            self.context.metric("docking_time", now - state.started, robot=self.robot_name)
        if state is not None and state.T_M_Q is not None:  # the levers hold Part B at the heading it was caught with
            T_M_A = self.carrier.arm_kinematics.transform(self.carrier.joint_positions(), PART_A_LINK)
            yaw = yaw_of_rotation((invert(T_M_A) @ state.T_M_Q @ part_b_transform(self.robot))[:3, :3])
            self.write(f"{self.params.carrier}/{PART_B_YAW}", yaw)
            fields["part_b_yaw"] = round(yaw, 3)
        phase_event(self, "locked", **fields)
        took = f"tracking → lock {fields['docking_time']:.1f} s" if "docking_time" in fields else ""
        milestone(self, "docked", detail=f"on {self.params.carrier}" + (f", {took}" if took else ""))
        self.feedback_message = f"{self.robot.name} locked on Part A, motors off"
        return Status.SUCCESS

    def cancel(self, why: str) -> Status | Transition:
        """Cancel the contact: magnet off, target withdrawn (the end effector drops), authorization asked again."""
        self.device.magnet_off()
        self.write(self.key, None)
        self.cancellations += 1
        phase_event(self, "contact_cancelled", why=why, cancellations=self.cancellations)
        if self.cancellations > self.params.max_cancellations:
            self.feedback_message = f"contact cancelled {self.cancellations} times: {why}"
            return Status.FAILURE
        return self.request_authorization(why)


class Stored(Condition["Stored.Params"]):
    """Holds while the UAV is locked on its carrier's Part A and no docking or deployment is in progress."""

    class Params(NodeParams):
        carrier: CarrierName = "carrier"
        """Team member whose docking device holds the UAV (a mobile_manipulator)."""

    primary: ClassVar[str] = "carrier"
    robot_kinds = (Rotorcraft,)
    reads = (f"{{carrier}}/{DOCKING_FLAG}",)

    def check(self) -> bool:
        device = carrier_port(self, self.params.carrier).docking
        busy = bool(self.read(f"{self.params.carrier}/{DOCKING_FLAG}", False))
        return device.locked and self.robot.docked and not busy
