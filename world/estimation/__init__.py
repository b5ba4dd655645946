"""Onboard state estimation: what each robot's own computer believes about its motion.

Estimators live on the world side (their robot feeds them its sensors) and
are read by skills only through the onboard interface
(:mod:`marsupial.api.views`). :mod:`.base` has the estimate type,
:mod:`.flight` the quadrotors' IMU + optical-flow + sonar + barometer
estimator, :mod:`.external` the external vision fixes it fuses (a team
member's camera measuring the UAV, over the team link), :mod:`.ground`
wheel odometry and map localisation.
"""

from marsupial.api.readings import StateEstimate

from .base import Estimator

__all__ = ["Estimator", "StateEstimate"]
