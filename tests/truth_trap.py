"""A trap for simulator truth read on behalf of decision code (the sensing boundary, at run time).

While the behaviour tree ticks or stops (``Behaviour.tick_once`` /
``Behaviour.stop``), every call to a truth accessor — pybullet's state and
ray queries, and the bodies' pose, velocity, link, contact and gap
accessors — is checked: it is allowed only below a frame that simulates
hardware (a sensor's ``read``/``measure``, a physics-step hook, a function
marked with :func:`marsupial.world.onboard.simulates_hardware`); otherwise
the call is recorded as a violation with the stack that made it. Outside
the tree's tick the world reads truth freely (physics, sensors sampling,
recorder, referee).
"""

from __future__ import annotations

import functools
import sys
import traceback
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType
from typing import Any

import py_trees
import pybullet

import marsupial.world
from marsupial.world.onboard import HARDWARE_CODE
from marsupial.world.robots.base import Robot
from marsupial.world.robots.docking_device import DockingDevice
from marsupial.world.robots.quadrotor import Quadrotor
from marsupial.world.sensors.camera import Camera

WORLD_DIR = Path(marsupial.world.__file__).resolve().parent
SENSORS_DIR = WORLD_DIR / "sensors"
HOOKS = frozenset({"pre_physics", "post_physics", "step"})

#: pybullet functions that read the simulator's state (truth)
PYBULLET_TRUTH = (
    "getBasePositionAndOrientation", "getBaseVelocity", "getLinkState", "getLinkStates", "getJointState",
    "getJointStates", "rayTest", "rayTestBatch", "getClosestPoints", "getContactPoints", "getAABB",
    "getOverlappingObjects", "getCameraImage",
)
#: (class, method) pairs that return truth
METHOD_TRUTH: tuple[tuple[type, str], ...] = (
    (Robot, "pose"), (Robot, "velocity"), (Robot, "link_pose"), (Robot, "mounted_frame"),
    (Quadrotor, "acceleration"), (Camera, "optical_pose"),
    (DockingDevice, "distance_to"), (DockingDevice, "offset_to"), (DockingDevice, "part_a_pose"),
    (DockingDevice, "part_b_pose"), (DockingDevice, "aligned"), (DockingDevice, "in_contact"),
)


@dataclass
class Trap:
    """State of an installed trap: tree-tick depth and the violations seen."""

    depth: int = 0
    violations: list[str] = field(default_factory=list)

    def allowed(self, frame: FrameType | None) -> bool:
        """Whether a hardware-simulating frame lies between this truth read and the decision code above it."""
        while frame is not None:
            code = frame.f_code
            if code in HARDWARE_CODE:
                return True
            path = Path(code.co_filename)
            if code.co_name in HOOKS and WORLD_DIR in path.parents:
                return True
            if code.co_name in ("read", "measure") and SENSORS_DIR in path.parents:
                return True
            frame = frame.f_back
        return False

    def check(self, what: str) -> None:
        """Record a violation if ``what`` is read during a tree tick without a hardware frame above it."""
        if self.depth and not self.allowed(sys._getframe(2)):
            stack = "".join(traceback.format_stack(sys._getframe(2), limit=8))
            self.violations.append(f"{what} read by decision code:\n{stack}")


def _guarded(trap: Trap, what: str, function: Callable[..., Any]) -> Callable[..., Any]:
    @functools.wraps(function)
    def guarded(*args: Any, **kwargs: Any) -> Any:
        trap.check(what)
        return function(*args, **kwargs)

    return guarded


def _counting(trap: Trap, function: Callable[..., Any]) -> Callable[..., Any]:
    @functools.wraps(function)
    def counting(*args: Any, **kwargs: Any) -> Any:
        trap.depth += 1
        try:
            return function(*args, **kwargs)
        finally:
            trap.depth -= 1

    return counting


@contextmanager
def truth_trap() -> Iterator[Trap]:
    """Install the trap for the ``with`` block; yields it (``trap.violations`` lists what was caught)."""
    trap = Trap()
    saved: list[tuple[Any, str, Any]] = []

    def patch(owner: Any, name: str, replacement: Any) -> None:
        saved.append((owner, name, owner.__dict__[name] if isinstance(owner, type) else getattr(owner, name)))
        setattr(owner, name, replacement)

    try:
        for name in PYBULLET_TRUTH:
            patch(pybullet, name, _guarded(trap, f"pybullet.{name}", getattr(pybullet, name)))
        for cls, name in METHOD_TRUTH:
            patch(cls, name, _guarded(trap, f"{cls.__name__}.{name}", cls.__dict__[name]))
        behaviour = py_trees.behaviour.Behaviour
        for name in ("tick_once", "stop"):
            patch(behaviour, name, _counting(trap, behaviour.__dict__[name]))
        yield trap
    finally:
        for owner, name, original in reversed(saved):
            setattr(owner, name, original)
