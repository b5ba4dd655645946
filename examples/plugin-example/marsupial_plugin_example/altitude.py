"""A condition: the robot flies above a height (as its own estimate tells it; no sensor to declare)."""

from __future__ import annotations

from typing import ClassVar

from marsupial.trees.skill import Condition, NodeParams


class AltitudeAbove(Condition["AltitudeAbove.Params"]):
    """Holds while the robot's estimated height is above a value (its onboard estimate, navigation frame)."""

    class Params(NodeParams):
        height: float
        """Height (m, z of the robot's navigation frame) above which the condition holds."""

    primary: ClassVar[str] = "height"

    def check(self) -> bool:
        return float(self.robot.estimate().position[2]) > self.params.height
