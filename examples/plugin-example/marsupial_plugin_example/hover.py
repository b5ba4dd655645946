"""A replacement for marsupial's ``hover`` that also records how far the UAV drifted and how high its sonar reads it.

The skill holds only data (``docs/plugins.md``): each tick it reads the
UAV's readings through its view (``self.robot``: the onboard estimate, the
sonar it declares in ``sensors``) and sends commands as messages, which the
world applies after the tick. The algorithm, :func:`horizontal_drift`, is a
plain function, tested on its own.
"""

from __future__ import annotations

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.skills.generic import Hover
from marsupial.trees.metrics import MetricSpec
from marsupial.trees.skill import NodeParams


def horizontal_drift(anchor: np.ndarray, position: np.ndarray) -> float:
    """Horizontal distance (m) of ``position`` from ``anchor``, both in the UAV's navigation frame."""
    return float(np.linalg.norm(np.asarray(position, dtype=float)[:2] - np.asarray(anchor, dtype=float)[:2]))


class MeteredHover(Hover):
    """Hold a UAV in place like hover, recording its drift (metric hover_drift); fail beyond max_drift.

    The drift is the horizontal distance from where the hover started, as
    the UAV's own estimate sees it; the height above the ground as its sonar
    measures it is recorded beside it (metric ``hover_sonar_range``).
    """

    class Params(NodeParams):
        seconds: float = Field(1.0, ge=0.0)
        """How long to hover (simulated s)."""
        max_drift: float = Field(0.5, gt=0.0)
        """Drift (m) from the start point beyond which the skill fails."""

    writes = ("{robot}/hover_drift",)
    sensors = ("sonar",)  # delivered while the skill runs; reading an undeclared sensor raises an error
    # robot_kinds (Rotorcraft) and claims ("rotors") are Hover's
    metrics = (MetricSpec("hover_drift", "m", "horizontal drift from where the hover began (estimate)", "max"),)

    def start(self) -> None:
        super().start()
        self.anchor = self.robot.estimate().position.copy()

    def step(self) -> Status:
        status = super().step()  # Hover sends hover(): a command message, applied after this tick
        drift = horizontal_drift(self.anchor, self.robot.estimate().position)
        self.write(f"{self.robot_name}/hover_drift", drift)
        self.context.metric("hover_drift", drift, robot=self.robot_name)
        echo = self.robot.sensor("sonar").read()  # None until the first sample is delivered
        if echo is not None:
            self.context.metric("hover_sonar_range", echo.data.range, robot=self.robot_name)
        return Status.FAILURE if drift > self.params.max_drift else status
