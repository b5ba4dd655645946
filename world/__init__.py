"""marsupial.world: the pybullet world of a run — scenes, robots, sensors, energy, disturbances."""

from .quiet import quiet_fd

with quiet_fd(2):  # pybullet prints its build time on stderr when first imported
    import pybullet  # noqa: F401

from marsupial.api.errors import UnknownNameError, WorldError  # noqa: E402

from .world import PHYSICS_HZ, SimClock, World  # noqa: E402

__all__ = ["PHYSICS_HZ", "SimClock", "UnknownNameError", "World", "WorldError"]
