"""A condition: the robot flies above a height."""

from __future__ import annotations

from typing import ClassVar

from marsupial.trees.skill import Condition, NodeParams


class AltitudeAbove(Condition):
    """Holds while the robot's base is higher than a height above the world origin."""

    class Params(NodeParams):
        height: float
        """Height (m, world z) above which the condition holds."""

    primary: ClassVar[str] = "height"

    def check(self) -> bool:
        return float(self.robot.pose()[0][2]) > self.params.height
