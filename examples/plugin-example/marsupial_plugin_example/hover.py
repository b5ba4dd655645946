"""A replacement for marsupial's ``hover`` that also records how far the UAV drifted."""

from __future__ import annotations

import numpy as np
from py_trees.common import Status
from pydantic import Field

from marsupial.skills.generic import Hover
from marsupial.trees.metrics import MetricSpec
from marsupial.trees.skill import NodeParams


class MeteredHover(Hover):
    """Hold a UAV in place like ``hover``.

    Records its horizontal drift (as its estimate sees it) as the metric ``hover_drift``.
    """

    class Params(NodeParams):
        seconds: float = Field(1.0, ge=0.0)
        """How long to hover (simulated s)."""
        max_drift: float = Field(0.5, gt=0.0)
        """Drift (m) from the start point beyond which the skill fails."""

    writes = ("{robot}/hover_drift",)
    metrics = (MetricSpec("hover_drift", "m", "horizontal drift from where the hover began (estimate)", "max"),)

    def start(self) -> None:
        super().start()
        self._anchor = self.robot.estimate().position[:2].copy()

    def step(self) -> Status:
        status = super().step()
        drift = float(np.linalg.norm(self.robot.estimate().position[:2] - self._anchor))
        self.write(f"{self.robot_name}/hover_drift", drift)
        self.context.metric("hover_drift", drift, robot=self.robot_name)
        return Status.FAILURE if drift > self.params.max_drift else status
