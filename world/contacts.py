"""Unintended contacts between bodies: a one-off query and a monitor over a run.

Bodies are named as a mission names them: a robot (its name or the
:class:`~marsupial.world.robots.base.Robot` itself), a scene object (its
label) or a raw pybullet body id. Links are named by the robot's
``links`` map (URDF link names; the base link too), ``"base"`` for other
bodies. A contact touching an *allowed* link on either side is intended
(the UAV touching the docking part ``part_a``) and is left out; every
other contact is reported.

Positions are in the world frame (m); ``normal_on_b`` is the unit contact
normal on body B pointing towards A; ``distance`` is the signed separation
(m, negative when penetrating); ``normal_force`` is the normal force (N)
the solver applied during the last physics step.

With ``margin == 0`` the query reads pybullet's contact manifold of the
last physics step (points closer than :data:`TOUCH_SLOP` count as touching);
with ``margin > 0`` it asks for the closest points within ``margin``
(near misses), which also works right after bodies were teleported.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import pybullet

from marsupial.api.errors import UnknownNameError

if TYPE_CHECKING:
    from .robots.base import Robot
    from .world import World

TOUCH_SLOP = 1e-3  # m: manifold points this close count as touching (resting contacts sit within ±1 mm)


@dataclass(frozen=True)
class Contact:
    """One contact point between body A and body B (world frame, m, N)."""

    body_a: str
    link_a: str
    body_b: str
    link_b: str
    position_on_a: tuple[float, float, float]
    position_on_b: tuple[float, float, float]
    normal_on_b: tuple[float, float, float]
    distance: float
    normal_force: float


@dataclass
class ContactEvent:
    """One unintended touch between a link of A and a link of B, from first to last step in contact.

    ``t_start``/``t_end`` are simulated seconds (``t_end`` is the last step
    still in contact), ``position`` the first contact point on B (m, world),
    ``max_normal_force`` (N) and ``min_distance`` (m) extremes over the touch.
    """

    body_a: str
    link_a: str
    body_b: str
    link_b: str
    t_start: float
    t_end: float
    position: tuple[float, float, float]
    max_normal_force: float
    min_distance: float
    ongoing: bool = True

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready record for logs."""
        return dict(self.__dict__)


@dataclass(frozen=True)
class ResolvedBody:
    """A body named for contact reports: its name, pybullet id and link names by index."""

    name: str
    body_id: int
    link_names: dict[int, str]

    def link_indices(self, names: Iterable[str]) -> frozenset[int]:
        """pybullet link indices of ``names``; the error lists this body's links."""
        by_name = {n: i for i, n in self.link_names.items()}
        indices = set()
        for name in names:
            if name not in by_name:
                raise UnknownNameError(f"{self.name} link", name, by_name)
            indices.add(by_name[name])
        return frozenset(indices)


def resolve_body(world: World, ref: Robot | str | int) -> ResolvedBody:
    """Name, id and link names of a robot (object or name), scene label or pybullet body id.

    Raises :class:`UnknownNameError` listing the robots and scene objects for an unknown name.
    """
    if isinstance(ref, str):
        if ref in world.robots:
            return _robot_body(world.robots[ref])
        if ref in world.scene.objects:
            return _plain_body(world, world.scene.objects[ref].body_id, ref)
        raise UnknownNameError("body name", ref, [*world.robots, *world.scene.objects])
    if isinstance(ref, int):
        for robot in world.robots.values():
            if robot.body_id == ref:
                return _robot_body(robot)
        return _plain_body(world, ref, world.scene.label_of(ref) or f"body_{ref}")
    return _robot_body(ref)


def _robot_body(robot: Robot) -> ResolvedBody:
    return ResolvedBody(robot.name, robot.body_id, {i: n for n, i in robot.links.items()})


def _plain_body(world: World, body_id: int, name: str) -> ResolvedBody:
    cid = world.client_id
    links = {-1: "base"}
    for j in range(pybullet.getNumJoints(body_id, physicsClientId=cid)):
        links[j] = pybullet.getJointInfo(body_id, j, physicsClientId=cid)[12].decode()
    return ResolvedBody(name, body_id, links)


def _points(cid: int, a: int, b: int, margin: float) -> list[tuple]:
    """``(link_a, link_b, pos_a, pos_b, normal_b, distance, force)`` of the points between ``a`` and ``b``."""
    manifold = pybullet.getContactPoints(a, b, physicsClientId=cid)
    if margin <= 0.0:
        return [(p[3], p[4], p[5], p[6], p[7], p[8], p[9]) for p in manifold if p[8] <= TOUCH_SLOP]
    force: dict[tuple[int, int], float] = {}
    for p in manifold:
        force[(p[3], p[4])] = force.get((p[3], p[4]), 0.0) + p[9]
    closest = pybullet.getClosestPoints(a, b, margin, physicsClientId=cid)
    return [(p[3], p[4], p[5], p[6], p[7], p[8], force.get((p[3], p[4]), 0.0)) for p in closest]


def contacts_between(
    world: World,
    a: Robot | str | int,
    b: Robot | str | int,
    allowed_links_a: Iterable[str] = (),
    allowed_links_b: Iterable[str] = (),
    margin: float = 0.0,
) -> list[Contact]:
    """Contacts between bodies ``a`` and ``b`` now, except those touching an allowed link.

    ``margin > 0`` also reports near misses closer than ``margin`` metres.
    Example: ``contacts_between(world, "uav", "carrier", allowed_links_b=["part_a"])``.
    """
    body_a, body_b = resolve_body(world, a), resolve_body(world, b)
    allowed_a, allowed_b = body_a.link_indices(allowed_links_a), body_b.link_indices(allowed_links_b)
    return [
        Contact(
            body_a.name,
            body_a.link_names.get(la, str(la)),
            body_b.name,
            body_b.link_names.get(lb, str(lb)),
            tuple(pa),
            tuple(pb),
            tuple(n),
            float(d),
            float(f),
        )
        for la, lb, pa, pb, n, d, f in _points(world.client_id, body_a.body_id, body_b.body_id, margin)
        if la not in allowed_a and lb not in allowed_b
    ]


class ContactMonitor:
    """An actor recording every unintended contact between ``a`` and ``b`` over a run.

    Add it with ``world.add_actor(monitor)``; after each physics step it
    reads the contacts (same rules as :func:`contacts_between`) and keeps one
    :class:`ContactEvent` per touch of a link pair in :attr:`events` (in the
    order they began). ``on_contact(event)`` is called when a touch begins
    (e.g. to log it).
    """

    def __init__(
        self,
        world: World,
        a: Robot | str | int,
        b: Robot | str | int,
        allowed_links_a: Iterable[str] = (),
        allowed_links_b: Iterable[str] = (),
        margin: float = 0.0,
        on_contact: Callable[[ContactEvent], None] | None = None,
    ):
        self.world = world
        self.body_a = resolve_body(world, a)
        self.body_b = resolve_body(world, b)
        self.allowed_a = self.body_a.link_indices(allowed_links_a)
        self.allowed_b = self.body_b.link_indices(allowed_links_b)
        self.margin = float(margin)
        self.on_contact = on_contact
        self.events: list[ContactEvent] = []
        self._open: dict[tuple[int, int], ContactEvent] = {}

    @property
    def active(self) -> list[ContactEvent]:
        """Touches still going on after the last physics step."""
        return list(self._open.values())

    def pre_physics(self, dt: float) -> None:
        """Nothing to do before the step."""

    def post_physics(self, dt: float) -> None:
        """Update the touches from this step's contacts."""
        points = _points(self.world.client_id, self.body_a.body_id, self.body_b.body_id, self.margin)
        if not points and not self._open:
            return
        now = self.world.now
        seen = set()
        for la, lb, _, pb, _, distance, force in points:
            if la in self.allowed_a or lb in self.allowed_b:
                continue
            key = (la, lb)
            seen.add(key)
            event = self._open.get(key)
            if event is None:
                event = ContactEvent(
                    self.body_a.name,
                    self.body_a.link_names.get(la, str(la)),
                    self.body_b.name,
                    self.body_b.link_names.get(lb, str(lb)),
                    now,
                    now,
                    tuple(pb),
                    force,
                    distance,
                )
                self._open[key] = event
                self.events.append(event)
                if self.on_contact is not None:
                    self.on_contact(event)
            else:
                event.t_end = now
                event.max_normal_force = max(event.max_normal_force, force)
                event.min_distance = min(event.min_distance, distance)
        for key in [k for k in self._open if k not in seen]:
            self._open.pop(key).ongoing = False
