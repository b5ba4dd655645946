"""Robot kinds of the world, looked up by name (``world.add_robot("bebop2")``)."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, cast

from marsupial.api.errors import UnknownNameError

if TYPE_CHECKING:
    from .base import Robot

# kind -> "module:Class" (modules import lazily: a run loads only what it uses)
ROBOT_KINDS: dict[str, str] = {
    "bebop2": ".quadrotor:Bebop2",
    "ardrone2": ".quadrotor:ArDrone2",
    "tello": ".quadrotor:Tello",
    "summit_xl": ".summit_xl:SummitXL",
    "mobile_manipulator": ".mobile_manipulator:MobileManipulator",
    "child_ugv": ".ugv_docking:ChildUGV",
    "mother_ugv": ".ugv_docking:MotherUGV",
    "mms": ".mms:MMS",
}


def robot_class(kind: str) -> type[Robot]:
    """The Python class implementing robot ``kind``; the error lists the known kinds."""
    try:
        target = ROBOT_KINDS[kind]
    except KeyError:
        raise UnknownNameError("robot", kind, ROBOT_KINDS) from None
    module, _, cls = target.partition(":")
    return cast("type[Robot]", getattr(importlib.import_module(module, __name__), cls))
