"""Onboard state estimation: what each robot's own computer believes about its motion.

Estimators live on the world side (they are fed by the robot's sensors each
physics step) and are read by skills only through the onboard interface
(:mod:`marsupial.world.onboard`). See :mod:`.base` for the estimate type.
"""

from .base import Estimator, StateEstimate

__all__ = ["Estimator", "StateEstimate"]
