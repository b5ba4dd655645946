"""Rim contacts of a micro-scout insertion (Arora & Papachristos §IV-F), measured on truth for the referee.

"The arm's motion is executed by the joint controllers in the physics, and
contacts are monitored: a rim contact is a failure, recorded." Whatever an
MMS slips through an aperture — its launching apparatuses, the MAVs they
hold (until a MAV flies off: motors on and not held) and its arm, gripper
and camera links — is watched against the scene objects tagged
:data:`RIM_TAG` (the aperture wall and its sills, heads and lobes). Each touch
of one part and one wall object, from its first to its last step in contact,
is one rim contact.

Only the referee uses this (:mod:`.scoring`): no skill can read it. Per
physics step it asks pybullet for the contacts of each wall object once
(``getContactPoints(bodyA=wall)``), a few microseconds when nothing touches.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import pybullet

if TYPE_CHECKING:
    from .world import World

RIM_TAG = "mockup_wall"
"""Scene objects with this tag are the structure the apertures are cut into."""
ARM_PARTS = ("arm_link_", "gripper_base", "finger_", "camera_link", "tcp")
"""Link names (prefixes) of the MMS that reach through an aperture."""


@dataclass(frozen=True)
class RimTouch:
    """The start of one rim contact: what touched which wall object, when and where (world frame, m, s)."""

    carrier: str
    part: str
    wall: str
    t: float
    position: tuple[float, float, float]


class RimContacts:
    """Watches every MMS's insertable parts against the rim objects of the scene; ``on_touch`` at each new touch."""

    def __init__(self, world: World, on_touch: Callable[[RimTouch], None]):
        self.world = world
        self.on_touch = on_touch
        self.walls = {obj.body_id: obj.label for obj in world.scene.tagged(RIM_TAG)}
        self.carriers = [r for r in world.robots.values() if hasattr(r, "apparatuses")]
        self._open: set[tuple[int, int, int]] = set()
        self.count: dict[str, int] = {c.name: 0 for c in self.carriers} if self.walls else {}

    @property
    def active(self) -> bool:
        """Whether there is anything to watch (a rim in the scene and a carrier of apparatuses)."""
        return bool(self.walls and self.carriers)

    def _parts(self) -> dict[int, tuple[str, Any]]:
        """Watched bodies now: body id → (carrier name, part-naming function of the link index)."""
        parts: dict[int, tuple[str, Any]] = {}
        for carrier in self.carriers:
            arm_links = {i: n for n, i in carrier.links.items() if n.startswith(ARM_PARTS)}
            parts[carrier.body_id] = (carrier.name, arm_links.get)
            for apparatus in carrier.apparatuses():
                parts[apparatus.body_id] = (carrier.name, lambda _, name=apparatus.name: name)
                mav = apparatus.mav
                if mav is not None and (apparatus.mav_secured or not getattr(mav, "motors_on", False)):
                    parts[mav.body_id] = (carrier.name, lambda _, name=mav.name: name)
        return parts

    def post_physics(self, dt: float) -> None:
        """Read this step's contacts with the rim; report the touches that began."""
        if not self.active:
            return
        cid = self.world.client_id
        points = [(wall, label, point) for wall, label in self.walls.items()
                  for point in pybullet.getContactPoints(bodyA=wall, physicsClientId=cid)]
        if not points and not self._open:
            return  # nothing touches the rim (the usual step): the watched parts need not be listed
        parts = self._parts()
        touching: dict[tuple[int, int, int], tuple[str, str, str, tuple[float, float, float]]] = {}
        for wall, label, point in points:
            body, link = point[2], point[4]
            if body not in parts:
                continue
            carrier, name_of = parts[body]
            part = name_of(link)
            if part is None:
                continue  # the base or a wheel: driving into the wall is not an insertion contact
            touching[(wall, body, link)] = (carrier, part, label, tuple(point[6]))
        for key in touching.keys() - self._open:
            carrier, part, label, position = touching[key]
            self.count[carrier] += 1
            self.on_touch(RimTouch(carrier, part, label, self.world.now, position))
        self._open = set(touching)
