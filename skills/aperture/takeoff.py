"""``scout_takeoff``: the micro-scout's side of the launch (Arora & Papachristos §IV-F): off the apparatus, up.

"The MAV is ready to takeoff based on an appropriately timed command": the
MMS's ``launch_scout`` opens the apparatus's hold; this skill, on the MAV,
waits until the MAV senses it is no longer held (its ``docked`` device
state), starts the motors and climbs ``climb`` metres straight up on its own
estimate from where it was let go, then hovers (SUCCESS). The climb takes the
MAV clear of the apparatus's 8 mm lips and of the arm before the arm
withdraws (``launch_scout`` waits for it on the team link).

What it senses: the MAV's docked state and its state estimate. Metres, seconds, the navigation frame.
"""

from __future__ import annotations

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.trees.skill import NodeParams, Skill
from marsupial.world.capabilities import Rotorcraft

from ..uav_docking.team import phase_event


class ScoutTakeoff(Skill["ScoutTakeoff.Params"]):
    """Wait for the apparatus to let the MAV go, then climb straight up by ``climb`` and hover."""

    class Params(NodeParams):
        climb: float = Field(0.3, gt=0.0, le=3.0)
        """Height (m) to climb above the estimate at the release."""
        speed: float = Field(0.3, gt=0.0, le=1.0)
        """Climb speed (m/s)."""
        tolerance: float = Field(0.03, gt=0.0)
        """The climb is done within this much (m) of its height."""

    robot_kinds = (Rotorcraft,)
    claims = ("rotors",)

    def start(self) -> None:
        self.released_at: np.ndarray | None = None

    def step(self) -> Status:
        if self.robot.docked:
            self.feedback_message = "held by the launching apparatus"
            return Status.RUNNING
        position = self.robot.estimate().position
        if self.released_at is None:
            self.released_at = position.copy()
            self.robot.set_motors(True)
            phase_event(self, "released", position=[round(float(x), 3) for x in position])
        remaining = float(self.released_at[2] + self.params.climb - position[2])
        if remaining <= self.params.tolerance:
            self.robot.hover()
            self.feedback_message = f"{self.params.climb:.2f} m above the release"
            return Status.SUCCESS
        self.robot.command_velocity(0.0, 0.0, float(np.clip(2.0 * remaining, 0.05, self.params.speed)))
        self.feedback_message = f"climbing off the apparatus: {remaining:.2f} m to go"
        return Status.RUNNING
