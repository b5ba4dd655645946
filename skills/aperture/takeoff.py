"""``scout_takeoff``: the micro-scout's side of the launch (Arora & Papachristos §IV-F): off the apparatus, up.

"The MAV is ready to takeoff based on an appropriately timed command": the
MMS's ``launch_scout`` opens the apparatus's hold; this skill, on the MAV,
waits until the MAV senses it is no longer held (its ``docked`` device
state), restarts its estimate where the MMS knows the cradle's seat to be
(the hand-over, :func:`~.insertion.held_mav_pose`: arm encoders, grasp,
cradle, the MMS's base estimate), starts the motors and climbs ``climb``
metres straight up on its estimate from there, flies ``egress`` metres
forward (body x: the MAV went through nose first, so away from the wall),
then hovers (SUCCESS). The climb takes the MAV clear of the apparatus's 8 mm
lips and of the arm before the arm withdraws (``launch_scout`` waits for it
on the team link).

The egress keeps the MAV's downward range sensor off the wall: hovering a few
centimetres behind the wall's back face, the edge of the Tello's 6° beam meets
the face at the same range whatever the height (0.87 m, measured), its height
filter accepts that echo as the floor, and the autopilot chasing the height
it believes climbed to 3.3 m (seed 4 of ``aperture_scouts`` before the egress).

The hand-over is needed because a MAV's estimate is held while a device holds
it (its zero-velocity update): carried by the arm from the holster to beyond
the aperture, the MAV is 0.4 m higher and 2.5 m further than its estimate at
the release, so far off that its height filter gates every sonar echo out
(measured: without it, the Tello's true height swung between 0.4 and 2.8 m
and one scout left the open-topped corridor over its walls).

What it senses: the MAV's docked state and its state estimate; the MMS's arm encoders and base estimate at the
release (the same hand-over as ``deploy``'s). Metres, seconds, the navigation frame.
"""

from __future__ import annotations

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.api.capabilities import HasArmModel, Rotorcraft
from marsupial.trees.phases import phase_event
from marsupial.trees.skill import NodeParams, Skill

from .insertion import held_mav_pose


class ScoutTakeoff(Skill["ScoutTakeoff.Params"]):
    """Wait for the apparatus to let the MAV go, then climb straight up by ``climb``, fly ``egress`` forward, hover."""

    class Params(NodeParams):
        carrier: str
        """The MMS whose apparatus holds the MAV (its arm and base estimate give the hand-over pose)."""
        climb: float = Field(0.3, gt=0.0, le=3.0)
        """Height (m) to climb above the estimate at the release."""
        speed: float = Field(0.3, gt=0.0, le=1.0)
        """Climb and egress speed (m/s)."""
        egress: float = Field(0.5, ge=0.0, le=3.0)
        """Distance (m) flown forward after the climb, away from the aperture's wall (0: hover where it climbed)."""
        tolerance: float = Field(0.03, gt=0.0)
        """The climb and the egress are done within this much (m) of their ends."""

    robot_kinds = (Rotorcraft,)
    claims = ("rotors",)

    def start(self) -> None:
        self.carrier = self.member(self.params.carrier)
        if not self.carrier.provides(HasArmModel):
            raise ValueError(f"carrier {self.params.carrier!r} of {self.name} has no arm to hand the MAV over")
        self.released_at: np.ndarray | None = None
        self.climbed_at: np.ndarray | None = None

    def step(self) -> Status:
        if self.robot.docked:
            self.feedback_message = "held by the launching apparatus"
            return Status.RUNNING
        if self.released_at is None:
            seat, yaw = held_mav_pose(self.carrier)
            self.robot.reset_estimate(seat, yaw)
            self.released_at = seat
            self.robot.set_motors(True)
            phase_event(self, "released", position=[round(float(x), 3) for x in seat])
        position = self.robot.estimate().position
        if self.climbed_at is None:
            remaining = float(self.released_at[2] + self.params.climb - position[2])
            if remaining > self.params.tolerance:
                self.robot.command_velocity(0.0, 0.0, float(np.clip(2.0 * remaining, 0.05, self.params.speed)))
                self.feedback_message = f"climbing off the apparatus: {remaining:.2f} m to go"
                return Status.RUNNING
            self.climbed_at = position.copy()
        remaining = self.params.egress - float(np.hypot(*(position[:2] - self.climbed_at[:2])))
        if remaining <= self.params.tolerance:
            self.robot.hover()
            self.feedback_message = f"{self.params.climb:.2f} m above the release, {self.params.egress:.2f} m on"
            return Status.SUCCESS
        self.robot.command_velocity(float(np.clip(2.0 * remaining, 0.05, self.params.speed)), 0.0, 0.0)
        self.feedback_message = f"leaving the wall: {remaining:.2f} m to go"
        return Status.RUNNING
