"""marsupial.world: the pybullet world of a run — scenes, robots, sensors, energy, disturbances."""

from .errors import UnknownNameError, WorldError
from .world import PHYSICS_HZ, SimClock, World

__all__ = ["PHYSICS_HZ", "SimClock", "UnknownNameError", "World", "WorldError"]
